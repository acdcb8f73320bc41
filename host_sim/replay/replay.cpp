// Closed-loop replay (replay.hpp).
#include "replay.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "io/beside.hpp"
#include "io/trace_files.hpp"
#include "signals/filters.hpp"
#include "sim/plant.hpp"

namespace feedid::host {
namespace {

std::string at_time(double t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g s", t);
  return buf;
}

/// The trace's columns with `column` read through the position slot,
/// scaled by `scale`. The reader needs position or velocity: the time
/// column stands in for velocity, so that a missing column reads as
/// has_position false.
CsvColumns through_position(const CsvColumns& cols, const std::string& column, double scale) {
  CsvColumns c = cols;
  c.position = column;
  c.velocity = cols.time;
  c.position_scale = scale;
  c.position_scale_stated = true;
  c.named_columns_required = false;  // read_column names a missing column itself
  return c;
}

/// The file's header as the reader names it where `column` is not in it
/// ("header has: 't_s', 'qm_m', ..."), or empty: a typo in the controller's
/// optional column then shows beside the names it missed.
std::string header_without(const std::string& path, const CsvColumns& cols, const std::string& column) {
  CsvColumns c = through_position(cols, column, 1.0);
  c.named_columns_required = true;
  const std::string error = read_trace_file(path, c).error;
  const std::size_t at = error.find("header has: ");
  return at == std::string::npos ? std::string() : error.substr(at);
}

/// The first row (from 0) at which `read` keeps another time than `t`
/// (a row beyond t's end counts); read's size where every row agrees.
std::size_t first_other_row(const Trace& read, const std::vector<double>& t) {
  for (std::size_t k = 0; k < read.samples.size(); ++k)
    if (k >= t.size() || read.samples[k].t_s != t[k]) return k;
  return read.samples.size();
}

/// One column of the file as the trace reader reads it (same rows, same
/// rules), through its position slot; `scale` as position_scale. Empty
/// when the file has no such column and it is `optional`.
Outcome<std::vector<double>> read_column(const std::string& path, const CsvColumns& cols, const std::string& column,
                                const std::string& role, double scale, const std::vector<double>& t, bool optional) {
  const CsvResult r = read_trace_file(path, through_position(cols, column, scale));
  using Column = std::vector<double>;
  if (r.ok && !r.trace.has_position && optional) return {};
  if (!r.ok || !r.trace.has_position)
    return refused<Column>(path + ": the " + role + " column '" + column + "' (from the controller file) cannot be read" +
                           (r.ok ? ": no such column" : ": " + r.error));
  const std::size_t other = first_other_row(r.trace, t);
  // A row the trace kept but this column's read skipped: the reader's own
  // words name the file, the line and why ("value is NaN/Inf").
  if (other < r.trace.samples.size() && !r.trace.skipped_rows.empty())
    return refused<Column>(path + ": the " + role + " column '" + column + "' (from the controller file) has a bad row " +
                           "the other columns do not: " + r.trace.skipped_rows.front());
  if (other < r.trace.samples.size())
    return refused<Column>(path + ": reading the " + role + " column '" + column +
                           "' kept other rows than the trace (a bad value in one column only?): first differs at row " +
                           std::to_string(other + 1));
  if (r.trace.samples.size() != t.size())
    return refused<Column>(path + ": the " + role + " column '" + column + "' has fewer usable rows than the trace");
  Outcome<Column> y;
  y.value.reserve(t.size());
  for (const TraceSample& s : r.trace.samples) y.value.push_back(s.x_m);
  return y;
}

/// Sums of squares for one relative error, 100 ||y - y_sim|| / ||y||.
struct RelativeError {
  double error = 0.0, norm = 0.0;
  /// One sample: the difference and the signal it is relative to.
  void add(double difference, double y) {
    error += difference * difference;
    norm += y * y;
  }
  /// NaN (null in JSON) when the measured signal is zero throughout: no error relative to it.
  double pct() const { return norm > 0.0 ? 100.0 * std::sqrt(error / norm) : std::nan(""); }
};

/// The four figures of measured (x, v, a, u) against simulated series over
/// samples first.. (the errors' norms are the measured signals').
/// The four signals' series, read in place.
using FourSeries = std::array<const std::vector<double>*, 4>;

/// 100 ||a - b|| / ||y|| for each of the four signals, over the samples
/// `counted(k)` keeps (y's length at most).
template <class Counted>
ReplayFigures relative_errors(const FourSeries& y, const FourSeries& a, const FourSeries& b, Counted counted) {
  RelativeError e[4];
  for (std::size_t s = 0; s < 4; ++s)
    for (std::size_t k = 0; k < y[s]->size(); ++k)
      if (counted(k)) e[s].add((*a[s])[k] - (*b[s])[k], (*y[s])[k]);
  return {e[0].pct(), e[1].pct(), e[2].pct(), e[3].pct()};
}

/// The processing of the protocol on a position: zero-phase Butterworth,
/// then central differences for velocity and acceleration.
void process_position(const std::vector<double>& x, const std::vector<double>& t, double filter_hz, double rate_hz,
                      std::vector<double>& xf, std::vector<double>& v, std::vector<double>& a) {
  xf = filtfilt_butter4(x, applied_cutoff_hz(filter_hz, rate_hz), rate_hz);
  v = central_difference(xf, t);
  a = central_difference(v, t);
}

/// A step this many periods long has lost a row: the loop is replayed at
/// every period from the logged reference, and the figures are taken
/// sample by sample, so a lost row put every later sample one period off
/// (one row missing from EMPS PULSES took its acceleration error from 18 %
/// to 50 %). Clock jitter stays well below it.
constexpr double kLostRowStep = 1.5;

/// The sample period of a run that must be continuous: its median step,
/// or an error naming the first gap or lost row (a replay cannot bridge one).
Outcome<double> continuous_period(const LoggedRun& run) {
  const double dt = median_step(run.t);
  const double limit = max_step_s(dt);
  for (std::size_t k = 1; k < run.t.size(); ++k) {
    const double step = run.t[k] - run.t[k - 1];
    if (step > limit)
      return refused<double>(run.source + ": a gap of " + at_time(step) + " at t = " + at_time(run.t[k - 1]) +
                             ": a replay needs one continuous recording");
    if (step > kLostRowStep * dt) {
      char periods[32];
      std::snprintf(periods, sizeof periods, "%.3g", step / dt);
      return refused<double>(run.source + ": rows missing after t = " + at_time(run.t[k - 1]) + " (a step of " +
                             periods + " periods: a bad row skipped, or a row the logger dropped); a replay runs the " +
                             "drive's loop at every period and needs every row");
    }
  }
  return {dt, ""};
}

/// The plant's effects: the model's load (its constant force and an arm's
/// weight) added to those asked for.
Effects with_load(const ModelLoad& load, Effects e) {
  e.load.offset_N += load.offset_N;
  if (load.gravity_N != 0.0) {
    e.load.gravity_N = load.gravity_N;
    e.load.gravity_angle0_rad = load.gravity_angle0_rad;
  }
  return e;
}

/// The drive's loop around the model's plant, one sample at a time.
class LoopReplay {
 public:
  LoopReplay(const ModelFile& m, const Controller& c, const Gains& g, double dt, int substeps, const ReplayOptions& opt)
      : c_(c), g_(g), dt_(dt), substeps_(substeps), fx_(with_load(m.load, opt.effects)), extra_(opt.extra_force),
        plant_(m.drive, fx_, extra_, no_change_, true), vel_(c.position_fir, dt),
        commands_(static_cast<std::size_t>(c.delay_samples) + 1, 0.0) {}
  void start_at(double x) { plant_.start_at(x); }

