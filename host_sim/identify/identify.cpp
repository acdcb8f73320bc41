#include "identify.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "timing_search.hpp"
#include "gravity.hpp"
#include "signals/filters.hpp"
#include "io/number_format.hpp"
#include "uncertainty.hpp"

namespace feedid::host {
namespace {

/// The lag a named --alignment states (sample periods); NaN for "auto"
/// (and for a name alignment_refusal refuses).
double named_lag(const std::string& name) {
  if (name == "held-backward") return feedid::force_lag_of<double>(feedid::ForceAlignment::held_force_backward_velocity);
  if (name == "held-instant") return feedid::force_lag_of<double>(feedid::ForceAlignment::held_force_instant_velocity);
  if (name == "trapezoid") return feedid::force_lag_of<double>(feedid::ForceAlignment::trapezoid);
  return std::numeric_limits<double>::quiet_NaN();
}

/// Why --alignment names no alignment, or empty.
std::string alignment_refusal(const std::string& name) {
  if (name == "auto" || std::isfinite(named_lag(name))) return "";
  return "--alignment must be auto, held-backward, held-instant or trapezoid, not '" + name + "'";
}

/// The lag nearest `lag` whose force delay (lag + the velocity's own lag,
/// none when unknown: the core's velocity is a zero-phase derivative) a logging convention
/// explains; what is cut off is kept in s.lag_beyond_conventions.
double keep_within_conventions(Signals& s, double lag, double velocity_lag) {
  const double v_lag = std::isfinite(velocity_lag) ? velocity_lag : 0.0;
  const double limit = convention_force_delay_limit();
  const double kept = std::clamp(lag + v_lag, -limit, limit) - v_lag;
  s.lag_beyond_conventions = lag - kept;
  return kept;
}

/// How align_force finds a lag it is not told. `found`: a search already
/// run on these signals with another velocity cut-off (a zero-phase filter
/// moves no timing), taken instead of a new one. `held`: the friction
/// shared between lag searches (estimate_force_lag). `cfg`: the
/// configuration a new search measures with, where the caller has it
/// already; none: auto_config of the signals.
struct LagSearch {
  const LagEstimate* found = nullptr;
  HeldFriction* held = nullptr;
  const feedid::Config<double>* cfg = nullptr;
};

/// Finds (or takes from the options) the force lag and applies it.
/// velocity_lag: the core velocity's lag behind the motion (periods, NaN
/// unknown); column_lag: the logged velocity column's lag behind the core's
/// velocity, in which stated lags are given and the lag is reported.
/// `search`: how a lag not stated is found (LagSearch).
/// s.error where the lag lies beyond any logging's.
void align_force(Signals& s, const IdentifyOptions& opt, double velocity_lag, double column_lag,
                 const LagSearch& search = {}) {
  const double dt = s.period_s();
  double lag = named_lag(opt.alignment) + column_lag, se = 0.0;
  s.force_lag_origin = Signals::LagOrigin::convention;
  auto found_or_searched = [&] {
    return search.found ? *search.found : estimate_force_lag(s, search.cfg ? *search.cfg : auto_config(s, opt), search.held);
  };
  // A lag the user stated, searched beside before it moves the motion (identify_warnings).
  auto search_beside_stated = [&] {
    const LagEstimate e = found_or_searched();
    s.lag_search = e;
    if (e.ok) s.searched_force_lag = {(e.lag_samples - column_lag) * dt, e.se_samples * dt, at_range_end(e), e.absorbed_by_refit};
  };
  if (std::isfinite(opt.force_lag_s)) {
    lag = opt.force_lag_s / dt + column_lag;
    se = opt.force_lag_se_s > 0 ? opt.force_lag_se_s / dt : 0.0;
    s.force_lag_origin = Signals::LagOrigin::option;
    if (opt.check_stated_lag) search_beside_stated();
  } else if (std::isfinite(lag)) {  // a named --alignment
    if (opt.check_stated_lag) search_beside_stated();
  } else {
    const LagEstimate e = found_or_searched();
    s.lag_search = e;
    if (e.ok) {
      lag = e.lag_samples;
      se = e.se_samples;
      s.force_lag_origin = Signals::LagOrigin::estimated;
      if (opt.lag_within_conventions) lag = keep_within_conventions(s, lag, velocity_lag);
    } else {
      lag = -0.5 - (std::isfinite(velocity_lag) ? velocity_lag : 0.0);  // a held command, the commonest log
      s.force_lag_origin = Signals::LagOrigin::assumed;
    }
  }
  // The core pairs a force up to max_lead periods ahead of the velocity;
  // a later one moves the motion by whole samples (apply_force_lag).
  const double earliest = -static_cast<double>(feedid::ForcePairing<double>::max_lead), latest = kForceLagMax + 1.0;
  if (!(lag >= earliest && lag <= latest)) {
    char buf[360];
    std::snprintf(buf, sizeof buf,
                  "a force lag of %.4g ms (%.3g sample periods behind the velocity the core pairs with) is beyond what "
                  "the pairing reaches at %.6g Hz: %.4g to %.4g ms behind the logged velocity",
                  1e3 * (lag - column_lag) * dt, lag, 1.0 / dt, 1e3 * (earliest - column_lag) * dt,
                  1e3 * (latest - column_lag) * dt);
    s.error = buf;
    return;
  }
  apply_force_lag(s, lag);
  s.force_lag_s = (lag - column_lag) * dt;
  s.force_lag_se_s = se * dt;
  s.force_convention = std::isfinite(velocity_lag) ? nearest_force_convention(lag, velocity_lag)
                                                   : "unknown (no position column to time the velocity by)";
}


nlohmann::json direction_json(const feedid::DirectionEstimate<double>& d) {
  const bool st = d.stribeck_identified();
  return {
      {"sigma", d.viscous_Ns_m}, {"fc", d.coulomb_N}, {"fs", d.breakaway_N}, {"vs", d.stribeck_velocity_m_s},
      {"sigma_se", d.viscous_se}, {"fc_se", d.coulomb_se}, {"fs_se", d.breakaway_se}, {"vs_se", d.stribeck_velocity_se},
      {"identifiable", {{"sigma", d.viscous_identified()}, {"fc", d.coulomb_identified()}, {"fs", st}, {"vs", st}}},
      {"flags", flag_names(d.flags)},
      {"sections", d.sections}, {"bands_used", d.bands_used}, {"time_in_bands_s", d.time_in_bands_s},
      {"friction_r2", d.friction_r2}, {"friction_rms_N", d.friction_rms_N},
  };
}

}  // namespace

ForceAges force_ages(const std::vector<double>& u, std::size_t k, std::size_t first, std::size_t last) {
  ForceAges a;
  constexpr auto lead = static_cast<std::size_t>(kForceLead);
  // interval_force_in_chain's rule: taps from before the chain take its
  // first force; likewise after it, its last.
  const std::size_t oldest = k - first, newest = last - k;
  for (std::size_t i = 0; i < a.size(); ++i)
    a[i] = i < lead ? u[k + std::min(lead - i, newest)] : u[k - std::min(i - lead, oldest)];
  return a;
}

double paired_force(const std::vector<double>& u, const feedid::ForcePairing<double>& p, std::size_t k,
                    std::size_t first) {
  // force_ages' rule for the ages a pairing taps (0 and older), without the other taps.
  const std::size_t oldest = k - first;
  return p.interval_force([&](int age) { return u[k - std::min(static_cast<std::size_t>(age), oldest)]; });
}

namespace {
/// What a block integrates over an interval: the friction model, and the
/// logged force at each age the pairing rule can tap (the chain's first
/// force for taps before it). The rule is linear in its taps
/// (force_pairing.hpp), so the integral of u - F(v) at any pairing is a
/// combination of these, and one pass serves every lag of a search.
struct Integrands {
  double friction = 0.0;  ///< F(v) (N)
  ForceAges force{};      ///< u at age 0, 1, ... (N)
  Integrands& add(const Integrands& o, double w) {
    friction += w * o.friction;
    for (std::size_t i = 0; i < force.size(); ++i) force[i] += w * o.force[i];
    return *this;
  }
};

/// The same at one pairing: the paired force alone, three taps per sample
/// instead of eleven integrals (the scan's and the refits' observations).
struct PairedIntegrands {
  double friction = 0.0;  ///< F(v) (N)
  double force = 0.0;     ///< the paired force (N)
  PairedIntegrands& add(const PairedIntegrands& o, double w) {
    friction += w * o.friction;
    force += w * o.force;
    return *this;
  }
};

/// One block's sums; phi = (t - t_start)/tau rises from 0 to 1 across it.
template <typename I>
struct BlockSums {
  int dir = 0;
  double tau = 0.0;           ///< s
  I impulse;                  ///< integrals over the block (N s)
  I phi_impulse;              ///< same, weighted by phi
  double dv = 0.0;            ///< velocity change (m/s)
  double phi_dv = 0.0;        ///< same, weighted by phi
};

/// The one block rule: blocks of block_s within a direction (above v_min),
/// and observations from adjacent pairs under a triangular weight w rising
/// over the first block and falling over the second. visit(integrals, dv,
/// area, k_end) gets, for the pair ending at sample k_end, the weighted integrals of F(v) and of the force taps
/// (N s) and of dv (m/s) and the weight's area (s). Under w the velocity change sums by
/// parts to the difference of the two blocks' mean velocities, so no raw
/// velocity sample carries it: with raw block-end samples, m times the
/// velocity's noise (a quantum of 0.8 mm/s at 8 kHz and 100 nm) dominated
/// the residual, a lag search on it preferred whatever lag attenuated the
/// mass, and a mass fitted on the blocks was attenuated. Smoothing the end
/// samples instead biased m by +0.1 % per half-millisecond of mean at the
/// motion's corners; the triangle is exact. (docs/diagnosis.md uses the
/// same observation.) I: Integrands or PairedIntegrands; force_of(k,
/// first, last) its force at sample k of a stretch from `first` whose
/// force taps may reach `last`.
template <typename I, typename ForceOf, typename Visit>
void for_each_block(const Signals& s, const DriveParams& p, double v_min, double block_s, ForceOf force_of,
                    Visit visit) {
  using Sums = BlockSums<I>;
  Sums prev, cur;
  I moment_impulse, g;
  double t_start = 0.0, moment_dv = 0.0;
  const auto full = s.reached_at(block_s), half = s.reached_at(0.5 * block_s);
  auto close = [&](std::size_t k_end, bool adjacent_next) {
    if (cur.dir != 0 && half.by(cur.tau)) {
      cur.phi_impulse = I{}.add(moment_impulse, 1.0 / cur.tau);
      cur.phi_dv = moment_dv / cur.tau;
      if (prev.dir == cur.dir)
        visit(I{prev.phi_impulse}.add(cur.impulse, 1.0).add(cur.phi_impulse, -1.0),
              prev.phi_dv + cur.dv - cur.phi_dv, 0.5 * (prev.tau + cur.tau), k_end);
      prev = adjacent_next ? cur : Sums{};
    } else {
      prev = Sums{};
    }
    cur = Sums{};
    moment_impulse = I{};
    moment_dv = 0.0;
  };
  // The stretch around k, tracked as k advances rather than searched for
  // at every sample (Signals::stretch_start and the lead's reach): the
  // same first and last samples, in one pass.
  const std::size_t n = s.t.size();
  const double max_step = s.max_step_s();
  auto gap_before = [&](std::size_t k) { return s.t[k] - s.t[k - 1] > max_step; };
  std::size_t stretch_first = 0, stretch_last = 0;
  constexpr auto reach = static_cast<std::size_t>(feedid::ForcePairing<double>::history);
  for (std::size_t k = 1; k < n; ++k) {
    const double dt = s.t[k] - s.t[k - 1];
    if (gap_before(k)) {  // another run or a cut: no block, no pair, no force tap spans it
      if (cur.dir != 0) close(k - 1, false);
      prev = Sums{};
      stretch_first = k;
      continue;
    }
    if (k > stretch_last)
      for (stretch_last = k; stretch_last + 1 < n && !gap_before(stretch_last + 1);) ++stretch_last;
    const double vm = 0.5 * (s.v[k] + s.v[k - 1]);
    const int d = std::fabs(vm) < v_min ? 0 : (vm > 0 ? 1 : -1);
    if (cur.dir != 0 && d != cur.dir) close(k - 1, false);
    if (d == 0) continue;
    if (cur.dir == 0) { cur.dir = d; t_start = s.t[k - 1]; }
    g.friction = stribeck_friction(p, vm);
    const std::size_t last = std::min(stretch_last, k + static_cast<std::size_t>(kForceLead));
    g.force = force_of(k, std::max(stretch_first, k > reach ? k - reach : 0), last);
    const double dv = s.v[k] - s.v[k - 1];
    const double age = 0.5 * (s.t[k] + s.t[k - 1]) - t_start;
    cur.impulse.add(g, dt);
    cur.dv += dv;
    moment_impulse.add(g, age * dt);
    moment_dv += age * dv;
    cur.tau += dt;
    if (full.by(cur.tau)) close(k, true);
  }
  if (cur.dir != 0) close(n - 1, false);  // the last block, as at a gap
}
}  // namespace

double BlockPair::impulse(const feedid::ForcePairing<double>& p, int lead) const {
  return p.interval_force([this, lead](int age) { return force[static_cast<std::size_t>(age - lead + kForceLead)]; }) -
         friction;
}

namespace {
/// Room for the blocks of s: its span over the block length, but never more
/// than its samples (one row stamped years ahead made the span's count a
/// hundred billion, and identify died of bad_alloc).
std::size_t block_capacity(const Signals& s, double block_s) {
  if (s.t.empty() || !(block_s > 0)) return 1;
  const double by_time = (s.t.back() - s.t.front()) / block_s;
  return static_cast<std::size_t>(std::min(by_time, static_cast<double>(s.t.size()))) + 1;
}
}  // namespace

std::vector<BlockPair> block_pairs(const Signals& s, const DriveParams& p, double v_min, double block_s) {
  std::vector<BlockPair> out;
  out.reserve(block_capacity(s, block_s));
  auto taps = [&s](std::size_t k, std::size_t first, std::size_t last) { return force_ages(s.u, k, first, last); };
  for_each_block<Integrands>(s, p, v_min, block_s, taps, [&](const Integrands& w, double dv, double area, std::size_t k_end) {
    out.push_back({w.friction, w.force, dv, area, chunk_of(k_end, s.t.size())});
  });
  return out;
}

std::vector<PairedBlock> paired_blocks(const Signals& s, const DriveParams& p, double v_min, double block_s) {
  std::vector<PairedBlock> out;
  out.reserve(block_capacity(s, block_s));
  const feedid::ForcePairing<double> pairing = s.pairing();
  // BlockPair::impulse at lead 0 taps ages 0 and older only, so `last` plays no part.
  auto paired = [&](std::size_t k, std::size_t first, std::size_t) { return paired_force(s.u, pairing, k, first); };
  for_each_block<PairedIntegrands>(s, p, v_min, block_s, paired,
                                   [&](const PairedIntegrands& w, double dv, double area, std::size_t k_end) {
                                     out.push_back({w.force - w.friction, dv, area, chunk_of(k_end, s.t.size())});
                                   });
  return out;
}

std::vector<PairedBlock> at_pairing(const std::vector<BlockPair>& pairs, const feedid::ForcePairing<double>& pairing,
                                    int lead) {
  std::vector<PairedBlock> out;
  out.reserve(pairs.size());
  for (const BlockPair& b : pairs) out.push_back({b.impulse(pairing, lead), b.dv, b.area, b.chunk});
  return out;
}

int chunk_of(std::size_t k, std::size_t n) {
  // The last chunk whose first sample is at or before k.
  int c = 0;
  while (c + 1 < kJackknifeChunks && chunk_begin(c + 1, n) <= k) ++c;
  return c;
}

double jackknife_se(const std::vector<double>& leave_one_out) {
  if (leave_one_out.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  const double g = static_cast<double>(leave_one_out.size());
  double mean = 0.0, ss = 0.0;
  for (double x : leave_one_out) mean += x;
  mean /= g;
  for (double x : leave_one_out) ss += (x - mean) * (x - mean);
  return std::sqrt((g - 1.0) / g * ss);
}

double convention_force_delay_limit() { return 0.5 + kLagAccuracy; }

BlockResidual block_residual(const std::vector<BlockPair>& pairs, const feedid::ForcePairing<double>& pairing,
                             double mass_kg, int lead) {
  return block_residual(at_pairing(pairs, pairing, lead), mass_kg);
}

BlockResidual block_residual(const std::vector<PairedBlock>& blocks, double mass_kg) {
  BlockResidual out;
  for (const PairedBlock& b : blocks) {
    const double r = (b.impulse - mass_kg * b.dv) / b.area;
    out.sum_squares += r * r;
    out.chunk_sum_squares[static_cast<std::size_t>(b.chunk)] += r * r;
    ++out.blocks;
  }
  return out;
}

BlockResidual block_residual(const Signals& s, const DriveParams& p, double v_min, double block_s) {
  return block_residual(paired_blocks(s, p, v_min, block_s), p.mass_kg);
}

BlockMass block_mass(const std::vector<BlockPair>& pairs, const feedid::ForcePairing<double>& pairing, int lead) {
  return block_mass(at_pairing(pairs, pairing, lead));
}

BlockMass block_mass(const std::vector<PairedBlock>& blocks) {
  BlockMass out;
  constexpr int chunks = kJackknifeChunks;
  // Sums per jackknife chunk (contiguous samples), for the delete-one jackknife.
  std::vector<double> num(static_cast<std::size_t>(chunks), 0.0), den(num);
  for (const PairedBlock& b : blocks) {
    const auto c = static_cast<std::size_t>(b.chunk);
    num[c] += b.impulse * b.dv;
    den[c] += b.dv * b.dv;
  }
  double n_all = 0.0, d_all = 0.0;
  for (int c = 0; c < chunks; ++c) { n_all += num[c]; d_all += den[c]; }
  if (!(d_all > 0.0)) return out;
  out.mass_kg = n_all / d_all;
  std::vector<double> leave_out;
  for (int c = 0; c < chunks; ++c)
    if (d_all - den[c] > 0.0) leave_out.push_back((n_all - num[c]) / (d_all - den[c]));
  out.mass_se_kg = jackknife_se(leave_out);
  out.ok = std::isfinite(out.mass_se_kg) && std::isfinite(out.mass_kg) && out.mass_kg > 0.0;
  return out;
}

BlockMass block_mass(const Signals& s, const DriveParams& p, double v_min, double block_s) {
  if (s.t.size() < 2) return BlockMass{};
  return block_mass(paired_blocks(s, p, v_min, block_s));
}

double block_length_s(const Signals& s) { return s.sample_rate_hz > 0 ? std::max(0.01, 8.0 / s.sample_rate_hz) : 0.01; }

namespace {
/// Velocity as the core sees it: position through the zero-phase
/// Butterworth at cut-off fc (at most 0.4 of the rate), then central
/// differences: no lag, and the encoder's counts averaged over about 1/fc.
std::vector<double> derived_velocity(const Signals& s, double fc_hz) {
  return zero_phase_velocity(s.x, s.t, applied_cutoff_hz(fc_hz, s.sample_rate_hz), s.sample_rate_hz, s.max_step_s());
}
}  // namespace

void derive_velocity(Signals& s, double fc_hz) {
  s.velocity_filter_hz = applied_cutoff_hz(fc_hz, s.sample_rate_hz);
  zero_phase_velocity(s.x, s.t, s.velocity_filter_hz, s.sample_rate_hz, s.max_step_s(), s.v);  // into s.v's storage
}

void derive_rival_velocities(Signals& s) {
  s.rival_velocities.clear();
  for (double fc : s.velocity_filter_rivals_hz) s.rival_velocities.push_back(derived_velocity(s, fc));
}

namespace {
/// The velocity bands' edges as opt states them or s's velocity gives them
/// (m/s), and the velocity's top (its 0.999 quantile of |v|).
struct VelocityEdges {
  double resolution = 0.0, lowest = 0.0, highest = 0.0, top = 0.0;
};

VelocityEdges velocity_edges(const Signals& s, const IdentifyOptions& opt) {
  const double dt = s.period_s();
  VelocityEdges e;
  // Velocity resolution: the encoder quantum per sample period, or the white
  // noise of the velocity (second differences), whichever is larger; a
  // velocity column that was integrated and derived again keeps its own.
  e.top = quantile_abs(s.v, 0.999);
  if (opt.velocity_resolution_m_s > 0) {
    e.resolution = opt.velocity_resolution_m_s;
  } else {
    const double v_noise = std::max(velocity_noise(s.v, s.t, dt), s.column_velocity_noise_m_s);
    e.resolution = std::max(s.position_quantum_m / dt, v_noise);
  }
  e.lowest = opt.velocity_min_m_s > 0 ? opt.velocity_min_m_s : std::max({2.0 * e.resolution, 1e-4 * e.top, 1e-6});
  e.highest = opt.velocity_max_m_s > 0 ? opt.velocity_max_m_s : std::max(1.05 * e.top, 5.0 * e.lowest);
  return e;
}

/// What identify's options tell the conditioning (condition.hpp).
ConditionOptions conditioning(const IdentifyOptions& opt) {
  ConditionOptions c;
  c.spread_held_values = opt.spread_held_values;
  c.force_sign = opt.force_sign;
  c.velocity_column_given = opt.velocity_source == VelocitySource::given;
  return c;
}

/// Timing of the velocity column (periods): `core` is the lag behind the
/// motion of the velocity the core will see (NaN unknown), `column` the
/// logged column's lag behind that velocity, in which stated force lags are
/// given and the estimated one is reported.
struct VelocityTiming {
  double core = 0.0, column = 0.0;
};

VelocityTiming time_velocity_column(Signals& s, const Trace& trace, const IdentifyOptions& opt) {
  const double dt = s.period_s();
  const double stated = std::isfinite(opt.velocity_lag_s) ? opt.velocity_lag_s / dt : std::numeric_limits<double>::quiet_NaN();
  VelocityTiming v;
  if (s.has_velocity_column && opt.velocity_source == VelocitySource::given) {
    v.core = std::isfinite(stated) ? stated : 0.0;
  } else if (s.has_velocity_column && trace.has_position) {
    const double lag = std::isfinite(stated) ? stated : estimate_velocity_lag(s);
    s.velocity_lag_s = lag * dt;
    v.column = std::isfinite(lag) ? lag : 0.5;
  } else if (!trace.has_position) {
    // Integrated and derived again, the column is advanced by exactly half
    // a period; its own lag behind the motion is unknown unless stated.
    v.column = 0.5;
    v.core = stated - 0.5;
  }
  return v;
}

/// The core's velocity at cut-off fc_hz (`derived`: that velocity, already
/// derived from raw's position), its force not yet aligned.
Signals derived_at(const Signals& raw, const Trace& trace, const VelocityTiming& timing, double fc_hz,
                   std::vector<double>* derived = nullptr) {
  Signals s = raw;
  if (derived && derived->size() == s.t.size()) {
    s.velocity_filter_hz = applied_cutoff_hz(fc_hz, s.sample_rate_hz);
    s.v = std::move(*derived);
  } else {
    derive_velocity(s, fc_hz);
  }
  std::ostringstream o;
  o << "derived: zero-phase 4th-order Butterworth " << std::setprecision(3) << s.velocity_filter_hz << " Hz ("
    << s.velocity_filter_origin << ") on position" << (trace.has_position ? "" : " (integrated velocity)")
    << ", central differences";
  if (raw.has_velocity_column && trace.has_position)
    o << "; the velocity column lags position by " << std::setprecision(2) << timing.column << " periods";
  if (trace.has_velocity && !raw.has_velocity_column)
    o << "; the velocity column, " << std::setprecision(3) << raw.velocity_column_gain
      << " times the derivative of position (another unit, the other sign, or the motor side of a gear), is left out";
  s.velocity_origin = o.str();
  s.core_velocity_lag = timing.core;
  return s;
}

/// derived_at, then the force lag on it.
Signals derive_and_align(const Signals& raw, const Trace& trace, const IdentifyOptions& opt, const VelocityTiming& timing,
                         double fc_hz, const LagSearch& lag = {}, std::vector<double>* derived = nullptr) {
  Signals s = derived_at(raw, trace, timing, fc_hz, derived);
  align_force(s, opt, timing.core, timing.column, lag);
  return s;
}

/// A velocity column lagging position by more than this (periods) went
/// through a filter beyond the position difference (0.5); the estimate is
/// good to about 0.02 period.
constexpr double kFilteredVelocityLag = 0.6;

/// VelocitySource::column: the column if it is a position difference, else
/// the backward difference of position (a filter's rounding of quantised
/// counts wrecked Fs, +3000 % on a 100 nm, 4 kHz drive).
Signals column_and_align(Signals s, const IdentifyOptions& opt, VelocityTiming timing, const LagSearch& lag = {}) {
  if (timing.column > kFilteredVelocityLag) {
    for (std::size_t k = s.v.size(); k-- > 1;) {
      const double h = s.t[k] - s.t[k - 1];
      s.v[k] = h > 0 ? (s.x[k] - s.x[k - 1]) / h : 0.0;
    }
    // A stretch's first sample has no difference within it: it takes its
    // successor's (never one across the gap before it).
    for (std::size_t k = 0; k + 1 < s.v.size(); ++k)
      if (k == 0 || s.gap_before(k)) s.v[k] = s.v[k + 1];
    std::ostringstream o;
    o << "backward differences of position (the column lags position by " << std::setprecision(2) << timing.column
      << " periods: a drive filter)";
    s.velocity_origin = o.str();
    timing.core = 0.5;
  } else {
    s.velocity_origin = "measured";
    timing.core = timing.column;
  }
  timing.column -= timing.core;
  s.core_velocity_lag = timing.core;
  align_force(s, opt, timing.core, timing.column, lag);
  return s;
}

/// The options with the band edges (lowest band, resolution, top) the
/// searches for the force lag and the velocity cut-off measure with: those
/// of the velocity at the lowest cut-off tried. The provisional cut-off's
/// derivative is the noisiest of all; on a slow, unevenly sampled log it
/// implied a resolution of 8.6 rad/s (a 200 Hz SysId log), which put the
/// lowest band above the slow ramps, and both searches then measured only
/// the fast transients.
IdentifyOptions with_smooth_band_edges(const Signals& raw, const IdentifyOptions& opt) {
  Signals smooth = raw;
  derive_velocity(smooth, lowest_velocity_filter_hz(raw));
  const VelocityEdges e = velocity_edges(smooth, opt);
  IdentifyOptions o = opt;
  o.velocity_min_m_s = e.lowest;
  o.velocity_resolution_m_s = e.resolution;
  o.velocity_max_m_s = e.highest;
  return o;
}
}  // namespace

/// Of s's lag searched beside a stated lag and `other` (another candidate
/// velocity's), keeps the one nearer the stated lag: the warning speaks
/// only where every velocity's search puts the lag elsewhere (an 8 kHz
/// log's column and its position's derivative found lags a quarter period
/// apart, and the stated one, the column's, was warned of).
void keep_nearer_searched_lag(Signals& s, const Signals::SearchedLag& other);

Signals prepare_signals(const Trace& trace, const IdentifyOptions& opt) {
  Signals raw = condition(trace, conditioning(opt));
  if (raw.error.empty()) raw.error = alignment_refusal(opt.alignment);
  if (!raw.error.empty()) return raw;
  const VelocityTiming timing = time_velocity_column(raw, trace, opt);
  if (raw.has_velocity_column && opt.velocity_source == VelocitySource::given) {
    raw.velocity_origin = "given";
    raw.core_velocity_lag = timing.core;
    align_force(raw, opt, timing.core, timing.column);
    return raw;
  }
  if (raw.has_velocity_column && trace.has_position && opt.velocity_source == VelocitySource::column)
    return column_and_align(raw, opt, timing);
  const IdentifyOptions search = opt.velocity_filter_hz > 0 ? opt : with_smooth_band_edges(raw, opt);
  // The core's velocity is the zero-phase derivative of position (logged or
  // integrated): a drive's column carries the count noise (one count per
  // period is 0.4 mm/s at 4 kHz and 100 nm) into every band's m * dv at
  // each crossing, which left Fc- 0.9 % and sigma- 0.35 % off on a 400 kg
  // axis. How much to smooth depends on the encoder and the mass, so the
  // cut-off is chosen by the block residual its model leaves (the smoothest
  // within a standard error of the least; choose_velocity_filter), unless
  // stated. The column stays a candidate under the same measure: a log
  // whose velocity comes from a better sensor than its position keeps it,
  // if it beats the least residual of all cut-offs.
  const bool stated = opt.velocity_filter_hz > 0;
  raw.velocity_filter_origin = stated ? "stated" : "provisional";
  // The friction the derived velocity's lag search holds serves the
  // column's search too: one identification for both (issue 29).
  // The lag search measures with the band edges the cut-off scan holds
  // for all its candidates: the provisional velocity's configuration.
  HeldFriction held;
  Signals s = derived_at(raw, trace, timing, stated ? opt.velocity_filter_hz : kProvisionalVelocityFilter_hz);
  const feedid::Config<double> edges = auto_config(s, search);
  align_force(s, search, timing.core, timing.column, LagSearch{nullptr, &held, &edges});
  if (stated || !s.error.empty()) return s;
  // On a long log the scan runs on stretches spread over it (scan_selection);
  // the column is scored on the same samples.
  const bool whole = s.t.size() <= kScanSamplesMax;
  const std::vector<char> scanned = whole ? std::vector<char>{} : scan_selection(s);
  // The scan's velocities serve the choice and its rivals where it derived
  // them from the logged position itself: the whole log, not delayed by
  // the lag, which the choice then keeps (the found one).
  const bool reuse = whole && s.velocity_delay_samples == 0 && s.lag_search.ok;
  const LagEstimate found = s.lag_search;
  const Signals::SearchedLag derived_searched = s.searched_force_lag;
  Signals::SearchedLag column_searched;
  // The scan derives every candidate's velocity into its signals: s itself
  // on a whole log, which nothing below reads again, rather than a copy of
  // every column of it.
  FilterChoice choice = choose_velocity_filter(whole ? std::move(s) : select_samples(s, scanned), edges, reuse);
  if (raw.has_velocity_column && trace.has_position) {
    Signals column = column_and_align(raw, search, timing, LagSearch{nullptr, &held});
    if (column.error.empty() && block_fit_ssr(whole ? column : select_samples(column, scanned), edges) < choice.least_block_ssr) {
      column.velocity_origin += "; it fits the blocks better than the derivative of position at any cut-off";
      keep_nearer_searched_lag(column, derived_searched);
      return column;
    }
    column_searched = column.searched_force_lag;
  }
  std::ostringstream o;
  o << "the smoothest of " << choice.candidates << " cut-offs" << (raw.has_velocity_column && trace.has_position ? " and the velocity column" : "")
    << " within a standard error of the least block residual";
  raw.velocity_filter_origin = o.str();
  std::vector<double>* at_choice = choice.velocities.empty() ? nullptr : &choice.velocities.front();
  Signals chosen = derive_and_align(raw, trace, search, timing, choice.cutoff_hz,
                                    LagSearch{found.ok ? &found : nullptr}, at_choice);
  chosen.velocity_filter_rivals_hz = choice.rivals_hz;
  keep_nearer_searched_lag(chosen, column_searched);
  if (reuse && chosen.velocity_delay_samples == 0 && choice.velocities.size() == choice.rivals_hz.size() + 1) {
    chosen.rival_velocities.assign(std::make_move_iterator(choice.velocities.begin() + 1),
                                   std::make_move_iterator(choice.velocities.end()));
    // A rival the scan no longer held is derived again.
    for (std::size_t i = 0; i < chosen.rival_velocities.size(); ++i)
      if (chosen.rival_velocities[i].size() != chosen.t.size())
        chosen.rival_velocities[i] = derived_velocity(chosen, choice.rivals_hz[i]);
  } else {
    derive_rival_velocities(chosen);
  }
  return chosen;
}

IdentifyOptions with_conventions_of(const Signals& found, IdentifyOptions o) {
  o.force_lag_s = found.force_lag_s;
  o.force_lag_se_s = found.force_lag_se_s;  // an estimated lag's, or one stated with it; 0 otherwise
  o.check_stated_lag = false;               // carried, not stated: checked where it was found
  o.force_sign = found.force_sign.sign;
  if (std::isfinite(found.velocity_lag_s)) o.velocity_lag_s = found.velocity_lag_s;
  if (found.velocity_filter_hz > 0) {
    o.velocity_filter_hz = found.velocity_filter_hz;
    o.velocity_source = VelocitySource::position;
  } else if (o.velocity_source != VelocitySource::given) {  // the column won the search (or was asked for)
    o.velocity_source = VelocitySource::column;
  }
  return o;
}


feedid::Config<double> auto_config(const Signals& s, const IdentifyOptions& opt) {
  feedid::Config<double> c;
  const double dt = s.period_s();
  const VelocityEdges edges = velocity_edges(s, opt);
  const double v_top = edges.top;
  c.velocity_resolution_m_s = edges.resolution;
  c.velocity_min_m_s = edges.lowest;
  c.velocity_max_m_s = edges.highest;
  // Jumps beyond several times the largest acceleration in the trace are absurd.
  std::vector<double> acc;
  acc.reserve(s.v.size());
  for (std::size_t k = 1; k < s.v.size(); ++k)
    if (s.t[k] - s.t[k - 1] <= 1.5 * dt) acc.push_back((s.v[k] - s.v[k - 1]) / (s.t[k] - s.t[k - 1]));
  c.max_acceleration_m_s2 = std::max(200.0, 5.0 * quantile_abs(std::move(acc), 0.999));
  c.max_speed_m_s = std::max(20.0, 2.0 * v_top);
  // From the data, so that it scales with the force's unit (force_outliers.hpp):
  // identify has bridged what lay beyond it; a streamed log's core rejects it.
  c.max_force_N = force_outlier_limit(s.x, s.u);
  c.max_gap_s = s.max_step_s();
  c.mass_window_s = std::max(0.02, 20.0 * dt);
  c.min_section_s = std::max(0.02, 10.0 * dt);
  c.force_lag_samples = s.force_lag_samples;
  return c;
}





void fill_friction_curve(const Core& core, IdentifyResult& r) {
  const auto& st = core.statistics();
  for (int d = 0; d < 2; ++d)
    for (int j = 0; j < Core::bands; ++j) {
      const auto& b = st.band[d][j];
      const double t = b.time_s.get();
      if (t < feedid::analysis::min_band_time_s<double>()) continue;  // the core's own rule for a band point
      r.friction_curve[d].push_back({b.speed.get() / t, (b.force.get() - r.estimate.mass_kg * b.dvel.get()) / t, t});
    }
}

namespace {
/// Each run's counters: the difference of the snapshots before it and
/// before the next (after the solve for the last, whose split it counts).
std::vector<feedid::Diagnostics> per_run(const std::vector<feedid::Diagnostics>& at) {
  std::vector<feedid::Diagnostics> out;
  for (std::size_t i = 0; i + 1 < at.size(); ++i) {
    const feedid::Diagnostics &a = at[i], &b = at[i + 1];
    feedid::Diagnostics d;
    d.samples_accepted = b.samples_accepted - a.samples_accepted;
    d.samples_rejected = b.samples_rejected - a.samples_rejected;
    for (int k = 0; k < 2; ++k) d.sections_complete[k] = b.sections_complete[k] - a.sections_complete[k];
    d.sections_short = b.sections_short - a.sections_short;
    d.sections_split = b.sections_split - a.sections_split;
    d.mass_windows = b.mass_windows - a.mass_windows;
    out.push_back(d);
  }
  return out;
}
}  // namespace

IdentifyResult identify(const Trace& logged, const IdentifyOptions& opt) {
  IdentifyResult r;
  r.units = opt.units;
  // Every stage sees the trace with its force outliers bridged (force_outliers.hpp).
  ForceOutliers outliers;
  const Trace trace = bridge_force_outliers(logged, opt.units.force, outliers);
  const std::size_t n = trace.samples.size();
  const std::uint64_t pushed_before = core_samples_pushed();
  constexpr std::size_t min_samples = 100;
  if (n < min_samples) {
    r.status = feedid::Status::insufficient_data;
    r.error = trace.source + ": trace too short to identify: " + std::to_string(n) + " samples (need at least " +
              std::to_string(min_samples) + " and motion in both directions)";
  } else {
    std::vector<std::size_t> run_starts;
    for (const TraceRun& tr : trace.runs) run_starts.push_back(tr.first);
    r = identify_prepared(prepare_signals(trace, opt), opt, trace.source, run_starts);
  }
  r.force_outliers = std::move(outliers);
  r.rows_skipped = trace.rows_skipped;
  r.rows_repeated = trace.rows_repeated;
  r.skipped_rows = trace.skipped_rows;
  r.time_origin_s = trace.time_origin_s;
  r.runs = trace.runs;
  if (n > 0) r.core_passes = static_cast<double>(core_samples_pushed() - pushed_before) / static_cast<double>(n);
  return r;
}

IdentifyResult identify_prepared(Signals prepared, const IdentifyOptions& opt, const std::string& source,
                                 const std::vector<std::size_t>& run_starts) {
  if (opt.gravity != GravityTerm::none && prepared.error.empty())
    return identify_with_gravity(std::move(prepared), opt, source, run_starts);
  IdentifyResult r;
  r.units = opt.units;
  const std::uint64_t pushed_before = core_samples_pushed();
  r.signals = std::move(prepared);
  // Signals built by hand with rival cut-offs and no columns for them get them here.
  if (r.signals.rival_velocities.size() != r.signals.velocity_filter_rivals_hz.size()) derive_rival_velocities(r.signals);
  const Signals& s = r.signals;
  if (!s.error.empty() || s.t.size() < 2) {
    r.status = feedid::Status::insufficient_data;
    r.error = s.error.empty() ? source + ": no samples to identify" : s.error;
    return r;
  }
  r.duration_s = s.t.back() - s.t.front();
  r.config = auto_config(s, opt);
  CoreRun run = run_core(s, r.config, opt, 0, static_cast<std::size_t>(-1), run_starts);
  r.run_diagnostics = per_run(run.counters_at);
  if (run.status == feedid::Status::invalid_config) {
    r.status = run.status;
    r.error = std::string("invalid configuration: ") + run.core->config_error();
    return r;
  }
  r.config = run.core->config();  // as init() completed it: what the core ran with
  r.status = run.status;
  r.estimate = run.estimate;
  r.friction_model = run.friction_model;
  r.diagnostics = run.diagnostics;
  r.first_rejections = run.first_rejections;
  if (opt.progress) opt.progress(1.0);

  fill_friction_curve(*run.core, r);
  if (r.status == feedid::Status::insufficient_data) {
    std::ostringstream o;
    o << source << ": not enough motion to identify: " << r.duration_s << " s of data, "
      << r.estimate.pos.time_in_bands_s << " s moving positive and " << r.estimate.neg.time_in_bands_s
      << " s moving negative above " << r.config.velocity_min_m_s << " " << r.units.velocity()
      << "; each direction needs data in at least 5 velocity bands (what to record: docs/recording.md)";
    r.error = o.str();
    return r;
  }
  r.residual_block_s = block_length_s(s);
  // One observation of the blocks serves the residual and the mass refit:
  // the standard errors below change no parameter the friction is read from.
  const std::vector<BlockPair> pairs =
      block_pairs(s, to_drive_params(r.estimate), r.config.velocity_min_m_s, r.residual_block_s);
  r.residual_rms_N = block_residual(pairs, s.pairing(), r.estimate.mass_kg).rms();
  if (opt.honest_standard_errors && r.status == feedid::Status::ok) {
    const Uncertainty u = widen_standard_errors(r, opt);
    r.jackknife_chunks = u.chunks_used;
    r.se_model = u.model_se;
    r.se_jackknife = u.jackknife_se;
    r.se_timing = u.timing_se;
    r.se_cutoff = u.cutoff_se;
  }
  refit_mass_on_blocks(r, pairs);
  r.core_passes = static_cast<double>(core_samples_pushed() - pushed_before) / static_cast<double>(s.t.size());
  return r;
}

const char* lag_origin_name(Signals::LagOrigin o) {
  switch (o) {
    case Signals::LagOrigin::estimated: return "estimated";
    case Signals::LagOrigin::option: return "option";
    case Signals::LagOrigin::convention: return "convention";
    case Signals::LagOrigin::assumed: return "assumed held force (too little motion to estimate the lag)";
  }
  return "?";
}

namespace {
/// The block mass's spread over the rival velocity cut-offs (RMS of its
/// change; cutoff_standard_errors for the core's parameters).
double block_mass_cutoff_spread(const IdentifyResult& r, double mass_kg) {
  double sum = 0.0;
  int used = 0;
  Signals rival;  // one copy, its velocity each rival's in turn
  if (!r.signals.rival_velocities.empty()) rival = r.signals;
  for (const std::vector<double>& v : r.signals.rival_velocities) {
    rival.v = v;
    const BlockMass b = block_mass(rival, to_drive_params(r.estimate), r.config.velocity_min_m_s, r.residual_block_s);
    if (!b.ok) continue;
    sum += (b.mass_kg - mass_kg) * (b.mass_kg - mass_kg);
    ++used;
  }
  return used > 0 ? std::sqrt(sum / used) : 0.0;
}
}  // namespace

void refit_mass_on_blocks(IdentifyResult& r, const std::vector<BlockPair>& pairs) {
  r.mass_from_windows_kg = r.estimate.mass_kg;
  // Only an identified mass is refitted: the blocks remove the windows'
  // attenuation by velocity quantisation from a mass the data pin down;
  // they do not rescue one the windows could not pin (on the 200 Hz SysId
  // logs, whose positions are held for 20 ms, the block mass of such a
  // mass came out 13-73 % below kA, the windows' -28 to +10 %, when the
  // lowest cut-off tried was 20 Hz).
  if (r.status != feedid::Status::ok || !r.estimate.mass_identified()) return;
  // One observation of the blocks serves both pairings (BlockPair).
  const BlockMass b = block_mass(pairs, r.signals.pairing());
  if (!b.ok) return;
  r.estimate.mass_kg = b.mass_kg;
  // The block jackknife replaces the windows' one, and the timing term is
  // the block mass's own sensitivity to the lag: the window mass's, twice
  // to four times larger, made m's intervals cover 99.5 %.
  r.se_jackknife[0] = b.mass_se_kg;
  if (r.lag_se_periods > 0) {
    feedid::ForcePairing<double> probe;
    (void)probe.init(timing_probe_lag(r.signals));  // within the rule's range by construction
    const BlockMass shifted = block_mass(pairs, probe);
    if (shifted.ok) r.se_timing[0] = std::fabs(shifted.mass_kg - b.mass_kg) / kTimingProbeStep * r.lag_se_periods;
  }
  r.se_cutoff[0] = block_mass_cutoff_spread(r, b.mass_kg);
  r.estimate.mass_se_kg = std::hypot(b.mass_se_kg, r.se_timing[0], r.se_cutoff[0]);
  r.estimate.mass_flags |= feedid::analysis::mass_uncertainty_flags(r.estimate.mass_kg, r.estimate.mass_se_kg);
}

namespace {
/// The core's counters at each run's start (CoreRun::counters_at). A
/// run's first sample closes (splits) the run before, so the snapshot is
/// taken after it, less the run's own samples; if the core rejects it, the
/// gap is closed by the run's first accepted sample (the core keeps a
/// rejected sample's dt), so the snapshot waits for that one.
struct RunBoundary {
  std::vector<feedid::Diagnostics>& out;
  bool pending = false;
  uint64_t accepted = 0, rejected = 0;  ///< the pending run's samples so far

  void start(const feedid::Diagnostics& before, bool first_sample_of_all) {
    if (first_sample_of_all) { out.push_back(before); return; }
    if (pending) take(before);  // a run that the core rejected whole
    pending = true;
    accepted = rejected = 0;
  }
  void after_push(const feedid::Diagnostics& now, bool sample_ok) {
    if (!pending) return;
    ++(sample_ok ? accepted : rejected);
    if (sample_ok) take(now);
  }
  void finish(const feedid::Diagnostics& now) { if (pending) take(now); }
  void take(feedid::Diagnostics d) {
    d.samples_accepted -= accepted;
    d.samples_rejected -= rejected;
    out.push_back(d);
    pending = false;
  }
};
}  // namespace

namespace {
thread_local std::uint64_t pushed_on_this_thread = 0;
}  // namespace

std::uint64_t core_samples_pushed() { return pushed_on_this_thread; }

namespace {
/// Sample k of the signals as a core takes it; the first of a run of
/// pushes starts a chain (dt 0).
feedid::Sample<double> core_sample(const Signals& s, std::size_t k, std::size_t first) {
  feedid::Sample<double> smp;
  smp.dt_s = k == first ? 0.0 : s.t[k] - s.t[k - 1];
  smp.position_m = s.x[k];
  smp.velocity_m_s = s.v[k];
  smp.force_N = s.u[k];
  return smp;
}
}  // namespace

template <typename C>
SolvedCore<C> solve_core(const Signals& s, const feedid::Config<double>& cfg, feedid::Method method, std::size_t begin,
                         std::size_t end) {
  SolvedCore<C> run;
  run.core = std::make_unique<C>();
  run.status = run.core->init(cfg);
  if (run.status != feedid::Status::ok) return run;
  const std::size_t n = std::min(end, s.t.size());
  for (std::size_t k = begin; k < n; ++k) (void)run.core->push(core_sample(s, k, begin));
  pushed_on_this_thread += n > begin ? n - begin : 0;
  run.status = run.core->solve(method);
  run.estimate = run.core->estimate();
  return run;
}
template SolvedCore<Core> solve_core(const Signals&, const feedid::Config<double>&, feedid::Method, std::size_t, std::size_t);
template SolvedCore<BandsCore> solve_core(const Signals&, const feedid::Config<double>&, feedid::Method, std::size_t, std::size_t);

CoreRun run_core(const Signals& s, const feedid::Config<double>& cfg, const IdentifyOptions& opt,
                 std::size_t begin, std::size_t end, const std::vector<std::size_t>& run_starts) {
  CoreRun run;
  run.core = std::make_unique<Core>();
  Core& core = *run.core;
  run.status = core.init(cfg);
  if (run.status != feedid::Status::ok) return run;
  const std::size_t n = std::min(end, s.t.size());
  const std::size_t report_every = std::max<std::size_t>(n / 50, 1);
  std::size_t next_run = 0;
  RunBoundary boundary{run.counters_at};
  for (std::size_t k = begin; k < n; ++k) {
    const bool run_starts_here = next_run < run_starts.size() && run_starts[next_run] <= k;
    if (run_starts_here) boundary.start(core.diagnostics(), k == begin);
    const feedid::Status st = core.push(core_sample(s, k, begin));
    if (st != feedid::Status::ok && run.first_rejections.size() < 10) run.first_rejections.push_back({k, st});
    boundary.after_push(core.diagnostics(), st == feedid::Status::ok);
    while (next_run < run_starts.size() && run_starts[next_run] <= k) ++next_run;
    if (opt.progress && k % report_every == 0) opt.progress(static_cast<double>(k) / static_cast<double>(n));
  }
  boundary.finish(core.diagnostics());
  pushed_on_this_thread += n > begin ? n - begin : 0;
  run.status = core.solve(opt.method);
  run.estimate = core.estimate();
  run.diagnostics = core.diagnostics();
  if (!run_starts.empty()) run.counters_at.push_back(run.diagnostics);
  if (run.status == feedid::Status::ok && opt.select_friction_model) {
    run.friction_model = select_friction_models(core, run.estimate);
  } else {
    for (int d = 0; d < 2; ++d) {
      const auto& de = d == 0 ? run.estimate.pos : run.estimate.neg;
      run.friction_model[static_cast<std::size_t>(d)] = {de.breakaway_N > 0 && de.stribeck_velocity_m_s > 0,
                                                         "as the core fitted it (no model selection)", 0.0};
    }
  }
  return run;
}

namespace {
template <typename C>
FrictionModel select_direction(const C& core, int d, double mass, feedid::DirectionEstimate<double>& de) {
  FrictionModel m;
  if (!de.friction_identified()) {
    m.reason = "no friction identified";
    return m;
  }
  const auto p = feedid::analysis::friction_points(core.statistics(), d, mass);
  feedid::Vector<double, 3> th4, th2, inv2;
  double ssr4 = 0.0, ssr2 = 0.0;
  const bool has_dip = de.breakaway_N > 0 && de.stribeck_velocity_m_s > 0 &&
                       feedid::analysis::fit_friction_at(p, de.stribeck_velocity_m_s, th4, ssr4);
  if (!feedid::analysis::fit_coulomb_viscous_at(p, th2, ssr2, &inv2) || p.count < 6) {
    m.stribeck = has_dip;
    m.reason = "too few velocity bands to weigh the Stribeck law";
    return m;
  }
  const double n = p.count;
  m.bic_gain = has_dip && ssr4 > 0 ? n * std::log(ssr2 / ssr4) - 2.0 * std::log(n) : 0.0;
  const bool physical = de.coulomb_N >= 0 && de.viscous_Ns_m >= 0;
  // A Stribeck velocity at either end of its search range is not placed by
  // the data (at the top the exponential bends the whole curve, at the
  // bottom it touches the lowest bands alone), and BIC's count of two
  // parameters assumes an optimum inside the range. (With too few bands to
  // weigh, above, the core's fit stays as it is, its flags saying so.)
  const bool placed = !(de.flags & feedid::flag_stribeck_at_search_bound);
  m.stribeck = has_dip && physical && placed && m.bic_gain > 0;
  if (m.stribeck) {
    m.reason = "Stribeck: its dip lowers the band residual by more than BIC charges for Fs and vs";
    return m;
  }
  m.reason = !has_dip    ? "Coulomb + viscous: the fit found no dip (Fs = 0)"
             : !physical ? "Coulomb + viscous: the Stribeck fit was not physical (a negative Coulomb or viscous term)"
             : !placed   ? "Coulomb + viscous: the Stribeck velocity came out at the end of its search range (the data do not place the dip)"
                         : "Coulomb + viscous: the dip does not lower the band residual enough to pay for Fs and vs (BIC)";
  m.refitted = refit_coulomb_viscous(core.statistics(), d, mass, de);
  if (m.refitted && (de.flags & feedid::flag_friction_still_falling))
    m.reason += "; friction falls across every speed logged, so its slope is held at 0 and sigma and Fc are not identifiable";
  return m;
}
}  // namespace

template <typename Stats>
bool refit_coulomb_viscous(const Stats& st, int d, double mass, feedid::DirectionEstimate<double>& de) {
  const auto p = feedid::analysis::friction_points(st, d, mass);
  feedid::Vector<double, 3> th2, inv2;
  double ssr2 = 0.0;
  if (!feedid::analysis::fit_coulomb_viscous_at(p, th2, ssr2, &inv2)) return false;
  // Standard errors of the unbounded fit: what the data resolve.
  const double s2 = ssr2 / std::max(static_cast<double>(p.count) - 2.0, 1.0);
  de.flags &= ~static_cast<uint32_t>(feedid::flag_not_physical | feedid::flag_coulomb_uncertain |
                                     feedid::flag_viscous_uncertain | feedid::flag_friction_still_falling);
  de.flags |= feedid::analysis::hold_falling_friction(p, th2, ssr2);
  de.coulomb_N = th2.v[0];
  de.viscous_Ns_m = th2.v[1];
  de.coulomb_se = std::sqrt(s2 * inv2.v[0]);
  de.viscous_se = std::sqrt(s2 * inv2.v[1]);
  de.breakaway_N = 0.0;
  de.stribeck_velocity_m_s = 0.0;
  if (de.coulomb_N < 0 || de.viscous_Ns_m < 0) de.flags |= feedid::flag_not_physical;
  de.flags |= feedid::analysis::coulomb_uncertainty_flags(de) | feedid::analysis::viscous_uncertainty_flags(de);
  if (!(de.flags & feedid::stribeck_flags)) de.flags |= feedid::flag_stribeck_uncertain;
  return true;
}

template bool refit_coulomb_viscous(const Core::Stats&, int, double, feedid::DirectionEstimate<double>&);
template bool refit_coulomb_viscous(const BandsCore::Stats&, int, double, feedid::DirectionEstimate<double>&);

template <typename C>
std::array<FrictionModel, 2> select_friction_models(const C& core, feedid::Estimate<double>& e) {
  return {select_direction(core, 0, e.mass_kg, e.pos), select_direction(core, 1, e.mass_kg, e.neg)};
}
template std::array<FrictionModel, 2> select_friction_models(const Core&, feedid::Estimate<double>&);
template std::array<FrictionModel, 2> select_friction_models(const BandsCore&, feedid::Estimate<double>&);





SymmetricFriction symmetric_friction(const IdentifyResult& r) {
  SymmetricFriction out;
  const auto& p = r.estimate.pos;
  const auto& n = r.estimate.neg;
  // A falling curve's held slope is no figure to pool.
  if (r.friction_model[0].stribeck || r.friction_model[1].stribeck || !p.friction_identified() ||
      !n.friction_identified() || ((p.flags | n.flags) & feedid::flag_friction_still_falling))
    return out;
  // Inverse-variance means; the directions agree when each difference is
  // within 2 of its standard errors.
  auto pooled = [](double a, double sa, double b, double sb, double& mean, double& se) {
    const double wa = 1.0 / (sa * sa), wb = 1.0 / (sb * sb);
    mean = (wa * a + wb * b) / (wa + wb);
    se = std::sqrt(1.0 / (wa + wb));
    return std::fabs(a - b) <= 2.0 * std::hypot(sa, sb);
  };
  out.agree = pooled(p.coulomb_N, p.coulomb_se, n.coulomb_N, n.coulomb_se, out.coulomb_N, out.coulomb_se) &&
              pooled(p.viscous_Ns_m, p.viscous_se, n.viscous_Ns_m, n.viscous_se, out.viscous_Ns_m, out.viscous_se);
  out.agree = out.agree && std::isfinite(out.coulomb_N) && std::isfinite(out.viscous_Ns_m);
  return out;
}

namespace {
nlohmann::json friction_model_json(const IdentifyResult& r) {
  nlohmann::json friction;
  for (int d = 0; d < 2; ++d) {
    const FrictionModel& m = r.friction_model[static_cast<std::size_t>(d)];
    friction[d == 0 ? "pos" : "neg"] = {{"law", m.stribeck ? "stribeck" : "coulomb_viscous"},
                                        {"reason", m.reason},
                                        {"bic_gain", m.bic_gain}};
  }
  friction["rule"] = "the Stribeck law is kept where it is physical and lowers the band residual by more than the "
                     "Bayesian information criterion charges for Fs and vs (n ln(SSR_cv/SSR_stribeck) > 2 ln n over n "
                     "velocity bands); otherwise Coulomb + viscous, with Fs = vs = 0";
  const SymmetricFriction sym = symmetric_friction(r);
  friction["symmetric"] = sym.agree ? nlohmann::json{{"fc", sym.coulomb_N}, {"fc_se", sym.coulomb_se},
                                                     {"sigma", sym.viscous_Ns_m}, {"sigma_se", sym.viscous_se},
                                                     {"fc_identifiable", sym.coulomb_identified()}}
                                    : nlohmann::json();
  return {{"friction", friction}};
}
}  // namespace

std::string not_physical(const IdentifyResult& r) {
  if (r.status != feedid::Status::ok) return "";
  return non_physical_parameters(to_drive_params(r.estimate), r.units);
}

std::string status_word(const IdentifyResult& r) {
  if (!not_physical(r).empty()) return "not_physical";
  return feedid::status_name(r.status);
}

std::vector<std::string> implausible_magnitudes(const IdentifyResult& r) {
  if (r.status != feedid::Status::ok) return {};
  return implausible_parameters(to_drive_params(r.estimate), r.units, r.config.velocity_max_m_s);
}

namespace {
/// How many standard errors (of both) the stated lag lies from a search's.
double stated_lag_off_by(const Signals& s, const Signals::SearchedLag& f) {
  const double se = std::hypot(s.force_lag_se_s, f.se_s);
  return se > 0 ? std::fabs(s.force_lag_s - f.lag_s) / se : std::numeric_limits<double>::infinity();
}

/// Where a stated lag lies beyond what the search beside it allows: more
/// than three standard errors of both (the stated one's, if any) and more
/// than kLagAccuracy from the lag the data show (0.2 periods off put m 4
/// of its standard errors off on a 2 kHz ladder). Not where the search is
/// told only by the reversals: there its own bias (0.1-0.18 ms on a single
/// tone at 2 kHz) is not in its error. Empty where it agrees.
std::string stated_lag_contradicted(const Signals& s) {
  const Signals::SearchedLag& f = s.searched_force_lag;
  const bool stated = s.force_lag_origin == Signals::LagOrigin::option || s.force_lag_origin == Signals::LagOrigin::convention;
  if (!stated || !std::isfinite(f.lag_s)) return "";
  if (f.absorbed_by_refit >= kLagToldByReversals) return "";
  const double off = s.force_lag_s - f.lag_s;
  if (!(stated_lag_off_by(s, f) > 3.0 && std::fabs(off) > kLagAccuracy * s.period_s())) return "";
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "the stated force lag (%.3g ms%s) differs by %.2g ms from the lag these data show (%.3g ms +- %.2g ms; "
                "%.1f standard errors%s): m and sigma take up the difference; check %s, or leave it out "
                "to use the lag found",
                1e3 * s.force_lag_s, s.force_lag_origin == Signals::LagOrigin::convention ? ", the named --alignment's" : "", 1e3 * std::fabs(off), 1e3 * f.lag_s, 1e3 * f.se_s, stated_lag_off_by(s, f),
                f.at_range_end ? "; that search stopped at an end of its range, so the data's lag may lie further still" : "",
                s.force_lag_origin == Signals::LagOrigin::convention ? "--alignment" : "--force-lag-s");
  return buf;
}
}  // namespace

void keep_nearer_searched_lag(Signals& s, const Signals::SearchedLag& other) {
  if (!std::isfinite(other.lag_s)) return;
  if (!std::isfinite(s.searched_force_lag.lag_s) || stated_lag_off_by(s, other) < stated_lag_off_by(s, s.searched_force_lag))
    s.searched_force_lag = other;
}

std::vector<std::string> identify_warnings(const IdentifyResult& r) {
  std::vector<std::string> w = implausible_magnitudes(r);
  const double absorbed = r.signals.lag_search.absorbed_by_refit;
  if (r.signals.force_lag_origin == Signals::LagOrigin::estimated && absorbed >= kLagToldByReversals) {
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "the force lag (%.3g ms +- %.2g) is told only by the reversals: refitting friction and mass takes "
                  "back %.0f %% of a shift's residual elsewhere (a motion of one frequency), so m and sigma rest on "
                  "the friction law at low speed; motion with several accelerations at each speed separates them "
                  "(docs/recording.md), or state the lag (--force-lag-s)",
                  1e3 * r.signals.force_lag_s, 1e3 * r.signals.force_lag_se_s, 100.0 * absorbed);
    w.emplace_back(buf);
  }
  if (const std::string c = stated_lag_contradicted(r.signals); !c.empty()) w.push_back(c);
  const LagEstimate& lag = r.signals.lag_search;
  if (r.signals.force_lag_origin == Signals::LagOrigin::estimated && lag.ok && at_range_end(lag)) {
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "the force lag came out at an end of the range searched (%+g periods of the core's velocity, "
                  "%.3g ms): the force may lag further, a delay beyond any logging convention, and m and sigma "
                  "absorb the rest of it; state it (--force-lag-s) where it is known, or see the delay diagnose names",
                  lag.lag_samples, 1e3 * r.signals.force_lag_s);
    w.emplace_back(buf);
  }
  return w;
}

