// Friction health from a log of any length. Host only.
#include "monitor.hpp"
#include "io/output_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "io/number_format.hpp"
#include "signals/condition.hpp"
#include "io/svg_plot.hpp"
#include "feedid/small_matrix.hpp"

namespace feedid::host {
namespace {

using Monitor = feedid::ChangeMonitor<double, 64>;

/// The conventions an identified epoch found, to state to the next epochs:
/// searching them on every epoch cost most of monitor's time, and they are
/// the log's, not the epoch's. `searched`: the options that epoch ran with.
LogConventions conventions_of(const IdentifyResult& r, const IdentifyOptions& searched, int epoch) {
  LogConventions c;
  c.fixed = true;
  c.stated = with_conventions_of(r.signals, searched);
  c.found_at_epoch = epoch;
  return c;
}

/// Whether this epoch finds the conventions: none fixed yet, or a re-check
/// due. Re-checks are at least two heads apart, so that short epochs
/// neither search every head nor search inside the batch a head served.
bool conventions_due(const MonitorOptions& opt, const LogConventions& c, int epoch) {
  const int every = opt.recheck_conventions_every;
  const double apart_s = std::max(every * opt.detector.epoch_s, 2.0 * kConventionsHead_s);
  return !c.fixed || (every > 0 && (epoch - c.found_at_epoch) * opt.detector.epoch_s >= apart_s * (1.0 - 1e-9));
}

/// The identify options every epoch starts from: a gravity term only where
/// asked (--gravity), never the automatic one, which could take the term in
/// one epoch and not the next and move the friction between them.
IdentifyOptions log_options(const MonitorOptions& opt) {
  IdentifyOptions o = opt.identify;
  if (o.gravity == GravityTerm::automatic) o.gravity = GravityTerm::none;
  return o;
}

/// The identify options for an epoch: the fixed conventions stated (those
/// the user stated were stated to the epoch that found them).
IdentifyOptions epoch_options(const MonitorOptions& opt, const LogConventions& c) {
  return c.fixed ? c.stated : log_options(opt);
}

/// The conventions result r found (searched with `searched`, on `epoch`
/// and on), counted as found and, where they differ, as changed.
void take_conventions(const IdentifyResult& r, const IdentifyOptions& searched, int epoch, LogConventions& conv) {
  LogConventions found = conventions_of(r, searched, epoch);
  found.times_found = conv.times_found + 1;
  const IdentifyOptions &now = found.stated, &was = conv.stated;
  found.times_changed = conv.times_changed + (conv.fixed && (now.force_sign != was.force_sign ||
                                                              now.velocity_source != was.velocity_source ||
                                                              now.velocity_filter_hz != was.velocity_filter_hz));
  conv = found;
}

/// A trace of `rows` as the stream reads them.
Trace trace_of(std::vector<TraceSample>&& rows, const CsvStream& in, const char* source) {
  Trace t;
  t.samples = std::move(rows);
  t.has_position = in.has_position();
  t.has_velocity = in.has_velocity();
  t.time_unit_stated = in.time_unit_stated();
  t.source = source;
  return t;
}

/// An epoch's rows, held while the conventions are found on the head they begin.
struct PendingEpoch {
  std::vector<TraceSample> rows;
  double temperature = NAN, load = NAN;  ///< the epoch means of the covariate columns
};

/// The conventions found on the pending epochs pooled (the log's head, or a
/// re-check's), `epoch` the first one's index; `conv` as it was where the
/// head does not identify (the epochs then search their own, identify_epoch).
void find_conventions_on_head(const std::vector<PendingEpoch>& head, const CsvStream& in, const MonitorOptions& opt,
                              int epoch, LogConventions& conv) {
  std::vector<TraceSample> rows;
  for (const PendingEpoch& p : head) rows.insert(rows.end(), p.rows.begin(), p.rows.end());
  const IdentifyOptions options = log_options(opt);
  const IdentifyResult r = identify(trace_of(std::move(rows), in, "head"), options);
  if (!r.error.empty()) return;
  take_conventions(r, options, epoch, conv);
}

/// An epoch's samples identified on their own, with the log's conventions
/// (found here when they are not fixed or due for a re-check).
MonitorEpoch identify_epoch(std::vector<TraceSample>& buf, const CsvStream& in, const MonitorOptions& opt,
                            int epoch, LogConventions& conv) {
  MonitorEpoch e;
  e.t_start_s = buf.front().t_s + in.time_origin_s();  // the log's own clock (MonitorResult::time_origin_s)
  e.t_end_s = buf.back().t_s + in.time_origin_s();
  e.samples = buf.size();
  Trace t = trace_of(std::move(buf), in, "epoch");
  const bool searching = conventions_due(opt, conv, epoch);
  const IdentifyOptions options = searching ? log_options(opt) : epoch_options(opt, conv);
  const IdentifyResult r = identify(t, options);
  e.error = r.error;
  if (r.error.empty()) e.estimate = r.estimate;
  for (int d = 0; d < 2; ++d) e.stribeck[static_cast<std::size_t>(d)] = r.friction_model[static_cast<std::size_t>(d)].stribeck;
  if (r.error.empty() && searching) take_conventions(r, options, epoch, conv);
  return e;
}

/// Value, se and identifiable of tracked index i in an epoch (as the monitor reads it).
struct Reading {
  double value = 0.0, se = 0.0;
  bool identifiable = false;
};
Reading reading(const MonitorEpoch& ep, int i) {
  Reading x;
  if (ep.error.empty()) (void)feedid::tracked_value(ep.estimate, i, x.value, x.se);
  x.identifiable = carried(ep, i);
  return x;
}

/// A Coulomb force read off a line whose slope the epoch could not fix
/// (viscous term flagged): the intercept moves with the slope's error times
/// the epoch's mean speed, which its standard error does not hold (on
/// ladder motion 73.6 +- 0.35 N in an epoch of slow strokes, 68.2 N true).
bool coulomb_extrapolated(const feedid::DirectionEstimate<double>& de) {
  return (de.flags & feedid::flag_viscous_uncertain) != 0;
}

/// The epoch's estimate as the change monitor sees it: what it does not
/// carry has no standard error, so the core's rule (tracked_value) skips it.
feedid::Estimate<double> as_compared(const MonitorEpoch& ep) {
  feedid::Estimate<double> e = ep.estimate;
  for (int d = 0; d < 2; ++d) {
    feedid::DirectionEstimate<double>& de = d == 0 ? e.pos : e.neg;
    if (coulomb_extrapolated(de)) de.coulomb_se = 0.0;
    if (!ep.law_differs[static_cast<std::size_t>(d)]) continue;
    de.viscous_se = de.coulomb_se = de.breakaway_se = de.stribeck_velocity_se = 0.0;
  }
  return e;
}

void fix_law(LogLaw& law, std::size_t d) {
  law.fixed[d] = true;
  law.stribeck[d] = law.votes_stribeck[d] >= law.votes_cv[d];
}

/// One identified epoch's vote for each direction's law, while it is open.
void vote(LogLaw& law, const MonitorEpoch& ep, int needed) {
  if (!ep.error.empty()) return;
  for (std::size_t d = 0; d < 2; ++d) {
    const feedid::DirectionEstimate<double>& de = d == 0 ? ep.estimate.pos : ep.estimate.neg;
    if (law.fixed[d] || !de.friction_identified()) continue;
    (ep.stribeck[d] ? law.votes_stribeck[d] : law.votes_cv[d]) += 1;
    if (law.votes_stribeck[d] + law.votes_cv[d] >= needed) fix_law(law, d);
  }
}

/// Each tracked parameter as a linear function of the epoch's temperature
/// and load, a + b (c - c0), fitted (inverse-variance weights) over the
/// epochs that agree with it. What the change monitor is handed is the
/// epoch's value less b (c - c0): a warm-up or a payload change moves the
/// value along the slope and not the compared one, while a change at
/// constant temperature and load is compared as it is. The slope is learnt
/// as the log goes (the reference epochs seldom span a warm-up); an epoch
/// more than the floor (2 % of the value, 3 se) off the fit is left out of
/// it, so a wear step does not teach the fit a slope or an intercept.
class CovariateModel {
 public:
  /// Value less the covariates' modelled effect; then the epoch joins the fit if it agrees.
  /// `forming`: the parameter's reference is still forming, and takes the
  /// slopes the epochs draw so far, significant or not: a reference formed
  /// during a warm-up from values left as they were sat 2.4 % below the
  /// later compensated ones, and a step's alarm was dated to the warm-up.
  double compensate(double x, double se, const std::array<double, 2>& c, bool forming) {
    if (!anchored_) {
      c0_ = c;
      anchored_ = true;
    }
    const feedid::Vector<double, 3> z = centred(c);
    const Fit fit = fitted_at(z);
    // Agreement is judged against the line the epochs so far draw, slopes
    // not yet significant included: judged against the intercept alone, a
    // warm-up's epochs left the fit once they had drifted 2 %, before their
    // slope was significant, and the slope was never learnt.
    // The line's own uncertainty where it predicts counts beside the
    // epoch's: a slope drawn by a few epochs over a small covariate spread,
    // projected far, would otherwise turn every later epoch away and never
    // be corrected.
    const double predicted = fit.line.v[0] + fit.line.v[1] * z.v[1] + fit.line.v[2] * z.v[2];
    const bool agrees = n_ == 0 || std::fabs(x - predicted) <=
                                       std::max(3.0 * std::sqrt(se * se + fit.predicted_var), 0.02 * std::fabs(predicted));
    if (agrees) add(x, se, z);
    const feedid::Vector<double, 3>& slopes = forming ? fit.line : fit.significant;
    return x - slopes.v[1] * z.v[1] - slopes.v[2] * z.v[2];
  }