  /// Samples the plant at t_k, runs the loop, records x, v, a and the
  /// force into sample k of r, then integrates over the period.
  void sample(std::size_t k, double t, double r_k, double extra_k, ReplayResult& r) {
    const double q = plant_.x();
    const double ev = g_.kp * (r_k - q) - vel_.next(q);
    const double raw = g_.kv * ev + g_.ki * integral_;
    // Conditional integration: the integral stops growing into the limit.
    if (!(std::fabs(raw) > c_.saturation && raw * ev > 0.0)) integral_ += ev * dt_;
    // Computation delay: the command of k - delay reaches the plant at k (0 before the first).
    std::rotate(commands_.rbegin(), commands_.rbegin() + 1, commands_.rend());
    commands_[0] = raw;
    const double delayed = commands_.back();
    if (std::fabs(delayed) >= c_.saturation) ++r.saturated_samples;
    const double force = c_.drive_gain * (std::clamp(delayed, -c_.saturation, c_.saturation) + extra_k);
    r.x_sim[k] = q;
    r.v_sim[k] = plant_.v();
    r.a_sim[k] = plant_.acceleration(t, force);
    r.u_sim[k] = force;
    if (plant_.v() == 0.0 && r.a_sim[k] == 0.0) ++r.stuck_samples;
    const double h = dt_ / substeps_;
    for (int j = 0; j < substeps_; ++j) plant_.step(t + j * h, h, force);
  }

