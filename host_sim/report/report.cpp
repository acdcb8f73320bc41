#include "report.hpp"
#include "io/output_file.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <nlohmann/json.hpp>

#include "compensate/circle.hpp"
#include "compensate/compensate.hpp"
#include "io/number_format.hpp"
#include "io/svg_plot.hpp"

namespace feedid::host {
namespace {

PlotSeries scatter(const std::string& label, const std::vector<double>& x, const std::vector<double>& y,
                   const std::string& color) {
  PlotSeries s;
  s.label = label;
  s.x = x;
  s.y = y;
  s.color = color;
  s.line = false;
  return s;
}

/// HTML text with <, > and & escaped.
std::string html(const std::string& t) {
  std::string o;
  for (char c : t) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return o;
}

/// Three significant digits (a fitted effect parameter has no standard error of its own).
std::string sig3(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}

/// v &plusmn; se with the digits the standard error justifies (round_to_se).
std::string with_se(double v, double se) {
  if (!(se > 0) || !std::isfinite(se)) return sig3(v);
  const Rounded r = round_to_se(v, se);
  return r.value + " &plusmn; " + r.se;
}

/// Unit of a diagnosis parameter from its SI name's suffix, in the
/// axis's units (a rotary axis's "_N" is N m, its "_m" rad).
std::string unit_of(const std::string& key, const Units& u) {
  const std::pair<const char*, std::string> suffixes[] = {{"_Ns_m", u.viscous()}, {"_hz", "Hz"}, {"_kg", u.mass()},
                                                          {"_rad", "rad"}, {"_N", u.force}, {"_s", "s"}, {"_m", u.position}};
  if (key == "c2") return u.force + " s^2/" + u.position + "^2";
  for (const auto& [suffix, unit] : suffixes) {
    const std::string sfx = suffix;
    if (key.size() > sfx.size() && key.compare(key.size() - sfx.size(), sfx.size(), sfx) == 0) return unit;
  }
  return "";
}

std::string parameters_html(const nlohmann::json& p, const Units& u) {
  std::string o;
  for (auto it = p.begin(); p.is_object() && it != p.end(); ++it) {
    if (!it.value().is_number()) continue;
    o += (o.empty() ? "" : ", ") + html(it.key()) + " = " + sig3(it.value().get<double>()) + " " + html(unit_of(it.key(), u));
  }
  return o;
}

/// Side-by-side panels of the held-out residual against one block quantity:
/// the base model, and (if effects were named) the model with them, on one
/// y range so the two compare at a glance and neither hides the other.
std::string residual_panels(const DiagnoseResult& r, const std::vector<double>& q, const std::string& xlabel,
                            const std::string& id) {
  std::vector<double> x, before, after;
  for (std::size_t i = 0; i < q.size(); ++i)
    if (r.block_heldout[i]) {
      x.push_back(q[i]);
      before.push_back(r.block_r_base[i]);
      after.push_back(r.block_r_aug[i]);
    }
  const bool named = !r.effects.empty();
  double lo = 0.0, hi = 0.0;
  for (double v : before) lo = std::min(lo, v), hi = std::max(hi, v);
  for (double v : after) lo = std::min(lo, v), hi = std::max(hi, v);
  std::string effects;
  for (const auto& e : r.effects) effects += (effects.empty() ? "" : " + ") + e.kind;
  std::string o = "<div class=\"row\">";
  for (int panel = 0; panel < (named ? 2 : 1); ++panel) {
    PlotSpec p;
    p.id = id + std::to_string(panel);
    p.title = panel == 0 ? "base model" : "with " + effects;
    p.x = {xlabel, false};
    p.y = {"residual, 5 ms observation mean (" + r.base.units.force + ")", false, lo, hi};
    p.series.push_back(scatter("", x, panel == 0 ? before : after, panel == 0 ? "#7f7f7f" : "#d62728"));
    p.width_px = 470;
    p.height_px = 330;
    p.note = "held-out observations only";
    o += render_svg(p);
  }
  return o + "</div>\n";
}

std::string verdict_html(const DiagnoseResult& r) {
  std::ostringstream o;
  const Units& u = r.base.units;
  const std::string N = " " + html(u.force);
  o << "<table>\n<tr><th>verdict</th><td><b>" << html(r.effect) << "</b></td></tr>\n";
  for (const auto& e : r.effects)
    o << "<tr><th>" << html(e.kind) << "</th><td>" << parameters_html(e.parameters, u) << "<br>held-out RMS after adding it "
      << sig3(e.heldout_rms_N) << N << "; closes " << sig3(100 * e.closed_fraction) << " % of the excess; z " << sig3(e.z_statistic)
      << "</td></tr>\n";
  if (r.gap_remains && !r.effects.empty())
    o << "<tr><th>unexplained</th><td>a gap of " << sig3(r.rms_augmented_N) << N << " RMS remains"
      << (r.where_left.empty() ? "" : ", most in " + html(r.where_left.front().domain + " " + r.where_left.front().range))
      << "</td></tr>\n";
  for (const auto& a : r.ambiguities) o << "<tr><th>ambiguous</th><td>" << html(a.value("note", std::string())) << "</td></tr>\n";
  o << "<tr><th>held-out RMS, base model</th><td>" << sig3(r.rms_base_N) << N << "</td></tr>\n";
  o << "<tr><th>noise floor</th><td>" << sig3(r.noise_floor_N) << N << " white";
  if (r.sampling_floor_N > 0) o << ", " << sig3(r.sampling_floor_N) << N << " from point-sampled force at acceleration steps";
  o << "</td></tr>\n<tr><th>observations</th><td>" << r.blocks_identification << " identification, " << r.blocks_heldout
    << " held out";
  if (r.heldout_beyond_identification > 0)
    o << ", " << r.heldout_beyond_identification << " set aside (the identification folds do not pin the model down there)";
  o << "</td></tr>\n</table>\n";
  return o.str();
}

std::string where_and_candidates_html(const DiagnoseResult& r) {
  std::ostringstream o;
  const Units& u = r.base.units;
  o << "<h2>Where the base model's residual lies</h2>\n<p>Share of the held-out residual energy against share of "
       "held-out time.</p>\n<table>\n<tr><th>domain</th><th>range</th><th>energy</th><th>time</th></tr>\n";
  for (const auto& w : r.where)
    o << "<tr><td>" << html(w.domain) << "</td><td>" << html(w.range) << "</td><td>" << sig3(100 * w.share)
      << " %</td><td>" << sig3(100 * w.time_share) << " %</td></tr>\n";
  o << "</table>\n<h2>Candidates at the first step</h2>\n<p>Each fitted with the base model on the identification "
       "folds and judged on the held-out folds.</p>\n<table>\n<tr><th>effect</th><th>held-out RMS</th><th>closes</th>"
       "<th>z</th><th>judgement</th><th>parameters</th></tr>\n";
  for (const auto& c : r.candidates)
    o << "<tr><td>" << html(c.kind) << "</td><td>" << sig3(c.heldout_rms_N) << " " << html(u.force) << "</td><td>" << sig3(100 * c.closed_fraction)
      << " %</td><td>" << sig3(c.z_statistic) << "</td><td>"
      << (c.indistinguishable ? "indistinguishable" : c.significant ? "significant" : "not significant")
      << (c.note.empty() ? "" : "<br><small>" + html(c.note) + "</small>") << "</td><td>" << parameters_html(c.parameters, u)
      << "</td></tr>\n";
  o << "</table>\n";
  return o.str();
}

std::string base_model_html(const IdentifyResult& b) {
  const auto& e = b.estimate;
  const Units& u = b.units;
  std::ostringstream o;
  o << "<h2>Base model (identification folds)</h2>\n<table>\n<tr><th>parameter</th><th>v &gt; 0</th><th>v &lt; 0</th>"
       "<th>unit</th></tr>\n";
  o << "<tr><td>mass m</td><td colspan=\"2\">" << with_se(e.mass_kg, e.mass_se_kg) << "</td><td>" << html(u.mass())
    << "</td></tr>\n";
  auto row = [&](const char* name, const std::string& unit, auto value, auto se) {
    o << "<tr><td>" << name << "</td><td>" << with_se(value(e.pos), se(e.pos)) << "</td><td>"
      << with_se(value(e.neg), se(e.neg)) << "</td><td>" << html(unit) << "</td></tr>\n";
  };
  using D = feedid::DirectionEstimate<double>;
  row("viscous &sigma;", u.viscous(), [](const D& d) { return d.viscous_Ns_m; }, [](const D& d) { return d.viscous_se; });
  row("Coulomb F<sub>c</sub>", u.force, [](const D& d) { return d.coulomb_N; }, [](const D& d) { return d.coulomb_se; });
  row("break-away F<sub>s</sub>", u.force, [](const D& d) { return d.breakaway_N; }, [](const D& d) { return d.breakaway_se; });
  row("Stribeck v<sub>s</sub>", u.velocity(), [](const D& d) { return d.stribeck_velocity_m_s; },
      [](const D& d) { return d.stribeck_velocity_se; });
  o << "</table>\n";
  return o.str();
}

}  // namespace

PlotSpec friction_curve_plot(const IdentifyResult& r) {
  PlotSpec p;
  p.title = "Friction curve: measured band means and identified model";
  p.x = {"speed |v| (" + r.units.velocity() + ")", true};
  p.y = {"friction magnitude (" + r.units.force + ")", false};
  const DriveParams m = to_drive_params(r.estimate);
  const char* colors[2] = {"#1f77b4", "#ff7f0e"};
  for (int d = 0; d < 2; ++d) {
    std::vector<double> x, y;
    for (const auto& pt : r.friction_curve[d]) { x.push_back(pt.speed_m_s); y.push_back(pt.friction_N); }
    p.series.push_back(scatter(d == 0 ? "measured, v > 0" : "measured, v < 0", x, y, colors[d]));
    if (x.empty()) continue;
    PlotSeries line;
    line.label = d == 0 ? "model, v > 0" : "model, v < 0";
    line.color = colors[d];
    line.markers = false;
    line.dashed = d == 1;
    const double lo = x.front(), hi = x.back();
    for (int i = 0; i <= 200; ++i) {
      const double v = lo * std::pow(hi / lo, i / 200.0);
      line.x.push_back(v);
      line.y.push_back(std::fabs(stribeck_friction(m, d == 0 ? v : -v)));
    }
    p.series.push_back(line);
  }
  p.note = "points: mean of u - m a per velocity band (inertia removed); lines: identified F(|v|)";
  p.legend = "below";
  return p;
}

bool write_friction_curve_svg(const IdentifyResult& r, const std::string& path, std::string& error) {
  return write_svg(path, friction_curve_plot(r), error);
}

namespace {
/// What to load into the drive: the 20-point table of the base model, and a
/// circle test with two axes that are this drive, compensated by its model
/// exactly and 20 % off (docs/compensation.md).
std::string compensation_html(const IdentifyResult& b) {
  const Units& u = b.units;
  const DriveParams model = to_drive_params(b.estimate);
  const double top = b.config.velocity_max_m_s;
  if (!(top > 0)) return "";
  const CompensationTable t = make_compensation_table(model, top, 20);
  std::ostringstream o;
  o << "<h2>Friction compensation</h2>\n<p>The table <code>feedid compensate --model id.json --points 20</code> "
       "writes from the base model: breakpoints where the curve bends, largest interpolation error "
    << sig3(t.max_interpolation_error_N) << " " << html(u.force) << ". Magnitudes; the drive adds +F moving "
       "positive and &minus;F moving negative.</p>\n<table>\n<tr><th>#</th><th>speed v &gt; 0 ("
    << html(u.velocity()) << ")</th><th>friction (" << html(u.force) << ")</th><th>speed v &lt; 0 (" << html(u.velocity())
    << ")</th><th>friction (" << html(u.force) << ")</th></tr>\n";
  for (std::size_t k = 0; k < t.dir[0].size() && k < t.dir[1].size(); ++k)
    o << "<tr><td>" << k + 1 << "</td><td>" << sig3(t.dir[0][k].speed_m_s) << "</td><td>" << sig3(t.dir[0][k].force_N)
      << "</td><td>" << sig3(t.dir[1][k].speed_m_s) << "</td><td>" << sig3(t.dir[1][k].force_N) << "</td></tr>\n";
  o << "</table>\n";
  if (!u.linear_si()) return o.str() + "<p>(The circle test needs a linear axis in m and N.)</p>\n";
  CircleOptions c;
  c.drives = {model, model};
  c.models = {model, model};
  CircleResult cr;
  try {
    cr = run_circle(c);
  } catch (const std::exception& e) {
    return o.str() + "<p>Circle test not run: " + html(e.what()) + "</p>\n";
  }
  PlotSpec p = circle_plot(cr, c);
  p.id = "circle";
  o << "<p>Circle test (<code>feedid circle</code>): two axes that are this drive, radius "
    << sig3(c.radius_m * 1e3) << " mm at " << sig3(c.feed_m_s * 1e3)
    << " mm/s, compensated by the base model exactly and with every friction magnitude 20 % off. It shows what the "
       "model is worth if the drive follows it; on the machine the gain is smaller.</p>\n<table>\n"
       "<tr><th>compensation</th><th>largest quadrant glitch</th><th>RMS radial error</th></tr>\n";
  for (const auto& run : cr.runs)
    o << "<tr><td>" << html(run.name) << "</td><td>" << sig3(*std::max_element(run.glitch_um.begin(), run.glitch_um.end()))
      << " &micro;m</td><td>" << sig3(run.rms_um) << " &micro;m</td></tr>\n";
  o << "</table>\n" << render_svg(p);
  return o.str();
}
}  // namespace

bool write_diagnosis_report(const DiagnoseResult& r, const std::string& dir, const std::string& source,
                            std::string& error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) { error = dir + ": cannot create: " + ec.message(); return false; }
  PlotSpec curve = friction_curve_plot(r.base);
  curve.id = "curve";
  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>feedid diagnosis: " << html(source)
    << "</title>\n<style>\nbody{font-family:Helvetica,Arial,sans-serif;max-width:1000px;margin:2em auto;color:#222}\n"
       "table{border-collapse:collapse;margin:0.5em 0 1.5em}td,th{border:1px solid #ccc;padding:4px 8px;text-align:left;"
       "vertical-align:top}th{background:#f4f4f4}\n.row{display:flex;gap:12px;flex-wrap:wrap}\n</style>\n</head>\n<body>\n";
  o << "<h1>Sim-to-real gap diagnosis</h1>\n<p>Trace <code>" << html(source) << "</code>, made by <code>feedid diagnose --in "
    << html(source) << " --report " << html(dir) << "</code>. docs/diagnosis.md explains every quantity.</p>\n";
  o << "<h2>Verdict</h2>\n" << verdict_html(r) << where_and_candidates_html(r);
  o << "<h2>Friction curve</h2>\n" << render_svg(curve);
  o << "<h2>Held-out residual over velocity</h2>\n" << residual_panels(r, r.block_v, "velocity (" + r.base.units.velocity() + ")", "v");
  o << "<h2>Held-out residual over position</h2>\n" << residual_panels(r, r.block_x, "position (" + r.base.units.position + ")", "x");
  o << "<h2>Held-out residual over time</h2>\n" << residual_panels(r, r.block_t, "time (s)", "t");
  o << base_model_html(r.base) << compensation_html(r.base) << "</body>\n</html>\n";
  error = write_whole_file(dir + "/report.html", o.str());
  return error.empty();
}

