// identify for logs too large to load. Host only.
#include "identify_stream.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <vector>

#include "uncertainty.hpp"

namespace feedid::host {
namespace {

/// Length of the blocks dealt to the jackknife's groups (s): ten groups
/// have data after 100 s.
constexpr double kGroupBlock_s = 10.0;
/// Fewer groups with data than this: the core's own standard errors.
constexpr int kMinGroups = 5;

/// Rows of the stream until t - t0 reaches span_s (the first row past it is kept in `next`).
bool read_span(CsvStream& in, Trace& into, double span_s, TraceSample& next, bool& have_next) {
  const double t0 = have_next ? next.t_s : (into.samples.empty() ? NAN : into.samples.front().t_s);
  if (have_next) into.samples.push_back(next);
  have_next = false;
  TraceSample s;
  while (in.next(s)) {
    const double start = std::isnan(t0) ? (into.samples.empty() ? s.t_s : into.samples.front().t_s) : t0;
    if (s.t_s - start >= span_s) {
      next = s;
      have_next = true;
      return true;
    }
    into.samples.push_back(s);
  }
  return false;
}

/// The whole-trace core and the jackknife's groups: blocks of kGroupBlock_s
/// dealt round-robin to kJackknifeChunks cores (the whole trace is not
/// there to cut in ten), fed sample by sample.
struct StreamedCores {
  Core core;
  std::vector<std::unique_ptr<Core>> groups;
  std::vector<double> group_last = std::vector<double>(kJackknifeChunks, -INFINITY);  ///< -inf: no data yet
  double t_first = 0.0, t_pushed = -INFINITY;
  std::size_t pushed = 0;

  /// False with the core's reason when the configuration is invalid.
  bool init(const feedid::Config<double>& cfg, double t0, std::string& error) {
    if (core.init(cfg) != feedid::Status::ok) {
      error = std::string("invalid configuration: ") + core.config_error();
      return false;
    }
    for (int g = 0; g < kJackknifeChunks; ++g) {
      groups.push_back(std::make_unique<Core>());
      (void)groups.back()->init(cfg);
    }
    t_first = t0;
    return true;
  }

  /// The filtered chunk's samples after those already pushed and before t_end.
  void push(const Signals& s, double t_end, std::vector<Rejection>& first_rejections) {
    for (std::size_t k = 0; k < s.t.size(); ++k) {
      if (!(s.t[k] > t_pushed) || !(s.t[k] < t_end)) continue;
      feedid::Sample<double> smp;
      smp.dt_s = pushed == 0 ? 0.0 : s.t[k] - t_pushed;
      smp.position_m = s.x[k];
      smp.velocity_m_s = s.v[k];
      smp.force_N = s.u[k];
      const feedid::Status st = core.push(smp);
      if (st != feedid::Status::ok && first_rejections.size() < 10) first_rejections.push_back({pushed, st});
      const auto g = static_cast<std::size_t>(std::floor((s.t[k] - t_first) / kGroupBlock_s)) % groups.size();
      smp.dt_s = std::isfinite(group_last[g]) ? s.t[k] - group_last[g] : 0.0;  // a gap across the other groups' blocks
      (void)groups[g]->push(smp);
      group_last[g] = s.t[k];
      t_pushed = s.t[k];
      ++pushed;
    }
  }