 private:
  const Controller& c_;
  Gains g_;
  double dt_;
  int substeps_;
  Effects fx_{};
  ExtraForce extra_{};
  ServiceChange no_change_{};
  DrivePlant plant_;
  VelocityEstimate vel_;
  std::vector<double> commands_;  ///< raw commands, newest first, delay_samples + 1 long
  double integral_ = 0.0;         ///< running integral of the velocity error (p_pi)
};

/// opt, with the model file's own effects in the plant where opt brings
/// none (diagnose --model replays its base without them, then with the
/// effects it names); each of the model's effects said in notes. Refused
/// where an effect's parameters are not what the plant can take.
Outcome<ReplayOptions> with_model_effects(const ModelFile& model, const ReplayOptions& opt, std::vector<std::string>& notes) {
  if (model.effects.empty() || !active_effects(opt.effects).empty() || opt.extra_force) return {opt, ""};
  const PlantEffects pe = plant_effects(model.effects, model.drive.mass_kg);
  if (!pe.error.empty())
    return refused<ReplayOptions>(model.source + ": " + pe.error + " (the model's effects, as the replay's plant takes them)");
  for (const PlantEffect& e : pe.list) notes.push_back("the model's effect " + e.kind + ": " + e.note);
  return {with_plant_effects(opt, pe), ""};
}

/// The fastest the logged axis moves (m/s): its largest speed over one
/// step, each the median of five in a row, so that one bad sample (two
/// steps off) or a rotary encoder's wrap (one) does not set it. A run too
/// short for five: the largest step speed.
double top_speed(const LoggedRun& run) {
  std::vector<double> speed;
  for (std::size_t k = 1; k < run.x.size(); ++k) speed.push_back(std::fabs(run.x[k] - run.x[k - 1]) / (run.t[k] - run.t[k - 1]));
  if (speed.size() < 5) return speed.empty() ? 0.0 : *std::max_element(speed.begin(), speed.end());
  double top = 0.0;
  for (std::size_t k = 0; k + 5 <= speed.size(); ++k) {
    std::array<double, 5> five;
    std::copy_n(speed.begin() + static_cast<std::ptrdiff_t>(k), 5, five.begin());
    std::nth_element(five.begin(), five.begin() + 2, five.end());
    top = std::max(top, five[2]);
  }
  return top;
}

/// The plant's shortest time scale (s) at the run's top speed.
double plant_time_scale(const ModelFile& model, const LoggedRun& run, const ReplayOptions& opt) {
  return shortest_time_scale_s(model.drive, with_load(model.load, opt.effects), opt.extra_scales, top_speed(run));
}

/// Plant steps per sample: opt's, or the fewest that resolve the plant's
/// shortest time scale tau (a note where they cannot).
int plant_substeps(const ReplayOptions& opt, double tau, double dt, std::vector<std::string>& notes) {
  if (opt.substeps > 0) return opt.substeps;
  const double steps = std::ceil(kStepsPerTimeScale * dt / tau);
  if (!(steps <= kMaxAutomaticSubsteps)) {
    notes.push_back("the plant's shortest time scale, " + at_time(tau) + ", is not resolved: " +
                    std::to_string(kMaxAutomaticSubsteps) + " steps per sample at most (a model far off?)");
    return kMaxAutomaticSubsteps;
  }
  return std::max(1, static_cast<int>(steps));
}

/// The model in the loop over the run, with the plant's effects `with`:
/// x, v, a and force at every sample into r (r.gains, r.dt_s and
/// r.substeps set); r.error where the simulation left the finite numbers.
void simulate_in_loop(const ModelFile& model, const Controller& c, const LoggedRun& run, const ReplayOptions& with,
                      ReplayResult& r) {
  const std::size_t n = run.t.size();
  r.x_sim.resize(n);
  r.v_sim.resize(n);
  r.a_sim.resize(n);
  r.u_sim.resize(n);
  LoopReplay loop(model, c, r.gains, r.dt_s, r.substeps, with);
  loop.start_at(run.x.front());
  for (std::size_t k = 0; k < n; ++k) {
    loop.sample(k, static_cast<double>(k) * r.dt_s, run.reference[k], run.extra.empty() ? 0.0 : run.extra[k], r);
    // Stops at the first non-finite sample: the rest would be NaN as well.
    if (!std::isfinite(r.x_sim[k]) || !std::isfinite(r.v_sim[k]) || !std::isfinite(r.a_sim[k]) ||
        !std::isfinite(r.u_sim[k])) {
      r.error = run.source + ": the simulated axis left the finite numbers at t = " + at_time(run.t[k]) +
                " (a model or controller value far off?)";
      return;
    }
  }
}

/// The three rows of figures, and the compared series (after drop_first) for plots.
void compare_with_run(const LoggedRun& run, const ReplayOptions& opt, ReplayResult& r) {
  const double rate = 1.0 / r.dt_s;
  r.filter_applied_hz = applied_cutoff_hz(opt.filter_hz, rate);
  if (std::string n = cutoff_note(opt.filter_hz, r.filter_applied_hz, "both positions were"); !n.empty()) r.notes.push_back(std::move(n));
  std::vector<double> xf, v, a, xsf, vs, as;
  process_position(run.x, run.t, opt.filter_hz, rate, xf, v, a);
  process_position(r.x_sim, run.t, opt.filter_hz, rate, xsf, vs, as);
  const std::size_t first = static_cast<std::size_t>(opt.drop_first);
  const FourSeries meas = {&xf, &v, &a, &run.u};
  const FourSeries state = {&r.x_sim, &r.v_sim, &r.a_sim, &r.u_sim};
  const FourSeries processed = {&xsf, &vs, &as, &r.u_sim};
  const auto compared = [first](std::size_t k) { return k >= first; };
  r.error_pct = relative_errors(meas, meas, state, compared);
  r.same_processing_pct = relative_errors(meas, meas, processed, compared);
  // The processing's own share: state against processed, relative to the measured norm.
  r.processing_pct = relative_errors(meas, state, processed, compared);
  // The series from `first` on, moved where nothing else reads them.
  const auto from_first = [first](std::vector<double>& y) {
    y.erase(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(std::min(first, y.size())));
    return std::move(y);
  };
  const auto tail = [first](const std::vector<double>& y) {
    return std::vector<double>(y.begin() + static_cast<std::ptrdiff_t>(std::min(first, y.size())), y.end());
  };
  r.t = tail(run.t);
  r.x = from_first(xf);
  r.v = from_first(v);
  r.a = from_first(a);
  r.u = tail(run.u);
  for (std::vector<double>* y : {&r.x_sim, &r.v_sim, &r.a_sim, &r.u_sim}) *y = from_first(*y);
  r.x_sim_processed = from_first(xsf);
  r.v_sim_processed = from_first(vs);
  r.a_sim_processed = from_first(as);
}

/// Why the replay cannot start: an input's own error, an option out of
/// range, a run too short or with columns of different lengths; empty when
/// it can.
std::string replay_refusal(const ModelFile& model, const Controller& c, const LoggedRun& run, const ReplayOptions& opt) {
  for (const std::string* e : {&model.error, &c.error, &run.error})
    if (!e->empty()) return *e;
  const std::size_t n = run.t.size();
  if (opt.substeps < 0 || opt.substeps > 10000) return "--substeps must be 0 (automatic) to 10000";
  if (opt.drop_first < 0) return "--drop-first must be >= 0";
  if (!(opt.filter_hz > 0.0)) return "--filter must be > 0 Hz";
  if (n < static_cast<std::size_t>(opt.drop_first) + 20)
    return run.source + ": too short to replay: " + std::to_string(n) + " samples, of which --drop-first leaves out " +
           std::to_string(opt.drop_first) + "; at least 20 must be left to compare";
  if (run.x.size() != n || run.u.size() != n || run.reference.size() != n || (!run.extra.empty() && run.extra.size() != n))
    return run.source + ": the replay's columns differ in length";
  return "";
}

}  // namespace

/// The one pass's read (read_reference_and_extra): not ok where the
/// controller names no extra command.
CsvResult reference_and_extra_file(const std::string& path, const CsvColumns& cols, const Controller& c) {
  if (c.extra_command.empty()) return {};
  CsvColumns both = through_position(cols, c.reference, position_scale(cols));
  both.force = c.extra_command;
  both.force_scale = 1.0;
  return read_trace_file(path, both);
}

/// The reference and the extra command of `r` (that pass's read) into
/// run; false, with run untouched, where r failed or kept other rows.
bool take_reference_and_extra(const CsvResult& r, LoggedRun& run) {
  if (!r.ok || !r.trace.has_position || r.trace.samples.size() != run.t.size() ||
      first_other_row(r.trace, run.t) != run.t.size())
    return false;
  run.reference.reserve(run.t.size());
  run.extra.reserve(run.t.size());
  for (const TraceSample& s : r.trace.samples) {
    run.reference.push_back(s.x_m);
    run.extra.push_back(s.u_N);
  }
  return true;
}

bool read_reference_and_extra(const std::string& path, const CsvColumns& cols, const Controller& c, LoggedRun& run) {
  return take_reference_and_extra(reference_and_extra_file(path, cols, c), run);
}

std::future<CsvResult> start_reference_and_extra(const std::string& path, const CsvColumns& cols, const Controller& c,
                                                 bool beside) {
  // A .mat file is read through libmatio and HDF5, which need not be
  // built for two threads at once: its passes run one after the other.
  return run_beside(beside && !is_mat_file(path), [path, cols, c] { return reference_and_extra_file(path, cols, c); });
}

ReplayOptions with_plant_effects(ReplayOptions opt, const PlantEffects& pe) {
  opt.effects = pe.effects;
  opt.extra_force = pe.extra_force;
  opt.extra_scales = pe.extra_scales;
  return opt;
}

LoggedRun read_logged_run(const std::string& path, const CsvColumns& cols, const Controller& c, bool beside) {
  std::future<CsvResult> both = start_reference_and_extra(path, cols, c, beside);
  const CsvResult main = read_trace_file(path, cols);
  return read_logged_run(path, cols, c, main, both.get());
}

LoggedRun read_logged_run(const std::string& path, const CsvColumns& cols, const Controller& c, const CsvResult& main,
                          const CsvResult& both) {
  LoggedRun run;
  run.source = path;
  if (!main.ok) {
    run.error = main.error;
    return run;
  }
  if (!main.trace.has_position) {
    run.error = path + ": no position column '" + cols.position +
                "': a replay compares the simulated position with the measured one (--position)";
    return run;
  }
  // A row the trace reader skipped (a bad position, force or time) is a
  // hole in the loop's run; the reference read keeps it, and its
  // complaint about the rows then blamed the reference column.
  if (main.trace.rows_skipped > 0) {
    run.error = path + ": " + std::to_string(main.trace.rows_skipped) + " row(s) could not be used" +
                (main.trace.skipped_rows.empty() ? "" : ", the first: " + main.trace.skipped_rows.front()) +
                "; a replay runs the drive's loop at every period and needs every row";
    return run;
  }
  for (const TraceSample& s : main.trace.samples) {
    run.t.push_back(s.t_s);
    run.x.push_back(s.x_m);
    run.u.push_back(s.u_N);
  }
  if (take_reference_and_extra(both, run)) return run;
  // Column by column, where the one pass failed: these reads say why.
  Outcome<std::vector<double>> reference = read_column(path, cols, c.reference, "reference", position_scale(cols), run.t, false);
  run.reference = std::move(reference.value);
  run.error = reference.error;
  if (c.extra_command.empty() || !run.error.empty()) return run;
  Outcome<std::vector<double>> extra = read_column(path, cols, c.extra_command, "extra command", 1.0, run.t, true);
  run.extra = std::move(extra.value);
  run.error = extra.error;
  if (run.error.empty() && run.extra.empty()) {
    const std::string header = header_without(path, cols, c.extra_command);
    run.notes.push_back(path + " has no extra command column '" + c.extra_command + "'" +
                        (header.empty() ? std::string() : " (" + header + ")") + ": none is added");
  }
  return run;
}

ReplayResult replay(const ModelFile& model, const Controller& c, const LoggedRun& run, const ReplayOptions& opt,
                    bool fit_always) {
  ReplayResult r;
  r.error = replay_refusal(model, c, run, opt);
  if (!r.error.empty()) return r;
  const Outcome<double> dt = continuous_period(run);
  r.error = dt.error;
  if (!r.error.empty()) return r;
  const std::size_t n = run.t.size();
  r.dt_s = dt.value;
  r.samples = n;
  r.notes = run.notes;
  r.units = opt.units;
  if (fit_always || needs_fit(c)) r.gain_fit = fit_gains(c, run.t, run.x, run.u, run.reference, run.extra);
  const Outcome<Gains> gains = resolve_gains(c, r.gain_fit, r.notes);
  r.gains = gains.value;
  r.error = gains.error;
  if (!r.error.empty()) return r;
  const Outcome<ReplayOptions> with = with_model_effects(model, opt, r.notes);
  r.error = with.error;
  if (!r.error.empty()) return r;
  r.shortest_time_scale_s = plant_time_scale(model, run, with.value);
  r.substeps = plant_substeps(with.value, r.shortest_time_scale_s, r.dt_s, r.notes);
  simulate_in_loop(model, c, run, with.value, r);
  if (!r.error.empty()) return r;
  compare_with_run(run, opt, r);
  r.samples_compared = r.t.size();
  const ReplayFigures& f = r.error_pct;
  for (double pct : {f.position, f.velocity, f.acceleration, f.force})
    if (std::isinf(pct))
      r.error = run.source + ": the simulated axis's errors overflow (a model or controller value far off?)";
  return r;
}

namespace {
nlohmann::json figures_json(const ReplayFigures& f) {
  auto value = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); };
  return {{"position", value(f.position)}, {"velocity", value(f.velocity)}, {"acceleration", value(f.acceleration)},
          {"force", value(f.force)}};
}
nlohmann::json gains_json(const Gains& g, ControlLaw law) {
  nlohmann::json j = {{"kp", g.kp}, {"kv", g.kv}};
  if (law == ControlLaw::p_pi) j["ki"] = g.ki;
  return j;
}

