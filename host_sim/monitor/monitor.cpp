// Friction health from a log of any length. Host only.
#include "monitor.hpp"
#include "io/output_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "io/number_format.hpp"
#include "io/svg_plot.hpp"

namespace feedid::host {
namespace {

using Monitor = feedid::ChangeMonitor<double, 64>;

/// The conventions an identified epoch found, to state to the next epochs:
/// searching them on every epoch cost most of monitor's time, and they are
/// the log's, not the epoch's.
LogConventions conventions_of(const IdentifyResult& r, int epoch) {
  LogConventions c;
  c.fixed = true;
  c.force_sign = r.signals.force_sign.sign;
  c.force_lag_s = r.signals.force_lag_s;
  c.velocity_lag_s = r.signals.velocity_lag_s;
  c.velocity_filter_hz = r.signals.velocity_filter_hz;
  c.found_at_epoch = epoch;
  return c;
}

/// Whether this epoch finds the conventions: none fixed yet, or a re-check due.
bool conventions_due(const MonitorOptions& opt, const LogConventions& c, int epoch) {
  const int every = opt.recheck_conventions_every;
  return !c.fixed || (every > 0 && epoch - c.found_at_epoch >= every);
}

/// The identify options for an epoch: the fixed conventions stated, where
/// the user did not state them.
IdentifyOptions epoch_options(const MonitorOptions& opt, const LogConventions& c) {
  IdentifyOptions o = opt.identify;
  if (!c.fixed) return o;
  if (o.force_sign == 0) o.force_sign = c.force_sign;
  if (!std::isfinite(o.force_lag_s) && o.alignment == "auto") o.force_lag_s = c.force_lag_s;
  if (!std::isfinite(o.velocity_lag_s) && std::isfinite(c.velocity_lag_s)) o.velocity_lag_s = c.velocity_lag_s;
  if (!(o.velocity_filter_hz > 0) && c.velocity_filter_hz > 0) o.velocity_filter_hz = c.velocity_filter_hz;
  return o;
}

/// An epoch's samples identified on their own, with the log's conventions
/// (found here when they are not fixed or due for a re-check).
MonitorEpoch identify_epoch(std::vector<TraceSample>& buf, const CsvStream& in, const MonitorOptions& opt,
                            int epoch, LogConventions& conv) {
  MonitorEpoch e;
  e.t_start_s = buf.front().t_s;
  e.t_end_s = buf.back().t_s;
  e.samples = buf.size();
  Trace t;
  t.samples.swap(buf);
  t.has_position = in.has_position();
  t.has_velocity = in.has_velocity();
  t.time_unit_stated = in.time_unit_stated();
  t.source = "epoch";
  const bool searching = conventions_due(opt, conv, epoch);
  const IdentifyResult r = identify(t, searching ? opt.identify : epoch_options(opt, conv));
  e.error = r.error;
  if (r.error.empty()) e.estimate = r.estimate;
  if (r.error.empty() && searching) {
    LogConventions found = conventions_of(r, epoch);
    found.times_found = conv.times_found + 1;
    found.times_changed = conv.times_changed + (conv.fixed && (found.force_sign != conv.force_sign ||
                                                                found.velocity_filter_hz != conv.velocity_filter_hz));
    conv = found;
  }
  buf.swap(t.samples);
  buf.clear();  // keeps its capacity: one epoch's memory, reused
  return e;
}

/// Value, se and identifiable of tracked index i in an epoch (as the monitor reads it).
struct Reading {
  double value = 0.0, se = 0.0;
  bool identifiable = false;
};
Reading reading(const MonitorEpoch& ep, int i) {
  Reading x;
  // Not identified at all: nothing it can carry; else the core's rule.
  if (ep.error.empty()) x.identifiable = feedid::tracked_value(ep.estimate, i, x.value, x.se);
  return x;
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
  TraceSample s;
  auto close_epoch = [&] {
    if (buf.size() < 2) return buf.clear();
    out.epochs.push_back(identify_epoch(buf, in, opt, static_cast<int>(out.epochs.size()), out.conventions));
    const MonitorEpoch& ep = out.epochs.back();
    int fresh = 0;
    if (ep.error.empty()) health.update(ep.estimate, ep.t_start_s, ep.t_end_s, fresh);
    for (int i = health.alarm_count() - fresh; i < health.alarm_count(); ++i) out.alarms.push_back(health.alarm(i));
    if (opt.progress) opt.progress(ep.t_end_s);
  };
  while (in.next(s)) {
    if (!buf.empty() && s.t_s - buf.front().t_s >= opt.detector.epoch_s) close_epoch();
    buf.push_back(s);
  }
  close_epoch();
  out.error = in.error();
  double v = 0.0, se = 0.0;
  for (int i = 0; i < feedid::kTrackedCount; ++i) out.referenced = out.referenced || health.reference(i, v, se);
  if (out.error.empty() && !out.referenced) {
    std::size_t identified = 0;
    for (const MonitorEpoch& ep : out.epochs) identified += ep.error.empty();
    out.error = "nothing was monitored: " + std::to_string(identified) + " of " + std::to_string(out.epochs.size()) +
                " epochs of " + std::to_string(opt.detector.epoch_s) + " s could be identified, and a reference needs " +
                std::to_string(opt.detector.reference_epochs) +
                " that carry a parameter (a longer log, more motion in both directions, or a longer --epoch-s)";
  }
  out.rows_skipped = in.rows_skipped();
  out.rows_repeated = in.rows_repeated();
  out.skipped_rows = in.skipped_rows();
  return out;
}

nlohmann::json to_json(const MonitorResult& r, const MonitorOptions& opt) {
  nlohmann::json epochs = nlohmann::json::array();
  for (const auto& ep : r.epochs) {
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
      j[d == 0 ? "pos" : "neg"] = side;
    }
    epochs.push_back(j);
  }
  nlohmann::json alarms = nlohmann::json::array();
  for (const auto& a : r.alarms)
    alarms.push_back({{"t_s", a.t_s},
                      {"raised_t_s", a.raised_t_s},
                      {"parameter", feedid::tracked_name(a.parameter)},
                      {"direction", a.direction == 0 ? nlohmann::json(nullptr) : nlohmann::json(direction_name(a.direction))},
                      {"change", a.change},
                      {"change_se", a.change_se},
                      {"change_pct", a.reference != 0 ? 100.0 * a.change / a.reference : 0.0},
                      {"reference", a.reference}});
  const LogConventions& c = r.conventions;
  nlohmann::json conventions = {{"fixed", c.fixed},
                                {"force_sign", c.force_sign},
                                {"force_lag_s", c.force_lag_s},
                                {"velocity_lag_s", std::isfinite(c.velocity_lag_s) ? nlohmann::json(c.velocity_lag_s) : nlohmann::json(nullptr)},
                                {"velocity_filter_hz", c.velocity_filter_hz},
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
                   {"rule", "each epoch identified alone; the first reference_epochs epochs a parameter can carry are "
                            "its reference; two-sided CUSUM of (epoch - reference) / (c sqrt(se^2 + se_ref^2)), c the "
                            "reference epochs' over-dispersion (>= 1); alarm above the threshold, then a new reference"}};
  j["input"] = {{"rows_skipped", r.rows_skipped}, {"rows_repeated", r.rows_repeated}, {"skipped_rows", r.skipped_rows}};
  if (!r.error.empty()) j["error"] = r.error;
  return j;
}

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
  if (r.alarms.empty() && r.referenced) o << "no alarms\n";
  for (const auto& a : r.alarms) {
    const Rounded c = round_to_se(a.change, a.change_se);
    std::snprintf(buf, sizeof buf, "ALARM at %.1f s (raised at %.1f s): %s%s%s changed by %s +- %s %s (%+.1f %%)\n", a.t_s, a.raised_t_s,
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
