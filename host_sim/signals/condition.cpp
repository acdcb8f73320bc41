#include "condition.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "signals/alignment.hpp"
#include "signals/held_values.hpp"

namespace feedid::host {
namespace {

/// Encoder quantum: the smallest position step, if the steps are (nearly
/// all) integer multiples of it; 0 for an unquantised or resampled position.
/// The smallest step carries the rounding of the two positions it joins:
/// EMPS's positions moved by 1e-13 relative (a parser that does not round
/// correctly) moved it by 5e-7, a step of 2000 counts then missed the
/// lattice by 1e-3 and the quantum was lost (the band edge fell sixfold).
/// So the lattice is checked against the spacing refined over every step of
/// a few counts; the quantum returned stays the smallest step.
double position_quantum(const std::vector<double>& x) {
  double q = 0.0;
  const double scale = 1e-12 * std::max(1.0, quantile_abs(x, 1.0));
  for (std::size_t k = 1; k < x.size(); ++k) {
    const double d = std::fabs(x[k] - x[k - 1]);
    if (d > scale && (q == 0.0 || d < q)) q = d;
  }
  if (q == 0.0) return 0.0;
  double dn = 0.0, nn = 0.0;  // least squares of |step| = n q over steps of 1-8 counts
  for (std::size_t k = 1; k < x.size(); ++k) {
    const double d = std::fabs(x[k] - x[k - 1]), n = std::round(d / q);
    if (n >= 1.0 && n <= 8.0 && std::fabs(d / q - n) < 0.05) { dn += d * n; nn += n * n; }
  }
  const double spacing = dn / nn;
  std::size_t on_grid = 0, n = 0;
  for (std::size_t k = 1; k < x.size(); k += 7) {
    const double r = (x[k] - x[k - 1]) / spacing;
    ++n;
    if (std::fabs(r - std::round(r)) < 1e-3) ++on_grid;
  }
  return n > 0 && on_grid >= 0.9 * static_cast<double>(n) ? q : 0.0;
}

/// Position and velocity columns updated every few rows only (a motor
/// controller's status frame in a faster loop) spread linearly between
/// their updates, so that no derivative sees the sawtooth of the holds. A
/// position counts as held only on changes of more than three encoder
/// quanta, where a slow axis cannot hold its count by itself.
void spread_held_columns(const Trace& trace, bool spread_them, Signals& s) {
  auto hold_of = [&](std::vector<double>& y, double min_change) {
    const HoldPattern h = detect_hold(y, min_change);
    if (spread_them && h.period_rows >= 2) spread_held_values(y, s.t, h.period_rows + 1, s.max_step_s());
    return h.period_rows;
  };
  if (trace.has_position) s.position_hold_rows = hold_of(s.x, 3.0 * s.position_quantum_m);
  if (trace.has_velocity) s.velocity_hold_rows = hold_of(s.v, 0.0);
  s.held_values_spread = spread_them && (s.position_hold_rows > 1 || s.velocity_hold_rows > 1);
  if (s.position_hold_rows > 1)
    s.position_origin = "measured, each value held for " + std::to_string(s.position_hold_rows) +
                        " rows (updated at 1/" + std::to_string(s.position_hold_rows) + " of the log rate)" +
                        (spread_them ? ": spread linearly between its updates" : "");
}

/// A velocity-only log: its quantisation and the drive's filter hide in
/// the samples (a low-pass leaves no lattice to read the encoder quantum
/// from, so the chatter at rest split sections and R^2 fell to 0.06 on a
/// 100 nm, 8 kHz log). Integrated, it is the position seen through the
/// drive's filter, and goes the way of a logged position; identify's force
/// lag search takes up the filter's delay.
void integrate_velocity_column(Signals& s) {
  s.x = integrate_velocity(s.v, s.t, s.max_step_s());
  s.position_origin = "integrated from the velocity column (none logged): relative to the start";
  // A position difference integrates back onto the encoder's lattice; a
  // filtered column does not, and its sample noise stands in for the
  // quantum (too low by the filter's noise gain, but on the right side of
  // a band edge that the derived velocity would put at 1e-4 of top speed).
  s.position_quantum_m = position_quantum(s.x);
  s.column_velocity_noise_m_s = velocity_noise(s.v, s.t, s.period_s());
}

/// The force multiplied by the sign stated, or found from its work on the
/// motion (force_sign.hpp): a reversed force would identify as a negative
/// mass and negative friction, and be predicted the wrong way round.
void orient_force(Signals& s, int stated_sign) {
  s.force_sign = stated_sign != 0 ? stated_force_sign(stated_sign) : find_force_sign(s.t, s.x, s.u, s.max_step_s());
  if (s.force_sign.sign < 0)
    for (double& u : s.u) u = -u;
}

/// Whether the velocity column can stand beside the position: a column
/// in another unit (rpm beside rad, mm/s beside m), of the other sign, or
/// on the motor side of a gear is some gain times the position's
/// derivative, and taken as it is it wrecked the diagnosis (an effect-free
/// trace came out `unexplained` at 26 times the noise floor with the sign
/// reversed). Such a column is left out, as if not logged; a given column
/// (ConditionOptions::velocity_column_given) is the caller's.
void check_velocity_column(Signals& s, const Trace& trace, bool given) {
  s.has_velocity_column = trace.has_velocity;
  if (!trace.has_velocity || !trace.has_position || given) return;
  s.velocity_column_gain = velocity_column_gain(s);
  s.has_velocity_column = velocity_column_agrees(s.velocity_column_gain);
}

/// Roughness the clock's slots must at least halve before they replace the stamps.
constexpr double kClearlySmoother = 0.5;

/// Sum of squared divided differences of y of the given order (2 for a
/// position, 1 for a velocity) over t: how rough the motion looks on that
/// time base.
double roughness(const std::vector<double>& y, const std::vector<double>& t, int order) {
  std::vector<double> d = y, tt = t;
  for (int o = 0; o < order; ++o) {
    std::vector<double> next, tn;
    for (std::size_t k = 1; k < d.size(); ++k) {
      next.push_back((d[k] - d[k - 1]) / (tt[k] - tt[k - 1]));
      tn.push_back(0.5 * (tt[k] + tt[k - 1]));
    }
    d.swap(next);
    tt.swap(tn);
  }
  double sum = 0.0;
  for (double e : d) sum += e * e;
  return sum;
}

/// Stamps of one stretch taken to the slots of the clock the log was
/// sampled on: each step counted in median steps (so the count does not
/// drift with a clock slightly off the median), and the clock's phase and
/// period fitted to all stamps by least squares. Empty where a step rounds
/// to no slot (the log was not taken on such a clock).
std::vector<double> clock_slots(const std::vector<double>& t) {
  const double h = median_step(t);
  if (!(h > 0)) return {};
  std::vector<double> slot(t.size(), 0.0);
  for (std::size_t k = 1; k < t.size(); ++k) {
    const double steps = std::round((t[k] - t[k - 1]) / h);
    if (steps < 1.0) return {};
    slot[k] = slot[k - 1] + steps;
  }
  const double n = static_cast<double>(t.size());
  double mean_slot = 0.0, mean_t = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) { mean_slot += slot[k] / n; mean_t += t[k] / n; }
  double sxy = 0.0, sxx = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    sxy += (slot[k] - mean_slot) * (t[k] - mean_t);
    sxx += (slot[k] - mean_slot) * (slot[k] - mean_slot);
  }
  const double period = sxy / sxx;
  for (double& x : slot) x = mean_t + (x - mean_slot) * period;
  return slot;
}