 private:
  feedid::Vector<double, 3> centred(const std::array<double, 2>& c) const {
    feedid::Vector<double, 3> z;
    z.v[0] = 1.0;
    for (int k = 0; k < 2; ++k) z.v[k + 1] = std::isfinite(c[k]) && std::isfinite(c0_[k]) ? c[k] - c0_[k] : 0.0;
    return z;
  }
  void add(double x, double se, const feedid::Vector<double, 3>& z) {
    const double w = 1.0 / (se * se);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) normal_.a[i][j] += w * z.v[i] * z.v[j];
      rhs_.v[i] += w * z.v[i] * x;
    }
    ++n_;
  }
  /// The fit so far: intercept and slopes as the epochs draw them (`line`;
  /// a covariate they do not spread, constant or not read, keeps a slope of
  /// 0), the variance of the line's value at covariates z, and the slopes
  /// they show beyond 3 standard errors (`significant`; the others 0).
  struct Fit {
    feedid::Vector<double, 3> line, significant;
    double predicted_var = 0.0;
  };
  Fit fitted_at(const feedid::Vector<double, 3>& z) const {
    Fit f;
    if (n_ == 0) return f;
    f.line.v[0] = rhs_.v[0] / normal_.a[0][0];
    f.significant = f.line;
    bool spread[3] = {true, false, false};
    for (int k = 1; k < 3; ++k) {
      const double mean = normal_.a[0][k] / normal_.a[0][0];
      spread[k] = n_ >= 3 && normal_.a[k][k] / normal_.a[0][0] - mean * mean > 1e-12 * (1.0 + normal_.a[k][k] / normal_.a[0][0]);
    }
    feedid::SymMatrix<double, 3> m;
    feedid::Vector<double, 3> r, a;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m.a[i][j] = spread[i] && spread[j] ? normal_.a[i][j] : (i == j ? 1.0 : 0.0);
      r.v[i] = spread[i] ? rhs_.v[i] : 0.0;
      a.v[i] = spread[i] ? z.v[i] : 0.0;
    }
    if (!feedid::cholesky(m, 1e-9)) return f;
    f.line = f.significant = feedid::cholesky_solve(m, r);
    const feedid::Vector<double, 3> va = feedid::cholesky_solve(m, a);
    f.predicted_var = a.v[0] * va.v[0] + a.v[1] * va.v[1] + a.v[2] * va.v[2];
    // A slope the fitted epochs do not show beyond 3 standard errors is
    // noise, and extrapolated it raised alarms of its own (vs, Fs on a
    // warm-up log): it is compensated with only while a reference forms.
    const feedid::Vector<double, 3> var = feedid::cholesky_inverse_diagonal(m);
    for (int k = 1; k < 3; ++k)
      if (!(std::fabs(f.line.v[k]) > 3.0 * std::sqrt(var.v[k]))) f.significant.v[k] = 0.0;
    return f;
  }
  feedid::SymMatrix<double, 3> normal_;
  feedid::Vector<double, 3> rhs_;
  std::array<double, 2> c0_{NAN, NAN};
  bool anchored_ = false;
  int n_ = 0;
};