SysIdGains sysid_gains(const IdentifyResult& r) {
  const auto& e = r.estimate;
  const auto& p = e.pos;
  const auto& n = e.neg;
  SysIdGains g;
  g.kA = e.mass_kg;
  g.kA_se = e.mass_se_kg;
  if (p.friction_identified() != n.friction_identified()) {
    // One direction only (a SysId forward or backward test on its own):
    // averaging in the other's zeros halved kS and kV, and kG needs both.
    const auto& seen = p.friction_identified() ? p : n;
    g.direction = p.friction_identified() ? "positive" : "negative";
    g.kS = seen.coulomb_N;
    g.kS_se = seen.coulomb_se;
    g.kV = seen.viscous_Ns_m;
    g.kV_se = seen.viscous_se;
    g.kG = g.kG_se = std::numeric_limits<double>::quiet_NaN();
    return g;
  }
  g.kS = 0.5 * (p.coulomb_N + n.coulomb_N);
  g.kG = 0.5 * (p.coulomb_N - n.coulomb_N);
  g.kS_se = g.kG_se = 0.5 * std::hypot(p.coulomb_se, n.coulomb_se);
  g.kV = 0.5 * (p.viscous_Ns_m + n.viscous_Ns_m);
  g.kV_se = 0.5 * std::hypot(p.viscous_se, n.viscous_se);
  return g;
}