/// A logger that samples on a fixed clock but stamps rows late by a varying
/// delay (a PC reading a drive's buffer) gives uneven stamps for even
/// samples; differentiated on those stamps, the position gets a velocity
/// error of v times the stamp error over a period (validate's EMPS
/// cross-test went from 4.9 % to 13 % with +-0.2 ms on 1 ms). A logger that
/// samples when it reads gives uneven stamps that are right. The motion
/// tells them apart: a mass cannot move rougher than its drive's force
/// allows at the scale of a period, so where the stamps taken to the
/// clock's slots (clock_slots) make the position (or a velocity-only log's
/// velocity) smoother than the stamps as logged, the slots are its times.
/// The slots must be clearly smoother (kClearlySmoother): on EMPS with
/// +-0.2 ms jitter they cut the roughness to 3e-4 of the stamps', while on
/// the SysId logs (a robot loop stamping CAN status frames) either base is
/// within 2 % of the other, the data cannot tell, and the stamps stay as
/// logged (taking them to slots there moved the roller's friction law and
/// flagged the drivetrains' mass). Rows dropped on a clock keep their slots
/// either way. Returns the stretches put on the slots.
std::size_t regularise_stamps(const Trace& trace, Signals& s) {
  const std::vector<double>& y = trace.has_position ? s.x : s.v;
  const int order = trace.has_position ? 2 : 1;
  for (const auto& [first, end] : stretches(s)) {
    const auto from = static_cast<std::ptrdiff_t>(first), to = static_cast<std::ptrdiff_t>(end);
    const std::vector<double> t(s.t.begin() + from, s.t.begin() + to), ys(y.begin() + from, y.begin() + to);
    if (evenly_stamped(t, 1.0 / median_step(t))) continue;
    const std::vector<double> slot = clock_slots(t);
    if (slot.empty() || !(roughness(ys, slot, order) < kClearlySmoother * roughness(ys, t, order))) continue;
    std::copy(slot.begin(), slot.end(), s.t.begin() + from);
    ++s.stretches_on_clock_slots;
  }
  return s.stretches_on_clock_slots;
}

}  // namespace