/// The four relative errors of a against b over the kept samples, relative to the measured signals.
ReplayFigures kept_errors(const ReplayResult& r, const FourSeries& a, const FourSeries& b, const std::vector<char>& keep) {
  return relative_errors({&r.x, &r.v, &r.a, &r.u}, a, b, [&keep](std::size_t k) { return k < keep.size() && keep[k]; });
}

}  // namespace

ReplayFigures figures_where(const ReplayResult& r, const std::vector<char>& keep, bool same_processing) {
  const FourSeries meas = {&r.x, &r.v, &r.a, &r.u};
  if (same_processing) return kept_errors(r, meas, {&r.x_sim_processed, &r.v_sim_processed, &r.a_sim_processed, &r.u_sim}, keep);
  return kept_errors(r, meas, {&r.x_sim, &r.v_sim, &r.a_sim, &r.u_sim}, keep);
}

ReplayFigures processing_where(const ReplayResult& r, const std::vector<char>& keep) {
  return kept_errors(r, {&r.x_sim, &r.v_sim, &r.a_sim, &r.u_sim},
                     {&r.x_sim_processed, &r.v_sim_processed, &r.a_sim_processed, &r.u_sim}, keep);
}

nlohmann::json to_json(const ReplayResult& r, const ModelFile& model, const Controller& c, const ReplayOptions& opt) {
  nlohmann::json j;
  j["relative_error_pct"] = figures_json(r.error_pct);
  j["relative_error_same_processing_pct"] = figures_json(r.same_processing_pct);
  j["processing_alone_pct"] = figures_json(r.processing_pct);
  j["comparison"] = {
      {"measured", "position filtered zero-phase by a 4th-order Butterworth, velocity and acceleration by central differences"},
      {"simulated", "position, velocity and acceleration from the plant's state at each sample; force = drive_gain * "
                    "(sat(delayed command) + extra)"},
      {"same_processing", "the simulated position processed as the measured one"},
      {"processing_alone", "simulated state against the same simulation processed, relative to the measured signal"},
      {"filter_hz", r.filter_applied_hz > 0.0 ? r.filter_applied_hz : opt.filter_hz},
      {"filter_requested_hz", opt.filter_hz},
      {"drop_first", opt.drop_first},
      {"relative_error", "100 ||y - y_sim|| / ||y||"}};
  j["controller"] = {{"law", law_name(c.law)}, {"gains", gains_json(r.gains, c.law)},
                     {"gains_from_file", {{"kp", c.kp.has_value()}, {"kv", c.kv.has_value()}, {"ki", c.ki.has_value()}}},
                     {"drive_gain", c.drive_gain}, {"saturation", c.saturation}, {"position_fir", c.position_fir},
                     {"delay_samples", c.delay_samples}, {"reference", c.reference},
                     {"extra_command", c.extra_command.empty() ? nlohmann::json() : nlohmann::json(c.extra_command)}};
  if (r.gain_fit.done)
    j["gain_fit"] = {{"gains", gains_json(r.gain_fit.value, c.law)}, {"standard_errors", gains_json(r.gain_fit.se, c.law)},
                     {"lag_samples", r.gain_fit.lag_samples}, {"samples", r.gain_fit.samples},
                     {"rms_residual", r.gain_fit.rms_residual}, {"rms_command", r.gain_fit.rms_command},
                     {"extra_gain", std::isfinite(r.gain_fit.extra_gain) ? nlohmann::json(r.gain_fit.extra_gain) : nlohmann::json()},
                     {"extra_gain_se", std::isfinite(r.gain_fit.extra_gain_se) ? nlohmann::json(r.gain_fit.extra_gain_se) : nlohmann::json()}};
  nlohmann::json m = model_json(model.drive, r.units);
  put_load(m, model.load);
  if (!model.effects.empty()) m["effects"] = model.effects;
  j["model"] = m;
  j["notes"] = r.notes;
  j["units"] = units_json(r.units);
  const double tau = r.shortest_time_scale_s;
  j["simulation"] = {{"sample_period_s", r.dt_s}, {"substeps", r.substeps}, {"substeps_automatic", opt.substeps == 0},
                     {"shortest_time_scale_s", std::isfinite(tau) ? nlohmann::json(tau) : nlohmann::json()},
                     {"samples", r.samples},
                     {"samples_compared", r.samples_compared}, {"saturated_samples", r.saturated_samples},
                     {"stuck_samples", r.stuck_samples},
                     {"plant", "rigid body, direction-dependent Stribeck friction, Karnopp stick/slip, RK4 with the force held"}};
  return j;
}

}  // namespace feedid::host