/// An epoch's estimate with each carried parameter's covariate effect taken out.
feedid::Estimate<double> compensated(feedid::Estimate<double> e, const MonitorEpoch& ep,
                                     std::array<CovariateModel, feedid::kTrackedCount>& models, const Monitor& health) {
  if (!std::isfinite(ep.temperature) && !std::isfinite(ep.load)) return e;
  const std::array<double, 2> c = {ep.temperature, ep.load};
  for (int i = 0; i < feedid::kTrackedCount; ++i) {
    double v = 0.0, se = 0.0;
    if (!feedid::tracked_value(e, i, v, se)) continue;
    // Temperature moves friction, not mass: a mass slope fitted on epochs
    // whose mass is known to 7 % only extrapolated into alarms.
    double ref = 0.0, ref_se = 0.0;
    const bool forming = !health.reference(i, ref, ref_se);
    const double x = models[static_cast<std::size_t>(i)].compensate(v, se, i == 0 ? std::array<double, 2>{NAN, c[1]} : c, forming);
    feedid::DirectionEstimate<double>& d = i <= 4 ? e.pos : e.neg;
    double* field[4] = {&d.viscous_Ns_m, &d.coulomb_N, &d.breakaway_N, &d.stribeck_velocity_m_s};
    *(i == 0 ? &e.mass_kg : field[(i - 1) % 4]) = x;
  }
  return e;
}