bool write_force_plot_svg(const ValidateResult& r, const std::string& path, const std::string& title,
                          std::string& error) {
  PlotSpec p;
  p.title = title;
  p.x = {"time (s)", false};
  p.y = {"force (" + r.units.force + ")", false};
  PlotSeries meas;
  meas.label = "measured";
  meas.x = r.t;
  meas.y = r.u;
  meas.markers = false;
  meas.color = "#1f77b4";
  PlotSeries pred;
  pred.label = "predicted";
  pred.x = r.t;
  pred.y = r.u_hat;
  pred.markers = false;
  pred.color = "#d62728";
  pred.dashed = true;
  std::vector<double> err;
  for (std::size_t i = 0; i < r.u.size(); ++i) err.push_back(r.u[i] - r.u_hat[i]);
  PlotSeries e;
  e.label = "measured - predicted";
  e.x = r.t;
  e.y = err;
  e.markers = false;
  e.color = "#7f7f7f";
  p.series = {meas, pred, e};
  p.width_px = 1000;
  char buf[160];
  std::snprintf(buf, sizeof buf, "relative error %.3f %% (decimated by the protocol), RMS %.3g %s", r.relative_error_pct,
                r.rms_error_N, r.units.force.c_str());
  p.note = buf;
  return write_svg(path, p, error);
}

}  // namespace feedid::host