  /// The groups that saw data: an empty one would leave the full estimate
  /// out of nothing and pull every standard error to zero.
  std::vector<std::unique_ptr<Core>> filled_groups() {
    std::vector<std::unique_ptr<Core>> filled;
    for (std::size_t g = 0; g < groups.size(); ++g)
      if (std::isfinite(group_last[g])) filled.push_back(std::move(groups[g]));
    return filled;
  }
};

/// The chunk's last two margins (one to filter again, one as the filter's lead-in).
void keep_tail(Trace& chunk, double t_end, double margin_s) {
  std::vector<TraceSample> tail;
  for (const auto& smp : chunk.samples)
    if (smp.t_s >= t_end - margin_s) tail.push_back(smp);
  chunk.samples.swap(tail);
}

/// The chunk without its clipped rows (leave_out_force_saturation, with the
/// levels earlier chunks showed): a clip that starts after the head would
/// otherwise reach the core (m 15 % low on a log clipped from 70 s on).
/// The rows left out between t_from and t_end, the part of the chunk that
/// is pushed, are counted into `log` once. A chunk's level below half the
/// head's largest force (its outliers bridged: one spike must not hide a
/// clip) is no clip (a chunk that only dwells).
Trace without_clipped_rows(const Trace& chunk, double t_from, double t_end, double head_peak, ForceSaturation& log) {
  ForceSaturation here;
  Trace kept = leave_out_force_saturation(chunk, here, log, 0.5 * head_peak);
  if (!here.found()) return kept;
  const auto pushed = [&](double t) { return t >= t_from && t < t_end; };
  std::size_t on_level = 0, in_chunk = 0, in_kept = 0;
  for (const TraceSample& s : chunk.samples) {
    if (!pushed(s.t_s)) continue;
    ++in_chunk;
    on_level += (here.found_hi && s.u_N == here.level_hi) || (here.found_lo && s.u_N == here.level_lo);
  }
  for (const TraceSample& s : kept.samples) in_kept += pushed(s.t_s);
  if (on_level == 0) return kept;
  if (here.found_hi) log.found_hi = true, log.level_hi = here.level_hi;
  if (here.found_lo) log.found_lo = true, log.level_lo = here.level_lo;
  log.rows += on_level;
  log.rows_left_out += in_chunk - in_kept;
  return kept;
}

/// Jackknife over the groups with data (the core's own below kMinGroups)
/// plus the timing term measured on the head, at the whole trace's parameters.
void apply_streamed_standard_errors(IdentifyResult& r, StreamedCores& cores, const IdentifyOptions& opt) {
  Uncertainty u;
  u.model_se = standard_errors(r.estimate);
  std::vector<std::unique_ptr<Core>> filled = cores.filled_groups();
  if (static_cast<int>(filled.size()) >= kMinGroups)
    u.chunks_used = jackknife_over(filled, opt.method, u.jackknife_se, refitted_directions(r));
  // The timing term is a sensitivity, not noise that averages out.
  u.timing_se = timing_standard_errors(r.signals, r.config, opt.method, parameters(r.estimate), r.lag_se_periods);
  apply_standard_errors(r.estimate, u);
  r.jackknife_chunks = u.chunks_used;
  r.se_model = u.model_se;
  r.se_jackknife = u.jackknife_se;
  r.se_timing = u.timing_se;  // in the *_se fields above; the JSON's `timing` said 0
}

/// Solve, model selection, standard errors and the friction curve.
void finish(IdentifyResult& r, StreamedCores& cores, const CsvStream& in, const std::string& source,
            const IdentifyOptions& opt) {
  r.rows_skipped = in.rows_skipped();
  r.time_origin_s = in.time_origin_s();
  r.rows_repeated = in.rows_repeated();
  r.skipped_rows = in.skipped_rows();
  r.status = cores.core.solve(opt.method);
  r.estimate = cores.core.estimate();
  r.diagnostics = cores.core.diagnostics();
  if (r.status == feedid::Status::ok && opt.select_friction_model)
    r.friction_model = select_friction_models(cores.core, r.estimate);
  if (r.status == feedid::Status::ok && opt.honest_standard_errors) apply_streamed_standard_errors(r, cores, opt);
  fill_friction_curve(cores.core, r);
  r.streamed = true;
  r.mass_from_windows_kg = r.estimate.mass_kg;  // the stream refits no block mass: its mass is the windows
  if (r.status == feedid::Status::insufficient_data) {
    std::ostringstream o;
    o << source << ": not enough motion to identify in " << r.duration_s << " s";
    r.error = o.str();
  }
}

/// The chunk with its position spikes bridged, as identify() bridges a
/// whole trace: the head's bridging chooses the conventions only, and one
/// spike pushed as it was logged took m 3.7 standard errors off with status
/// ok. The spikes in [t_from, t_end), the part of the chunk that is pushed,
/// are counted into `log` once.
Trace bridged_spikes(const Trace& chunk, double t_from, double t_end, PositionSpikes& log) {
  PositionSpikes here;
  Trace out = bridge_position_spikes(chunk, here);
  if (here.rows == 0) return out;
  for (std::size_t k = 0; k < out.samples.size(); ++k) {
    const double t = out.samples[k].t_s;
    if (out.samples[k].x_m != chunk.samples[k].x_m && t >= t_from && t < t_end) ++log.rows;
  }
  for (const std::string& named : here.first)
    if (log.first.size() < kNamedOutliers && std::find(log.first.begin(), log.first.end(), named) == log.first.end())
      log.first.push_back(named);
  return out;
}

}  // namespace

IdentifyResult identify_stream(CsvStream& in, const std::string& source, const IdentifyOptions& opt,
                               const StreamOptions& so) {
  IdentifyResult r;
  r.units = opt.units;
  Trace chunk;
  chunk.has_position = in.has_position();
  chunk.has_velocity = in.has_velocity();
  chunk.source = source;
  TraceSample next{};
  bool have_next = false;
  bool more = read_span(in, chunk, so.head_s, next, have_next);
  chunk.time_unit_stated = in.time_unit_stated();  // after a row: ISO stamps are known at the first that reads
  if (chunk.samples.size() < 100) {
    r.status = feedid::Status::insufficient_data;
    r.error = in.error().empty() ? source + ": too short to identify" : in.error();
    return r;
  }
  // Conventions, velocity and band edges from the head with its force
  // outliers bridged; the core rejects those of every chunk by the head's
  // limit (auto_config's max_force_N), counting them as out of range.
  r.signals = prepare_signals(bridge_force_outliers(chunk, opt.units.force, r.force_outliers), opt);
  if (!r.signals.error.empty()) {
    r.status = feedid::Status::insufficient_data;
    r.error = r.signals.error;
    return r;
  }
  r.force_outliers.rows = 0;
  r.force_outliers.first.clear();
  IdentifyOptions fixed = with_conventions_of(r.signals, opt);  // what the head chose, for every chunk
  fixed.progress = nullptr;
  auto cores = std::make_unique<StreamedCores>();
  r.config = auto_config(r.signals, opt);  // kept as asked when init() rejects it, as identify() does
  if (!cores->init(r.config, chunk.samples.front().t_s, r.error)) {
    r.status = feedid::Status::invalid_config;
    return r;
  }
  r.config = cores->core.config();  // as init() completed it: what the core ran with
  double t_last = cores->t_first, t_pushed = -INFINITY, head_peak = 0.0;
  for (double u : r.signals.u) head_peak = std::max(head_peak, std::fabs(u));
  ForceSaturation clipped;
  PositionSpikes spikes;  // every chunk's, counted where pushed
  for (;;) {
    // Filter the chunk with its margins; push what lies past the samples
    // already pushed and, unless it is the last chunk, before the trailing margin.
    const double t_end = more ? chunk.samples.back().t_s - so.margin_s : INFINITY;
    const Trace kept = bridged_spikes(without_clipped_rows(chunk, t_pushed, t_end, head_peak, clipped), t_pushed, t_end,
                                      spikes);
    // A chunk that only pushes against the limit keeps too few rows to condition: nothing to push.
    if (kept.samples.size() >= 2) {
      const Signals conditioned = prepare_signals(kept, fixed);
      if (!conditioned.error.empty()) {
        r.status = feedid::Status::insufficient_data;
        r.error = conditioned.error;
        return r;
      }
      cores->push(conditioned, t_end, r.first_rejections);
    }
    t_pushed = t_end;
    t_last = chunk.samples.back().t_s;
    if (opt.progress) opt.progress(t_last - cores->t_first);
    if (!more) break;
    keep_tail(chunk, t_end, so.margin_s);
    more = read_span(in, chunk, so.chunk_s + 2.0 * so.margin_s, next, have_next);
  }
  if (!in.error().empty()) {
    r.status = feedid::Status::insufficient_data;  // nothing solved: not "ok"
    r.error = in.error();
    return r;
  }
  r.duration_s = t_last - cores->t_first;
  r.force_outliers.saturation = clipped;  // every chunk's, the head's among them
  spikes.limit_m = r.force_outliers.position_spikes.limit_m;
  r.force_outliers.position_spikes = spikes;
  finish(r, *cores, in, source, opt);
  // The gravity fit refits the whole trace (gravity.hpp); a stream is read once.
  if (opt.gravity != GravityTerm::none && opt.units.position == "rad")
    r.gravity.note = "not fitted: a streamed log is read once, and the gravity term refits the whole trace (identify "
                     "without --stream fits it)";
  return r;
}

}  // namespace feedid::host