/// Counts of what each tracked parameter's epochs carried, and its reference.
void count_tracked(MonitorResult& out, const Monitor& health) {
  for (const MonitorEpoch& ep : out.epochs) {
    out.epochs_skipped += !ep.error.empty();
    if (!ep.error.empty()) continue;
    for (int i = 0; i < feedid::kTrackedCount; ++i) {
      double v = 0.0, se = 0.0;
      TrackedCount& c = out.tracked[static_cast<std::size_t>(i)];
      const bool core_rule = feedid::tracked_value(ep.estimate, i, v, se);
      if (carried(ep, i)) ++c.carried;
      else if (core_rule && i != 0 && ep.law_differs[i <= 4 ? 0 : 1]) ++c.law_differs;
      else ++c.flagged;  // by the core's flags, or an Fc under an unresolved slope (coulomb_extrapolated)
    }
  }
  for (int i = 0; i < feedid::kTrackedCount; ++i) {
    double v = 0.0, se = 0.0;
    out.tracked[static_cast<std::size_t>(i)].referenced = health.reference(i, v, se);
    out.tracked[static_cast<std::size_t>(i)].watched = health.watched(i);
    out.referenced = out.referenced || out.tracked[static_cast<std::size_t>(i)].referenced;
  }
}

std::string unit_of(feedid::Tracked p, const Units& u) {
  switch (p) {
    case feedid::Tracked::mass: return u.mass();
    case feedid::Tracked::viscous: return u.viscous();
    case feedid::Tracked::stribeck_velocity: return u.velocity();
    default: return u.force;
  }
}

std::string direction_name(int8_t d) { return d > 0 ? "pos" : d < 0 ? "neg" : ""; }

/// The tracked indices a report shows: m, sigma+, sigma-, Fc+, Fc-.
constexpr int kShown[5] = {0, 1, 5, 2, 6};

std::string tracked_label(int i) {
  const feedid::Tracked p = Monitor::parameter_of(i);
  const std::string d = direction_name(Monitor::direction_of(i));
  return std::string(feedid::tracked_name(p)) + (d.empty() ? "" : " " + d);
}

}  // namespace

bool carried(const MonitorEpoch& ep, int i) {
  double v = 0.0, se = 0.0;
  if (!ep.error.empty() || !feedid::tracked_value(as_compared(ep), i, v, se)) return false;
  return i == 0 || !ep.law_differs[i <= 4 ? 0 : 1];
}

std::string watch_status(const MonitorResult& r) {
  int referenced = 0;
  for (int i : kShown) referenced += r.tracked[static_cast<std::size_t>(i)].referenced;
  return referenced == 5 ? "watching" : r.referenced ? "partly_watching" : "not_watching";
}

namespace {
/// The tracked index (feedid::tracked_value's) of an alarm's parameter.
int tracked_index(const feedid::ChangeAlarm<double>& a) {
  for (int i = 0; i < feedid::kTrackedCount; ++i)
    if (Monitor::parameter_of(i) == a.parameter && Monitor::direction_of(i) == a.direction) return i;
  return 0;
}

/// MonitorResult::alarm_earliest_t_s of alarm a, raised at epochs[at].
double last_carried_before(const std::vector<MonitorEpoch>& epochs, std::size_t at, const feedid::ChangeAlarm<double>& a) {
  const auto bit = static_cast<std::uint16_t>(1u << tracked_index(a));
  for (std::size_t k = std::min(at + 1, epochs.size()); k-- > 0;)
    if (epochs[k].t_end_s <= a.t_s && (epochs[k].compared_mask & bit)) return epochs[k].t_start_s;
  return a.t_s;
}
}  // namespace