namespace {
/// JSON `sysid` for a force in volts (SysId's gains in its own names), else null.
nlohmann::json sysid_json(const IdentifyResult& r) {
  if (r.units.force != "V" || r.status != feedid::Status::ok) return nullptr;
  const SysIdGains g = sysid_gains(r);
  const Units& u = r.units;
  auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  nlohmann::json j{{"kS", g.kS}, {"kS_se", g.kS_se}, {"kV", g.kV}, {"kV_se", g.kV_se}, {"kA", g.kA}, {"kA_se", g.kA_se},
                   {"kG", number(g.kG)}, {"kG_se", number(g.kG_se)},
                   {"units", {{"kS", u.force}, {"kV", u.viscous()}, {"kA", u.mass()}, {"kG", u.force}}},
                   {"rule", "V = kS sgn(v) + kV v + kA a + kG: kS and kV the means of the two directions' Coulomb and "
                            "viscous terms, kG half the difference of the Coulomb terms (a constant load such as an "
                            "elevator's gravity), kA the mass; the Stribeck terms have no SysId counterpart"}};
  if (!g.direction.empty())
    j["note"] = "only the " + g.direction + " direction moved: kS and kV are its Coulomb and viscous terms, and kG, "
                "which needs both directions, is not identifiable (null)";
  return j;
}
}  // namespace