namespace feedid::host {
namespace {

struct ReplaySignal {
  const char* name;
  std::string (*unit)(const Units&);
  const std::vector<double> ReplayResult::*measured;
  const std::vector<double> ReplayResult::*simulated;
  double ReplayFigures::*figure;
};

const ReplaySignal kReplaySignals[] = {
    {"position", [](const Units& u) { return u.position; }, &ReplayResult::x, &ReplayResult::x_sim, &ReplayFigures::position},
    {"velocity", [](const Units& u) { return u.velocity(); }, &ReplayResult::v, &ReplayResult::v_sim, &ReplayFigures::velocity},
    {"acceleration", [](const Units& u) { return u.acceleration(); }, &ReplayResult::a, &ReplayResult::a_sim,
     &ReplayFigures::acceleration},
    {"force", [](const Units& u) { return u.force; }, &ReplayResult::u, &ReplayResult::u_sim, &ReplayFigures::force},
};

const ReplaySignal& replay_signal(const std::string& name) {
  for (const ReplaySignal& s : kReplaySignals)
    if (name == s.name) return s;
  throw std::invalid_argument("no replay signal '" + name + "'");
}

PlotSeries line_series(const std::string& label, const std::string& color, bool dashed) {
  PlotSeries s;
  s.label = label;
  s.color = color;
  s.markers = false;
  s.dashed = dashed;
  return s;
}

}  // namespace

PlotSpec replay_plot(const ReplayResult& r, const std::string& signal, const std::string& title) {
  const ReplaySignal& s = replay_signal(signal);
  const std::vector<double>& y = r.*s.measured;
  const std::vector<double>& y_sim = r.*s.simulated;
  PlotSeries meas = line_series("measured", "#1f77b4", false), sim = line_series("simulated", "#d62728", true),
             diff = line_series("measured - simulated", "#7f7f7f", false);
  const std::size_t every = std::max<std::size_t>(1, r.t.size() / 4000);
  for (std::size_t k = 0; k < r.t.size(); k += every) {
    for (PlotSeries* p : {&meas, &sim, &diff}) p->x.push_back(r.t[k]);
    meas.y.push_back(y[k]);
    sim.y.push_back(y_sim[k]);
    diff.y.push_back(y[k] - y_sim[k]);
  }
  PlotSpec p;
  p.title = title;
  p.id = signal;
  p.x = {"time (s)", false};
  p.y = {std::string(s.name) + " (" + s.unit(r.units) + ")", false};
  p.series = {meas, sim, diff};
  p.width_px = 1000;
  p.legend = "below";
  char buf[200];
  std::snprintf(buf, sizeof buf, "relative error %.4g %% (both sides processed alike: %.4g %%)", r.error_pct.*s.figure,
                r.same_processing_pct.*s.figure);
  p.note = buf;
  return p;
}

bool write_replay_report(const ReplayResult& r, const std::string& dir, const std::string& source,
                         const std::string& command, std::string& error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) { error = dir + ": cannot create: " + ec.message(); return false; }
  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>feedid replay: " << html(source)
    << "</title>\n<style>\nbody{font-family:Helvetica,Arial,sans-serif;max-width:1000px;margin:2em auto;color:#222}\n"
       "table{border-collapse:collapse;margin:0.5em 0 1.5em}td,th{border:1px solid #ccc;padding:4px 8px;text-align:right}"
       "th{background:#f4f4f4}\n</style>\n</head>\n<body>\n";
  o << "<h1>Closed-loop replay</h1>\n<p>Run <code>" << html(source) << "</code>, made by <code>" << html(command)
    << "</code>. docs/reference.md (\"replay\") defines every figure.</p>\n";
  o << "<table><tr><th>relative error (%)</th>";
  for (const ReplaySignal& s : kReplaySignals) o << "<th>" << s.name << "</th>";
  const std::pair<const char*, const ReplayFigures*> rows[] = {
      {"measured processed, simulated from the plant's state (published comparison)", &r.error_pct},
      {"both sides processed alike", &r.same_processing_pct},
      {"the processing alone (simulated state against simulated processed)", &r.processing_pct}};
  for (const auto& [label, f] : rows) {
    o << "</tr>\n<tr><td style=\"text-align:left\">" << label << "</td>";
    char buf[32];
    for (const ReplaySignal& s : kReplaySignals) {
      std::snprintf(buf, sizeof buf, "%.4g", (*f).*s.figure);
      o << "<td>" << buf << "</td>";
    }
  }
  o << "</tr></table>\n";
  for (const ReplaySignal& s : kReplaySignals)
    o << "<h2>" << s.name << "</h2>\n" << render_svg(replay_plot(r, s.name, std::string("Replay: ") + s.name));
  o << "</body>\n</html>\n";
  error = write_whole_file(dir + "/report.html", o.str());
  return error.empty();
}

}  // namespace feedid::host