double quantile_abs(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  for (double& x : v) x = std::fabs(x);
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

double velocity_noise(const std::vector<double>& v, const std::vector<double>& t, double dt) {
  double d2 = 0.0;
  std::size_t nd = 0;
  for (std::size_t k = 2; k < v.size(); ++k) {
    if (t[k] - t[k - 1] > 1.5 * dt || t[k - 1] - t[k - 2] > 1.5 * dt) continue;
    const double e = v[k] - 2.0 * v[k - 1] + v[k - 2];
    d2 += e * e;
    ++nd;
  }
  return nd > 0 ? std::sqrt(d2 / (6.0 * static_cast<double>(nd))) : 0.0;
}

Signals select_samples(const Signals& s, const std::vector<char>& keep) {
  Signals kept = s;  // conventions and provenance; the columns compacted in place
  std::size_t j = 0;
  for (std::size_t k = 0; k < s.t.size(); ++k) {
    if (k >= keep.size() || !keep[k]) continue;
    kept.t[j] = s.t[k];
    kept.x[j] = s.x[k];
    kept.v[j] = s.v[k];
    kept.u[j] = s.u[k];
    for (std::size_t i = 0; i < s.rival_velocities.size(); ++i) kept.rival_velocities[i][j] = s.rival_velocities[i][k];
    ++j;
  }
  for (std::vector<double>* column : {&kept.t, &kept.x, &kept.v, &kept.u}) column->resize(j);
  for (std::vector<double>& column : kept.rival_velocities) column.resize(j);
  return kept;
}

std::vector<std::pair<std::size_t, std::size_t>> stretches(const Signals& s) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t a = 0; a < s.t.size();) {
    std::size_t b = a + 1;
    while (b < s.t.size() && !s.gap_before(b)) ++b;
    out.emplace_back(a, b);
    a = b;
  }
  return out;
}

namespace {
/// A time column read as seconds for want of a stated unit, whose median
/// step is slower than any drive logs: a time in ms taken as s made the
/// mass 10^6 too large and said ok (issue 31). Why, or empty.
std::string slow_unstated_time(const Trace& trace, double median_step_s) {
  if (trace.time_unit_stated || median_step_s <= kSlowestUnstatedStep_s) return "";
  char buf[320];
  std::snprintf(buf, sizeof buf,
                ": the time column steps by a median of %.4g, read as seconds (%.3g Hz), slower than a drive logs: "
                "if it is in ms give --time-scale 0.001 (or name the column t_ms); if it is in s, --time-scale 1",
                median_step_s, 1.0 / median_step_s);
  return trace.source + buf;
}
}  // namespace

std::string log_refusal(const Trace& trace) {
  std::vector<double> t(trace.samples.size());
  for (std::size_t k = 0; k < t.size(); ++k) t[k] = trace.samples[k].t_s;
  const double dt = median_step(t);
  return dt > 0 ? slow_unstated_time(trace, dt) : std::string();
}

Signals condition(const Trace& trace, const ConditionOptions& opt) {
  Signals s;
  const std::size_t n = trace.samples.size();
  s.t.resize(n); s.x.resize(n); s.v.resize(n); s.u.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    s.t[k] = trace.samples[k].t_s;
    s.x[k] = trace.samples[k].x_m;
    s.v[k] = trace.samples[k].v_m_s;
    s.u[k] = trace.samples[k].u_N;
  }
  const double dt = median_step(s.t);
  // Readers reject non-increasing time, so only a trace of fewer than two
  // samples gets here without a rate; nothing downstream can use it.
  if (!(dt > 0)) s.error = trace.source + ": fewer than two samples, no sample rate to work with";
  else if (!trace.has_velocity && !trace.has_position) s.error = trace.source + ": neither velocity nor position column";
  else s.error = slow_unstated_time(trace, dt);
  if (!s.error.empty()) return s;
  s.sample_rate_hz = 1.0 / dt;
  s.has_position = trace.has_position;
  if (regularise_stamps(trace, s) > 0) s.sample_rate_hz = 1.0 / median_step(s.t);  // the clock's, not the jitter's
  if (trace.has_position) s.position_wrap = unwrap_position(s.t, s.x, s.max_step_s());
  s.position_quantum_m = trace.has_position ? position_quantum(s.x) : 0.0;  // of the lattice as logged
  spread_held_columns(trace, opt.spread_held_values, s);
  if (s.position_wrap.found()) s.position_origin += ", " + s.position_wrap.describe();
  if (!trace.has_position) integrate_velocity_column(s);
  check_velocity_column(s, trace, opt.velocity_column_given);
  orient_force(s, opt.force_sign);
  return s;
}

}  // namespace feedid::host