std::string not_physical_cause(const IdentifyResult& r) {
  if (not_physical(r).empty()) return "";
  const auto& e = r.estimate;
  const auto& p = e.pos;
  const auto& n = e.neg;
  if (e.mass_kg < 0 && p.coulomb_N < 0 && n.coulomb_N < 0)
    return "every term is negative: the force was taken with the wrong sign (--force-scale -1 reverses it)";
  const bool pos_low = p.coulomb_N < -2.0 * p.coulomb_se && n.coulomb_N > 0;
  const bool neg_low = n.coulomb_N < -2.0 * n.coulomb_se && p.coulomb_N > 0;
  if (pos_low || neg_low) {
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "one direction's Coulomb force is negative and the other's larger: a constant load force (gravity on "
                  "an inclined or vertical axis, a counterweight, cable drag, a sensor offset) of about %.3g %s adds "
                  "to one direction and takes from the other; without it the Coulomb force is about %.3g %s. "
                  "`feedid diagnose` fits it as an offset",
                  0.5 * (p.coulomb_N - n.coulomb_N), r.units.force.c_str(), 0.5 * (p.coulomb_N + n.coulomb_N),
                  r.units.force.c_str());
    return buf;
  }
  return "a negative term within about two standard errors of zero: the data do not resolve it; a zero mass or "
         "friction: the force carries no signal";
}