MonitorResult monitor(CsvStream& in, const MonitorOptions& opt) {
  MonitorResult out;
  out.units = opt.identify.units;
  Monitor health;
  if (health.init(opt.detector) != feedid::Status::ok) {
    out.error = "monitor: epoch length must be > 0 s, reference epochs 3..16, allowance >= 0 and threshold > 0";
    return out;
  }
  std::vector<TraceSample> buf;
  std::vector<PendingEpoch> pending;  // epochs waiting for the head's conventions
  TraceSample s;
  std::array<double, 2> covariate_sum{};  // the epoch's temperature and load, summed row by row
  std::size_t compared = 0;  // epochs handed to the change monitor; the rest wait for the log's law
  std::array<CovariateModel, feedid::kTrackedCount> covariates;
  auto compare_up_to = [&](std::size_t end) {
    for (; compared < end; ++compared) {
      MonitorEpoch& ep = out.epochs[compared];
      if (!ep.error.empty()) continue;
      // A direction whose friction the epoch did not identify has no law to differ.
      for (std::size_t d = 0; d < 2; ++d)
        ep.law_differs[d] = (d == 0 ? ep.estimate.pos : ep.estimate.neg).friction_identified() &&
                            ep.stribeck[d] != out.law.stribeck[d];
      int fresh = 0;
      const feedid::Estimate<double> e = compensated(as_compared(ep), ep, covariates, health);
      for (int i = 0; i < feedid::kTrackedCount; ++i) {
        double v, se;
        if (health.watched(i) && feedid::tracked_value(e, i, v, se)) ep.compared_mask |= static_cast<std::uint16_t>(1u << i);
      }
      (void)health.update(e, ep.t_start_s, ep.t_end_s, fresh);
      for (int i = health.alarm_count() - fresh; i < health.alarm_count(); ++i) {
        out.alarms.push_back(health.alarm(i));
        out.alarm_earliest_t_s.push_back(last_carried_before(out.epochs, compared, out.alarms.back()));
      }
    }
  };
  auto identify_pending = [&] {
    for (PendingEpoch& p : pending) {
      out.epochs.push_back(identify_epoch(p.rows, in, opt, static_cast<int>(out.epochs.size()), out.conventions));
      out.epochs.back().temperature = p.temperature;
      out.epochs.back().load = p.load;
      vote(out.law, out.epochs.back(), opt.detector.reference_epochs);
      if (out.law.fixed[0] && out.law.fixed[1]) compare_up_to(out.epochs.size());
      if (opt.progress) opt.progress(out.epochs.back().t_end_s - in.time_origin_s());  // seconds read, as identify --stream says
    }
    pending.clear();
  };
  // next_t_s: the row after the epoch (infinite at the log's end). While
  // the conventions are due, epochs wait until they span the head.
  auto close_epoch = [&](double next_t_s) {
    if (buf.size() >= 2) {
      // A log every epoch would refuse alike (a time column in ms read as
      // s) stops here, once, with the remedy.
      if (out.epochs.empty() && pending.empty()) out.error = log_refusal(trace_of(std::vector<TraceSample>(buf), in, "log"));
      if (!out.error.empty()) return;
      const double rows = static_cast<double>(buf.size());
      pending.push_back({std::move(buf), in.has_temperature() ? covariate_sum[0] / rows : NAN,
                         in.has_load() ? covariate_sum[1] / rows : NAN});
    }
    buf = {};
    covariate_sum = {};
    if (pending.empty()) return;
    const int first = static_cast<int>(out.epochs.size());
    if (conventions_due(opt, out.conventions, first)) {
      // (less a rounding's worth: t - t0 of the row 60 s on can round below 60)
      if (next_t_s - pending.front().rows.front().t_s < kConventionsHead_s * (1.0 - 1e-9)) return;
      find_conventions_on_head(pending, in, opt, first, out.conventions);
    }
    identify_pending();
  };
  while (out.error.empty() && in.next(s)) {
    if (!buf.empty() && s.t_s - buf.front().t_s >= opt.detector.epoch_s) close_epoch(s.t_s);
    buf.push_back(s);
    covariate_sum[0] += in.has_temperature() ? in.temperature() : 0.0;
    covariate_sum[1] += in.has_load() ? in.load() : 0.0;
  }
  if (out.error.empty()) close_epoch(INFINITY);
  if (!out.error.empty()) return out;
  for (std::size_t d = 0; d < 2; ++d)
    if (!out.law.fixed[d]) fix_law(out.law, d);  // the log ended first: the votes there are
  compare_up_to(out.epochs.size());
  out.error = in.error();
  count_tracked(out, health);
  if (out.error.empty() && !out.referenced) {
    std::size_t identified = 0;
    for (const MonitorEpoch& ep : out.epochs) identified += ep.error.empty();
    std::ostringstream o;  // the epoch's length as given (10 s, not 10.000000 s)
    o << "nothing was monitored: " << identified << " of " << out.epochs.size() << " epochs of " << opt.detector.epoch_s
      << " s could be identified, and a reference needs " << opt.detector.reference_epochs
      << " that carry a parameter (a longer log, more motion in both directions, or a longer --epoch-s)";
    out.error = o.str();
  }
  out.rows_skipped = in.rows_skipped();
  out.time_origin_s = in.time_origin_s();
  out.rows_repeated = in.rows_repeated();
  out.skipped_rows = in.skipped_rows();
  return out;
}

