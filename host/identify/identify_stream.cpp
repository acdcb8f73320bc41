// identify for logs too large to load. Host only.
#include "identify_stream.hpp"

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

/// Options that repeat, for every chunk, what was chosen on the head.
IdentifyOptions stated_from(const Signals& head, IdentifyOptions o) {
  o.force_lag_s = head.force_lag_s;
  if (std::isfinite(head.velocity_lag_s)) o.velocity_lag_s = head.velocity_lag_s;
  if (head.velocity_filter_hz > 0) {
    o.velocity_filter_hz = head.velocity_filter_hz;
    o.velocity_source = VelocitySource::position;
  } else {
    o.velocity_source = VelocitySource::column;
  }
  o.progress = nullptr;
  return o;
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
  if (chunk.samples.size() < 100) {
    r.status = feedid::Status::insufficient_data;
    r.error = in.error().empty() ? source + ": too short to identify" : in.error();
    return r;
  }
  // Conventions, velocity and band edges from the head.
  r.signals = prepare_signals(chunk, opt);
  r.config = auto_config(r.signals, opt);
  const IdentifyOptions fixed = stated_from(r.signals, opt);
  Core core;
  r.status = core.init(r.config);
  if (r.status != feedid::Status::ok) {
    r.error = std::string("invalid configuration: ") + core.config_error();
    return r;
  }
  r.config = core.config();  // as init() completed it: what the core ran with
  // The jackknife's groups: blocks of kGroupBlock_s dealt round-robin to
  // kJackknifeChunks cores; the whole trace is not there to cut in ten.
  std::vector<std::unique_ptr<Core>> groups;
  std::vector<double> group_last(kJackknifeChunks, -INFINITY);  // -inf: the group has no data yet
  for (int g = 0; g < kJackknifeChunks; ++g) {
    groups.push_back(std::make_unique<Core>());
    (void)groups.back()->init(r.config);
  }
  const double t_first = chunk.samples.front().t_s;
  double t_pushed = -INFINITY, t_last = t_first;
  std::size_t pushed = 0;
  for (;;) {
    // Filter the chunk with its margins; push what lies past the samples
    // already pushed and, unless it is the last chunk, before the trailing margin.
    const Signals s = prepare_signals(chunk, fixed);
    const double t_end = more ? chunk.samples.back().t_s - so.margin_s : INFINITY;
    for (std::size_t k = 0; k < s.t.size(); ++k) {
      if (!(s.t[k] > t_pushed) || !(s.t[k] < t_end)) continue;
      feedid::Sample<double> smp;
      smp.dt_s = pushed == 0 ? 0.0 : s.t[k] - t_pushed;
      smp.position_m = s.x[k];
      smp.velocity_m_s = s.v[k];
      smp.force_N = s.u[k];
      const feedid::Status st = core.push(smp);
      if (st != feedid::Status::ok && r.first_rejections.size() < 10) r.first_rejections.push_back({pushed, st});
      const auto g = static_cast<std::size_t>(std::floor((s.t[k] - t_first) / kGroupBlock_s)) % groups.size();
      smp.dt_s = std::isfinite(group_last[g]) ? s.t[k] - group_last[g] : 0.0;  // a gap across the other groups' blocks
      (void)groups[g]->push(smp);
      group_last[g] = s.t[k];
      t_pushed = s.t[k];
      ++pushed;
    }
    t_last = chunk.samples.back().t_s;
    if (opt.progress) opt.progress(t_last - t_first);
    if (!more) break;
    // Keep 2 margins of the chunk's tail (one refiltered, one as the filter's lead-in).
    std::vector<TraceSample> tail;
    for (const auto& smp : chunk.samples)
      if (smp.t_s >= t_end - so.margin_s) tail.push_back(smp);
    chunk.samples.swap(tail);
    more = read_span(in, chunk, so.chunk_s + 2.0 * so.margin_s, next, have_next);
  }
  if (!in.error().empty()) {
    r.status = feedid::Status::insufficient_data;  // nothing solved: not "ok"
    r.error = in.error();
    return r;
  }
  r.rows_skipped = in.rows_skipped();
  r.rows_repeated = in.rows_repeated();
  r.skipped_rows = in.skipped_rows();
  r.duration_s = t_last - t_first;
  r.status = core.solve(opt.method);
  r.estimate = core.estimate();
  r.diagnostics = core.diagnostics();
  if (r.status == feedid::Status::ok && opt.select_friction_model) r.friction_model = select_friction_models(core, r.estimate);
  if (r.status == feedid::Status::ok && opt.honest_standard_errors) {
    Uncertainty u;
    u.model_se = standard_errors(r.estimate);
    // Only groups that saw data: an empty one would leave the full estimate
    // out of nothing and pull every standard error to zero.
    std::vector<std::unique_ptr<Core>> filled;
    for (std::size_t g = 0; g < groups.size(); ++g)
      if (std::isfinite(group_last[g])) filled.push_back(std::move(groups[g]));
    if (static_cast<int>(filled.size()) >= kMinGroups) u.chunks_used = jackknife_over(filled, opt.method, u.jackknife_se);
    // The timing term is a sensitivity, not noise that averages out: the
    // head's, at the whole trace's parameters.
    u.timing_se = timing_standard_errors(r.signals, r.config, opt.method, parameters(r.estimate), r.lag_se_periods);
    apply_standard_errors(r.estimate, u);
    r.jackknife_chunks = u.chunks_used;
    r.se_model = u.model_se;
    r.se_jackknife = u.jackknife_se;
  }
  fill_friction_curve(core, r);
  r.streamed = true;
  if (r.status == feedid::Status::insufficient_data) {
    std::ostringstream o;
    o << source << ": not enough motion to identify in " << r.duration_s << " s";
    r.error = o.str();
  }
  return r;
}

}  // namespace feedid::host