namespace {
nlohmann::json gravity_json(const IdentifyResult& r) {
  const GravityFit& g = r.gravity;
  nlohmann::json j = {{"form", gravity_name(g.form)}, {"note", g.note}};
  if (g.form == GravityTerm::none) return j;
  j["G"] = g.G;
  j["G_se"] = g.G_se;
  j["units"] = {{"G", r.units.force}};
  if (g.form == GravityTerm::angle) {
    j["angle0_rad"] = g.angle0_rad;
    j["angle0_se_rad"] = g.angle0_se_rad;
    j["rule"] = "u = m a + F(v) + G cos(q - angle0): taken off the force before the friction fit";
  } else {
    j["rule"] = "u = m a + F(v) + G: taken off the force before the friction fit";
  }
  return j;
}
}  // namespace

nlohmann::json to_json(const IdentifyResult& r) {
  const auto& e = r.estimate;
  const auto& g = r.diagnostics;
  nlohmann::json j;
  j["status"] = status_word(r);
  if (!r.error.empty()) j["error"] = r.error;
  const std::string unphysical = not_physical(r);
  j["physical"] = unphysical.empty();
  if (!unphysical.empty()) {
    j["not_physical"] = unphysical;
    j["not_physical_cause"] = not_physical_cause(r);
  }
  j["method"] = e.method == feedid::Method::paper ? "paper" : "bands";
  j["m"] = e.mass_kg;
  j["m_se"] = e.mass_se_kg;
  j["m_identifiable"] = e.mass_identified();
  j["m_flags"] = flag_names(e.mass_flags);
  j["pos"] = direction_json(e.pos);
  j["neg"] = direction_json(e.neg);
  j["model"] = friction_model_json(r);
  j["sysid"] = sysid_json(r);
  if (r.gravity.form != GravityTerm::none || !r.gravity.note.empty()) j["gravity"] = gravity_json(r);
  j["warnings"] = identify_warnings(r);
  j["fit"] = {{"friction_r2", std::min(e.pos.friction_r2, e.neg.friction_r2)},
              {"friction_r2_pos", e.pos.friction_r2}, {"friction_r2_neg", e.neg.friction_r2},
              // null where not computed (streamed): a 0 read as a perfect fit
              {"rms_force_residual_N", r.streamed ? nlohmann::json() : nlohmann::json(r.residual_rms_N)},
              {"residual_block_s", r.streamed ? nlohmann::json() : nlohmann::json(r.residual_block_s)},
              {"force_noise_N", e.force_noise_N}};
  nlohmann::json rej = nlohmann::json::array();
  for (const auto& x : r.first_rejections) rej.push_back({{"sample", x.sample}, {"status", feedid::status_name(x.status)}});
  j["counts"] = {{"samples", r.signals.t.size()}, {"accepted", g.samples_accepted}, {"rejected", g.samples_rejected},
                 {"rejected_not_finite", g.rejected_not_finite},
                 {"rejected_time_not_increasing", g.rejected_time_not_increasing},
                 {"rejected_out_of_range", g.rejected_out_of_range},
                 {"rejected_velocity_jump", g.rejected_velocity_jump}, {"first_rejections", rej},
                 {"sections_pos", g.sections_complete[0]}, {"sections_neg", g.sections_complete[1]},
                 {"sections_short", g.sections_short}, {"sections_split", g.sections_split},
                 {"mass_windows", g.mass_windows}, {"continuity_breaks", g.continuity_breaks},
                 {"core_passes", r.core_passes}};
  const auto& c = r.config;
  j["input"] = {{"duration_s", r.duration_s}, {"sample_rate_hz", r.signals.sample_rate_hz},
                {"time_origin_s", r.time_origin_s},
                {"velocity", r.signals.velocity_origin},
                {"velocity_filter_hz", r.signals.velocity_filter_hz > 0 ? nlohmann::json(r.signals.velocity_filter_hz) : nlohmann::json()},
                {"velocity_filter_rivals_hz", r.signals.velocity_filter_rivals_hz},
                {"position", r.signals.position_origin},
                {"position_hold_rows", r.signals.position_hold_rows},
                {"position_wrap_period", r.signals.position_wrap.found() ? nlohmann::json(r.signals.position_wrap.period) : nlohmann::json()},
                {"position_unwraps", r.signals.position_wrap.wraps},
                {"velocity_hold_rows", r.signals.velocity_hold_rows},
                {"held_values_spread", r.signals.held_values_spread},
                {"force_lag_s", r.signals.force_lag_s}, {"force_lag_se_s", r.signals.force_lag_se_s},
                {"force_lag_absorbed_by_refit", std::isfinite(r.signals.lag_search.absorbed_by_refit)
                                                    ? nlohmann::json(r.signals.lag_search.absorbed_by_refit) : nlohmann::json()},
                {"force_lag_origin", lag_origin_name(r.signals.force_lag_origin)}, {"force_convention", r.signals.force_convention},
                {"force_sign", r.signals.force_sign.sign}, {"force_sign_origin", r.signals.force_sign.describe()},
                {"force_sign_ratio", std::isfinite(r.signals.force_sign.ratio) ? nlohmann::json(r.signals.force_sign.ratio) : nlohmann::json()},
                {"velocity_lag_s", std::isfinite(r.signals.velocity_lag_s) ? nlohmann::json(r.signals.velocity_lag_s) : nlohmann::json()},
                {"velocity_delay_samples", r.signals.velocity_delay_samples},
                {"velocity_column_gain", std::isfinite(r.signals.velocity_column_gain) ? nlohmann::json(r.signals.velocity_column_gain) : nlohmann::json()},
                {"velocity_column_used", r.signals.has_velocity_column},
                {"position_quantum_m", r.signals.position_quantum_m},
                {"rows_skipped", r.rows_skipped}, {"rows_repeated", r.rows_repeated}, {"skipped_rows", r.skipped_rows},
                {"force_outlier_rows", r.force_outliers.rows}, {"force_outlier_limit", r.force_outliers.limit},
                {"force_outliers", r.force_outliers.first},
                {"force_saturation", r.force_outliers.saturation.to_json()},
                {"position_spike_rows", r.force_outliers.position_spikes.rows},
                {"position_spikes", r.force_outliers.position_spikes.first}};
  if (r.streamed)
    j["input"]["streamed"] = "read row by row: force lag, velocity filter and band edges from the first 60 s; standard "
                             "errors from a jackknife over ten groups of 10 s blocks dealt round-robin, and the timing "
                             "term measured on the first 60 s; no block refit of m";
  if (!r.runs.empty()) {
    nlohmann::json runs = nlohmann::json::array();
    for (std::size_t i = 0; i < r.runs.size(); ++i) {
      const TraceRun& run = r.runs[i];
      nlohmann::json jr = {{"source", run.source}, {"samples", run.samples}, {"time_shift_s", run.time_shift_s},
                           {"time_origin_s", run.time_origin_s},
                           {"rows_skipped", run.rows_skipped}, {"rows_repeated", run.rows_repeated}};
      if (i < r.run_diagnostics.size()) {
        const feedid::Diagnostics& d = r.run_diagnostics[i];
        jr["core"] = {{"samples_accepted", d.samples_accepted}, {"samples_rejected", d.samples_rejected},
                      {"sections_complete", {{"pos", d.sections_complete[0]}, {"neg", d.sections_complete[1]}}},
                      {"sections_split", d.sections_split}, {"sections_short", d.sections_short},
                      {"mass_windows", d.mass_windows}};
      }
      runs.push_back(jr);
    }
    j["input"]["runs"] = runs;
    j["input"]["runs_rule"] = "each file is its own run: the time jumps by 10 s between runs, a gap no section, window "
                              "or integral spans";
  }
  // The configuration the core ran with (Estimator::config(), defaults filled by init()).
  j["config"] = {{"velocity_min_m_s", c.velocity_min_m_s}, {"velocity_max_m_s", c.velocity_max_m_s},
                 {"velocity_resolution_m_s", c.velocity_resolution_m_s}, {"section_enter_m_s", c.section_enter_m_s},
                 {"mass_window_s", c.mass_window_s}, {"max_step_speed_ratio", c.max_step_speed_ratio},
                 {"max_force_N", c.max_force_N},
                 {"max_acceleration_m_s2", c.max_acceleration_m_s2}, {"max_gap_s", c.max_gap_s},
                 {"stribeck_search_m_s", {feedid::analysis::stribeck_lo(c), feedid::analysis::stribeck_hi(c)}},
                 {"force_lag_samples", c.force_lag_samples}};
  nlohmann::json curve;
  for (int d = 0; d < 2; ++d) {
    nlohmann::json pts = nlohmann::json::array();
    for (const auto& p : r.friction_curve[d]) pts.push_back({p.speed_m_s, p.friction_N, p.time_s});
    curve[d == 0 ? "pos" : "neg"] = pts;
  }
  curve["columns"] = {"speed_m_s", "friction_N", "time_s"};
  j["friction_curve"] = curve;
  j["mass_from_windows_kg"] = r.mass_from_windows_kg;
  j["standard_errors"] = {{"order", {"m", "pos.sigma", "pos.fc", "pos.fs", "pos.vs", "neg.sigma", "neg.fc", "neg.fs", "neg.vs"}},
                           {"jackknife_chunks", r.jackknife_chunks}, {"core", r.se_model},
                           // null where none was formed: no chunks (the core's own serve), no cut-off scan (streamed)
                           {"jackknife", r.jackknife_chunks > 0 ? nlohmann::json(r.se_jackknife) : nlohmann::json()},
                           {"timing", r.se_timing},
                           {"velocity_cutoff", r.streamed ? nlohmann::json() : nlohmann::json(r.se_cutoff)}};
  j["units"] = units_json(r.units);
  return j;
}