namespace {
/// An epoch's parameters with their standard errors and whether each was
/// compared (`identifiable`), as `--json` and `--jsonl` write it.
nlohmann::json epoch_json(const MonitorEpoch& ep) {
  nlohmann::json j = {{"t_start_s", ep.t_start_s}, {"t_end_s", ep.t_end_s}, {"samples", ep.samples}};
  if (!ep.error.empty()) j["error"] = ep.error;
  const Reading m = reading(ep, 0);
  j["m"] = m.value;
  j["m_se"] = m.se;
  j["m_identifiable"] = m.identifiable;
  for (int d = 0; d < 2; ++d) {
    nlohmann::json side;
    const char* names[4] = {"sigma", "fc", "fs", "vs"};
    nlohmann::json ident;
    for (int k = 0; k < 4; ++k) {
      const Reading x = reading(ep, 1 + 4 * d + k);
      side[names[k]] = x.value;
      side[std::string(names[k]) + "_se"] = x.se;
      ident[names[k]] = x.identifiable;
    }
    side["identifiable"] = ident;
    side["law"] = ep.stribeck[static_cast<std::size_t>(d)] ? "stribeck" : "coulomb_viscous";
    side["law_differs"] = ep.law_differs[static_cast<std::size_t>(d)];
    j[d == 0 ? "pos" : "neg"] = side;
  }
  return j;
}

/// Alarm k's MonitorResult::alarm_earliest_t_s (its t_s in a result built without them).
double earliest_of(const MonitorResult& r, std::size_t k) {
  return k < r.alarm_earliest_t_s.size() ? r.alarm_earliest_t_s[k] : r.alarms[k].t_s;
}

/// Alarm k of r.
nlohmann::json alarm_json(const MonitorResult& r, std::size_t k) {
  const feedid::ChangeAlarm<double>& a = r.alarms[k];
  return {{"t_s", a.t_s},
          {"earliest_t_s", earliest_of(r, k)},
          {"raised_t_s", a.raised_t_s},
          {"parameter", feedid::tracked_name(a.parameter)},
          {"direction", a.direction == 0 ? nlohmann::json(nullptr) : nlohmann::json(direction_name(a.direction))},
          {"change", a.change},
          {"change_se", a.change_se},
          {"change_pct", a.reference != 0 ? 100.0 * a.change / a.reference : 0.0},
          {"reference", a.reference}};
}
}  // namespace

std::string jsonl_lines(const MonitorResult& r, const std::string& source) {
  std::string out;
  std::size_t next_alarm = 0;
  // Alarms in time order among the epochs: after the epoch that raised them.
  auto alarms_until = [&](double t) {
    for (; next_alarm < r.alarms.size() && r.alarms[next_alarm].raised_t_s <= t; ++next_alarm) {
      nlohmann::json a = alarm_json(r, next_alarm);
      a["type"] = "alarm";
      a["source"] = source;
      out += a.dump() + "\n";
    }
  };
  for (const MonitorEpoch& ep : r.epochs) {
    nlohmann::json j = epoch_json(ep);
    j["type"] = "epoch";
    j["source"] = source;
    j["skipped"] = !ep.error.empty();
    j["temperature"] = std::isfinite(ep.temperature) ? nlohmann::json(ep.temperature) : nlohmann::json(nullptr);
    j["load"] = std::isfinite(ep.load) ? nlohmann::json(ep.load) : nlohmann::json(nullptr);
    out += j.dump() + "\n";
    alarms_until(ep.t_end_s);
  }
  alarms_until(INFINITY);
  return out;
}

nlohmann::json to_json(const MonitorResult& r, const MonitorOptions& opt) {
  nlohmann::json epochs = nlohmann::json::array();
  for (const auto& ep : r.epochs) epochs.push_back(epoch_json(ep));
  nlohmann::json alarms = nlohmann::json::array();
  for (std::size_t k = 0; k < r.alarms.size(); ++k) alarms.push_back(alarm_json(r, k));
  const LogConventions& c = r.conventions;
  nlohmann::json conventions = {{"fixed", c.fixed},
                                {"force_sign", c.stated.force_sign},
                                {"force_lag_s", c.stated.force_lag_s},
                                {"force_lag_se_s", c.stated.force_lag_se_s},
                                {"velocity_lag_s", std::isfinite(c.stated.velocity_lag_s) ? nlohmann::json(c.stated.velocity_lag_s)
                                                                                          : nlohmann::json(nullptr)},
                                {"velocity_filter_hz", c.stated.velocity_filter_hz},
                                {"velocity_source", c.stated.velocity_source == VelocitySource::given    ? "given"
                                                    : c.stated.velocity_source == VelocitySource::column ? "column"
                                                                                                         : "position"},
                                {"found_at_epoch", c.found_at_epoch},
                                {"times_found", c.times_found},
                                {"times_changed", c.times_changed},
                                {"recheck_every_epochs", opt.recheck_conventions_every}};
  nlohmann::json j = {{"epochs", epochs}, {"alarms", alarms}, {"conventions", conventions},
                      {"referenced", r.referenced}, {"units", units_json(r.units)}};
  j["detector"] = {{"epoch_s", opt.detector.epoch_s},
                   {"reference_epochs", opt.detector.reference_epochs},
                   {"cusum_allowance", opt.detector.allowance},
                   {"cusum_threshold", opt.detector.threshold},
                   {"watch_stribeck", opt.detector.watch_stribeck},
                   {"rule", "each epoch identified alone; the first reference_epochs epochs a parameter can carry are "
                            "its reference; two-sided CUSUM of (epoch - reference) / (c sqrt(se^2 + se_ref^2)), c the "
                            "reference epochs' over-dispersion (>= 1); alarm above the threshold, then a new reference; "
                            "m, sigma and Fc watched, Fs and vs only with watch_stribeck"}};
  // A run that stopped after it formed a reference watched nothing from then on.
  j["status"] = !r.error.empty() && r.referenced ? "error" : watch_status(r);
  j["epochs_skipped"] = r.epochs_skipped;
  nlohmann::json tracked;
  for (int i = 0; i < feedid::kTrackedCount; ++i) {
    const TrackedCount& c = r.tracked[static_cast<std::size_t>(i)];
    tracked[tracked_label(i)] = {{"compared", c.watched ? c.carried : 0}, {"carried", c.carried}, {"flagged", c.flagged},
                                 {"law_differs", c.law_differs}, {"referenced", c.referenced}, {"watched", c.watched}};
  }
  j["tracked"] = tracked;
  j["friction_law"] = {{"pos", r.law.stribeck[0] ? "stribeck" : "coulomb_viscous"},
                       {"neg", r.law.stribeck[1] ? "stribeck" : "coulomb_viscous"},
                       {"rule", "fixed once per log: the law most of the first reference_epochs epochs that identified "
                                "the direction's friction kept (Stribeck on a tie); an epoch with the other law "
                                "does not compare that direction's Fc and sigma"}};
  j["input"] = {{"rows_skipped", r.rows_skipped}, {"rows_repeated", r.rows_repeated}, {"skipped_rows", r.skipped_rows},
                {"time_origin_s", r.time_origin_s},
                {"time_origin_rule", "the epochs' times are the log's own clock; its stamps were read from time_origin_s "
                                     "(a numeric stamp of 1e6 or more: its first one's whole part) so that they keep their digits"}};
  if (!r.error.empty()) j["error"] = r.error;
  return j;
}

namespace {
/// Which epochs were skipped and which parameters were watched, in words:
/// silence means nothing unless something was watched.
std::string watch_summary(const MonitorResult& r) {
  std::ostringstream o;
  o << "epochs: " << r.epochs.size() << ", " << r.epochs_skipped << " skipped (not identified)\n";
  for (int i : kShown) {
    const TrackedCount& c = r.tracked[static_cast<std::size_t>(i)];
    o << "  " << tracked_label(i) << ": " << c.carried << " compared, " << c.flagged << " not carried (flagged), "
      << c.law_differs << " with another friction law; "
      << (c.referenced ? "watched" : "NOT WATCHED (no reference formed)") << "\n";
  }
  const std::string status = watch_status(r);
  if (status != "watching") o << "status: " << status << (status == "not_watching" ? ": no alarm means nothing here\n" : "\n");
  return o.str();
}
}  // namespace