std::string summary(const IdentifyResult& r, const DriveParams* truth) {
  std::ostringstream o;
  const auto& e = r.estimate;
  char buf[256];
  o << "method " << (e.method == feedid::Method::paper ? "paper" : "bands") << ", status "
    << status_word(r) << "; "
    << (r.streamed ? r.diagnostics.samples_accepted + r.diagnostics.samples_rejected : r.signals.t.size())
    << (r.streamed ? " samples streamed, " : " samples, ") << r.duration_s << " s at "
    << r.signals.sample_rate_hz << " Hz; velocity " << r.signals.velocity_origin << "\n";
  if (r.signals.position_hold_rows > 1 || r.signals.position_wrap.found()) o << "  position " << r.signals.position_origin << "\n";
  const std::string unphysical = not_physical(r);
  if (!unphysical.empty())
    o << "  NOT PHYSICAL: " << unphysical << " (m must be positive, Fc and sigma not negative)\n";
  for (const std::string& w : identify_warnings(r)) o << "  WARNING: " << w << "\n";
  if (r.force_outliers.position_spikes.rows > 0) o << "  " << r.force_outliers.position_spikes.describe(r.units.position) << "\n";
  if (r.force_outliers.saturation.found()) o << "  force " << r.force_outliers.saturation.describe(r.units.force) << "\n";
  if (r.force_outliers.rows > 0) o << "  force: " << r.force_outliers.describe(r.units.force) << "\n";
  if (r.signals.force_sign.sign < 0 || !r.signals.force_sign.conclusive)
    o << "  force " << r.signals.force_sign.describe() << "\n";
  if (r.gravity.form != GravityTerm::none) {
    const Rounded G = round_to_se(r.gravity.G, r.gravity.G_se), q0 = round_to_se(r.gravity.angle0_rad, r.gravity.angle0_se_rad);
    o << "  gravity " << (r.gravity.form == GravityTerm::angle ? "G cos(q - q0)" : "G") << ": G " << G.value << " +- " << G.se
      << " " << r.units.force;
    if (r.gravity.form == GravityTerm::angle) o << ", q0 " << q0.value << " +- " << q0.se << " rad";
    o << " (taken off the force before the friction fit)\n";
  } else if (!r.gravity.note.empty()) {
    o << "  gravity " << r.gravity.note << "\n";
  }
  const Units& u = r.units;
  auto line = [&](const char* name, const std::string& unit_text, double v, double se, double t, bool ok) {
    const char* unit = unit_text.c_str();
    const Rounded x = round_to_se(v, se);  // the digits se justifies
    if (truth)
      std::snprintf(buf, sizeof buf, "  %-22s %12s %-10s +- %-10s truth %-11.6g err %+7.3f %%%s\n", name, x.value.c_str(), unit,
                    x.se.c_str(), t, t != 0 ? 100.0 * (v / t - 1.0) : 0.0, ok ? "" : "  NOT IDENTIFIABLE");
    else
      std::snprintf(buf, sizeof buf, "  %-22s %12s %-10s +- %-10s%s\n", name, x.value.c_str(), unit, x.se.c_str(),
                    ok ? "" : "  NOT IDENTIFIABLE");
    o << buf;
  };
  line("mass m", u.mass(), e.mass_kg, e.mass_se_kg, truth ? truth->mass_kg : 0, e.mass_identified());
  for (int d = 0; d < 2; ++d) {
    const auto& de = d == 0 ? e.pos : e.neg;
    const DirectionFriction* td = truth ? (d == 0 ? &truth->pos : &truth->neg) : nullptr;
    const char* s = d == 0 ? "+" : "-";
    std::string n;
    n = std::string("viscous sigma") + s; line(n.c_str(), u.viscous(), de.viscous_Ns_m, de.viscous_se, td ? td->viscous_Ns_m : 0, de.viscous_identified());
    n = std::string("Coulomb Fc") + s; line(n.c_str(), u.force, de.coulomb_N, de.coulomb_se, td ? td->coulomb_N : 0, de.coulomb_identified());
    n = std::string("break-away Fs") + s; line(n.c_str(), u.force, de.breakaway_N, de.breakaway_se, td ? td->breakaway_N : 0, de.stribeck_identified());
    n = std::string("Stribeck vel. vs") + s; line(n.c_str(), u.velocity(), de.stribeck_velocity_m_s, de.stribeck_velocity_se, td ? td->stribeck_velocity_m_s : 0, de.stribeck_identified());
    if (de.flags) {
      o << "    flags:";
      for (const auto& f : flag_names(de.flags)) o << " " << f;
      o << "\n";
    }
    if (!r.friction_model[static_cast<std::size_t>(d)].reason.empty())
      o << "    model: " << r.friction_model[static_cast<std::size_t>(d)].reason << "\n";
  }
  const SymmetricFriction sym = symmetric_friction(r);
  if (sym.agree) {
    const Rounded fc = round_to_se(sym.coulomb_N, sym.coulomb_se), sg = round_to_se(sym.viscous_Ns_m, sym.viscous_se);
    o << "  the directions agree within 2 standard errors: symmetric Coulomb " << fc.value << " +- " << fc.se << " "
      << u.force << (sym.coulomb_identified() ? "" : " (not identifiable: its standard error is over 25 % of it)")
      << ", viscous " << sg.value << " +- " << sg.se << " " << u.viscous()
      << (sym.viscous_identified() ? "" : " (not identifiable: its standard error is over 25 % of it)") << "\n";
  }
  if (r.units.force == "V" && r.status == feedid::Status::ok) {
    const SysIdGains g = sysid_gains(r);
    const Rounded ks = round_to_se(g.kS, g.kS_se), kv = round_to_se(g.kV, g.kV_se), ka = round_to_se(g.kA, g.kA_se),
                  kg = round_to_se(g.kG, g.kG_se);
    o << "  SysId gains: kS " << ks.value << " +- " << ks.se << " " << u.force << ", kV " << kv.value << " +- " << kv.se
      << " " << u.viscous() << ", kA " << ka.value << " +- " << ka.se << " " << u.mass();
    if (g.direction.empty())
      o << ", kG " << kg.value << " +- " << kg.se << " " << u.force << "\n";
    else
      o << " (the " << g.direction << " direction's alone: the only one that moved); kG not identifiable\n";
  }
  std::snprintf(buf, sizeof buf, "  friction curve R^2 %.5f (+) %.5f (-); ", e.pos.friction_r2, e.neg.friction_r2);
  o << buf;
  if (r.streamed) {
    o << "block residual not computed (streamed); ";
  } else {
    std::snprintf(buf, sizeof buf, "RMS force residual %.3g %s over %.0f ms blocks; ", r.residual_rms_N, u.force.c_str(),
                  1e3 * r.residual_block_s);
    o << buf;
  }
  std::snprintf(buf, sizeof buf, "force noise %.3g %s\n", e.force_noise_N, u.force.c_str());
  o << buf;
  const bool unresolved = !e.mass_identified() || !e.pos.friction_identified() || !e.neg.friction_identified() ||
                          !e.pos.stribeck_identified() || !e.neg.stribeck_identified();
  if (unresolved && r.status == feedid::Status::ok)
    o << "  what each parameter needs from the recording: docs/recording.md\n";
  const auto& g = r.diagnostics;
  o << "  sections: " << g.sections_complete[0] << " positive, " << g.sections_complete[1] << " negative; "
    << g.mass_windows << " mass windows; " << g.samples_rejected << " samples rejected\n";
  return o.str();
}

}  // namespace feedid::host