std::string trend_table(const MonitorResult& r) {
  std::ostringstream o;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%9s %9s  %-16s %-16s %-16s %-16s %-16s\n", "t0 (s)", "t1 (s)", "m", "sigma+", "sigma-",
                "Fc+", "Fc-");
  o << buf;
  const int shown[5] = {0, 1, 5, 2, 6};
  for (const auto& ep : r.epochs) {
    std::snprintf(buf, sizeof buf, "%9.1f %9.1f", ep.t_start_s, ep.t_end_s);
    o << buf;
    if (!ep.error.empty()) {
      o << "  not identified: " << ep.error.substr(0, 80) << "\n";
      continue;
    }
    for (int i : shown) {
      const Reading x = reading(ep, i);
      const Rounded v = round_to_se(x.value, x.se);
      const std::string cell = x.identifiable ? v.value + " +- " + v.se : "-";
      std::snprintf(buf, sizeof buf, "  %-16s", cell.c_str());
      o << buf;
    }
    o << "\n";
  }
  o << watch_summary(r);
  if (r.alarms.empty() && watch_status(r) != "not_watching") o << "no alarms in what was watched\n";
  for (std::size_t k = 0; k < r.alarms.size(); ++k) {
    const feedid::ChangeAlarm<double>& a = r.alarms[k];
    const Rounded c = round_to_se(a.change, a.change_se);
    const double earliest = earliest_of(r, k);
    char when[64] = "";
    if (earliest < a.t_s) std::snprintf(when, sizeof when, "changed since %.1f s at the earliest; ", earliest);
    std::snprintf(buf, sizeof buf, "ALARM at %.1f s (%sraised at %.1f s): %s%s%s changed by %s +- %s %s (%+.1f %%)\n", a.t_s, when, a.raised_t_s,
                  feedid::tracked_name(a.parameter), a.direction ? " " : "", direction_name(a.direction).c_str(),
                  c.value.c_str(), c.se.c_str(), unit_of(a.parameter, r.units).c_str(), a.reference != 0 ? 100.0 * a.change / a.reference : 0.0);
    o << buf;
  }
  return o.str();
}

bool write_trend_svg(const MonitorResult& r, const std::string& path, std::string& error) {
  const int shown[5] = {0, 1, 5, 2, 6};
  const Units& u = r.units;
  const std::string titles[5] = {"mass m (" + u.mass() + ")", "viscous sigma+ (" + u.viscous() + ")",
                                 "viscous sigma- (" + u.viscous() + ")", "Coulomb Fc+ (" + u.force + ")",
                                 "Coulomb Fc- (" + u.force + ")"};
  const int W = 760, H = 300;
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << 5 * H << "\" viewBox=\"0 0 " << W
    << " " << 5 * H << "\">\n";
  for (int p = 0; p < 5; ++p) {
    const int i = shown[p];
    PlotSpec spec;
    spec.id = "trend" + std::to_string(p);
    spec.title = titles[p];
    spec.x = {"time (s)", false};
    spec.y = {titles[p], false};
    spec.width_px = W;
    spec.height_px = H;
    spec.legend = "below";  // off the data
    PlotSeries est, lo, hi;
    est.label = "epoch estimate";
    est.color = "#1f77b4";
    lo.label = "+-2 se";
    lo.color = hi.color = "#9ecae1";
    lo.dashed = hi.dashed = true;
    lo.markers = hi.markers = false;
    // Epochs the motion barely carried (a band over 5 times the median
    // band) are left out: each would flatten the trend to a line.
    std::vector<double> widths;
    for (const auto& ep : r.epochs) {
      const Reading x = reading(ep, i);
      if (ep.error.empty() && x.identifiable) widths.push_back(4.0 * x.se);
    }
    std::vector<double> sorted = widths;
    std::sort(sorted.begin(), sorted.end());
    const double wide = sorted.empty() ? 0.0 : 5.0 * sorted[sorted.size() / 2];
    int left_out = 0;
    for (const auto& ep : r.epochs) {
      const Reading x = reading(ep, i);
      if (!ep.error.empty() || !x.identifiable) continue;
      if (4.0 * x.se > wide) {
        ++left_out;
        continue;
      }
      const double t = 0.5 * (ep.t_start_s + ep.t_end_s);
      est.x.push_back(t), est.y.push_back(x.value);
      lo.x.push_back(t), lo.y.push_back(x.value - 2 * x.se);
      hi.x.push_back(t), hi.y.push_back(x.value + 2 * x.se);
    }
    spec.series = {est, lo, hi};
    if (left_out > 0) spec.note = std::to_string(left_out) + " epoch(s) with a band over 5x the median left out";
    double ymin = 1e300, ymax = -1e300;
    for (double y : lo.y) ymin = std::min(ymin, y);
    for (double y : hi.y) ymax = std::max(ymax, y);
    for (const auto& a : r.alarms) {
      const int ai = a.parameter == feedid::Tracked::mass ? 0 : 1 + 4 * (a.direction > 0 ? 0 : 1) + static_cast<int>(a.parameter) - 1;
      if (ai != i || !(ymax > ymin)) continue;
      PlotSeries mark;
      mark.label = "alarm";
      mark.color = "#d62728";
      mark.markers = false;
      mark.x = {a.t_s, a.t_s};
      mark.y = {ymin, ymax};
      spec.series.push_back(mark);
    }
    std::string svg = render_svg(spec);
    svg.replace(0, 4, "<svg x=\"0\" y=\"" + std::to_string(p * H) + "\"");
    o << svg << "\n";
  }
  o << "</svg>\n";
  error = write_whole_file(path, o.str());
  return error.empty();
}

}  // namespace feedid::host
