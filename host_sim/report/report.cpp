#include "report.hpp"
#include "io/output_file.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <nlohmann/json.hpp>

#include "compensate/circle.hpp"
#include "compensate/compensate.hpp"
#include "gap/model_gap.hpp"
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

/// A percentage to whole percent: the shares and closed fractions come
/// from held-out RMS figures whose relative standard error is about
/// 1/sqrt(2 n) (a few percent for a few hundred observations), so digits
/// below one percent are noise (no "closes 7.84e-13 %").
std::string pct0(double share) {
  char b[32];
  const double v = 100.0 * share;
  std::snprintf(b, sizeof b, "%.0f", std::fabs(v) < 0.5 ? 0.0 : v);
  return b;
}

/// A held-out RMS over n observations with the digits its standard error
/// rms / sqrt(2 n) justifies (round_to_se; the error itself is not shown).
std::string rms_text(double rms, std::size_t n) {
  const double se = rms / std::sqrt(2.0 * static_cast<double>(n));
  if (n == 0 || !(se > 0) || !std::isfinite(se)) return sig3(rms);
  const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(se))));  // to se's first digit
  char b[32];
  std::snprintf(b, sizeof b, "%.*f", decimals, rms);
  return b;
}

std::string z_text(double z) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", z);
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

/// The "where" entries of one domain as shaded x ranges, labelled with
/// their share of the residual energy against their share of time.
std::vector<PlotBand> where_bands(const std::vector<WhereEntry>& where, const std::string& domain) {
  std::vector<PlotBand> out;
  for (const WhereEntry& w : where)
    if (w.domain == domain) out.push_back({w.lo, w.hi, pct0(w.share) + " % of energy in " + pct0(w.time_share) + " % of time"});
  return out;
}

/// Panels of the held-out residual against one block quantity, one above
/// the other at the page's width: the base model with the "where" windows
/// of its residual shaded, and (if effects were named) the model with them
/// and the windows of what they leave, on one y range so the two compare.
std::string residual_panels(const DiagnoseResult& r, const std::vector<double>& q, const std::string& xlabel,
                            const std::string& id, const std::string& domain) {
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
  std::string o;
  for (int panel = 0; panel < (named ? 2 : 1); ++panel) {
    PlotSpec p;
    p.id = id + std::to_string(panel);
    p.title = panel == 0 ? "base model" : "with " + effects;
    p.x = {xlabel, false};
    p.y = {"residual, observation mean (" + r.base.units.force + ")", false, lo, hi};
    p.series.push_back(scatter("", x, panel == 0 ? before : after, panel == 0 ? "#7f7f7f" : "#d62728"));
    p.x_bands = where_bands(panel == 0 ? r.where : r.where_left, domain);
    p.width_px = 1000;
    p.height_px = 360;
    p.note = "held-out observations only; shaded: where the residual's energy lies (the \"where\" table)";
    o += render_svg(p);
  }
  return o;
}

std::string verdict_html(const DiagnoseResult& r) {
  std::ostringstream o;
  const Units& u = r.base.units;
  const std::string N = " " + html(u.force);
  o << "<table>\n<tr><th>verdict</th><td><b>" << html(r.effect) << "</b></td></tr>\n";
  for (const auto& e : r.effects)
    o << "<tr><th>" << html(e.kind) << "</th><td>" << parameters_html(e.parameters, u) << "<br>held-out RMS after adding it "
      << rms_text(e.heldout_rms_N, r.blocks_heldout) << N << "; closes " << pct0(e.closed_fraction) << " % of the excess; z "
      << z_text(e.z_statistic) << "</td></tr>\n";
  if (r.gap_remains && !r.effects.empty())
    o << "<tr><th>unexplained</th><td>a gap of " << rms_text(r.rms_augmented_N, r.blocks_heldout) << N << " RMS remains"
      << (r.where_left.empty() ? "" : ", most in " + html(r.where_left.front().domain + " " + r.where_left.front().range))
      << "</td></tr>\n";
  for (const auto& a : r.ambiguities) o << "<tr><th>ambiguous</th><td>" << html(a.value("note", std::string())) << "</td></tr>\n";
  o << "<tr><th>held-out RMS, base model</th><td>" << rms_text(r.rms_base_N, r.blocks_heldout) << N << "</td></tr>\n";
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
    o << "<tr><td>" << html(w.domain) << "</td><td>" << html(w.range) << "</td><td>" << pct0(w.share)
      << " %</td><td>" << pct0(w.time_share) << " %</td></tr>\n";
  o << "</table>\n<h2>Candidates at the first step</h2>\n<p>Each fitted with the base model on the identification "
       "folds and judged on the held-out folds.</p>\n<table>\n<tr><th>effect</th><th>held-out RMS</th><th>closes</th>"
       "<th>z</th><th>judgement</th><th>parameters</th></tr>\n";
  for (const auto& c : r.candidates)
    o << "<tr><td>" << html(c.kind) << "</td><td>" << rms_text(c.heldout_rms_N, r.blocks_heldout) << " " << html(u.force)
      << "</td><td>" << pct0(c.closed_fraction) << " %</td><td>" << z_text(c.z_statistic) << "</td><td>"
      << (c.indistinguishable ? "indistinguishable" : c.significant ? "significant" : "not significant")
      << (c.note.empty() ? "" : "<br><small>" + html(c.note) + "</small>") << "</td><td>" << parameters_html(c.parameters, u)
      << "</td></tr>\n";
  o << "</table>\n";
  return o.str();
}

/// One direction's Stribeck term, or "not in the model" where it has none
/// (Fs 0: model selection kept Coulomb and viscous only; its standard
/// error then belongs to a term that is not there, not shown as 0 &plusmn; 540).
bool has_stribeck(const feedid::DirectionEstimate<double>& d) { return d.friction_identified() && d.breakaway_N > 0; }

std::string base_model_html(const IdentifyResult& b) {
  const auto& e = b.estimate;
  const Units& u = b.units;
  std::ostringstream o;
  o << "<h2>Base model (identification folds)</h2>\n<table>\n<tr><th>parameter</th><th>v &gt; 0</th><th>v &lt; 0</th>"
       "<th>unit</th></tr>\n";
  o << "<tr><td>mass m</td><td colspan=\"2\">" << with_se(e.mass_kg, e.mass_se_kg) << "</td><td>" << html(u.mass())
    << "</td></tr>\n";
  using D = feedid::DirectionEstimate<double>;
  auto row = [&](const char* name, const std::string& unit, bool stribeck, auto value, auto se) {
    auto cell = [&](const D& d) { return stribeck && !has_stribeck(d) ? std::string("not in the model") : with_se(value(d), se(d)); };
    o << "<tr><td>" << name << "</td><td>" << cell(e.pos) << "</td><td>" << cell(e.neg) << "</td><td>" << html(unit)
      << "</td></tr>\n";
  };
  row("viscous &sigma;", u.viscous(), false, [](const D& d) { return d.viscous_Ns_m; }, [](const D& d) { return d.viscous_se; });
  row("Coulomb F<sub>c</sub>", u.force, false, [](const D& d) { return d.coulomb_N; }, [](const D& d) { return d.coulomb_se; });
  row("break-away F<sub>s</sub>", u.force, true, [](const D& d) { return d.breakaway_N; }, [](const D& d) { return d.breakaway_se; });
  row("Stribeck v<sub>s</sub>", u.velocity(), true, [](const D& d) { return d.stribeck_velocity_m_s; },
      [](const D& d) { return d.stribeck_velocity_se; });
  o << "</table>\n";
  return o.str();
}

/// A value a model file states, as it states it (six significant digits).
std::string stated(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

/// A given model as the file states it (no standard errors: it is not fitted here).
std::string given_model_html(const ModelFile& m, const Units& u) {
  const DriveParams& d = m.drive;
  std::ostringstream o;
  o << "<h2>Base model (given: " << html(m.source) << ", not refitted)</h2>\n<table>\n<tr><th>parameter</th>"
       "<th>v &gt; 0</th><th>v &lt; 0</th><th>unit</th></tr>\n<tr><td>mass m</td><td colspan=\"2\">"
    << stated(d.mass_kg) << "</td><td>" << html(u.mass()) << "</td></tr>\n";
  auto row = [&](const char* name, const std::string& unit, double pos, double neg, bool present) {
    o << "<tr><td>" << name << "</td><td>" << (present ? stated(pos) : "not in the model") << "</td><td>"
      << (present ? stated(neg) : "not in the model") << "</td><td>" << html(unit) << "</td></tr>\n";
  };
  const bool dip = d.pos.breakaway_N > 0 || d.neg.breakaway_N > 0;
  row("viscous &sigma;", u.viscous(), d.pos.viscous_Ns_m, d.neg.viscous_Ns_m, true);
  row("Coulomb F<sub>c</sub>", u.force, d.pos.coulomb_N, d.neg.coulomb_N, true);
  row("break-away F<sub>s</sub>", u.force, d.pos.breakaway_N, d.neg.breakaway_N, dip);
  row("Stribeck v<sub>s</sub>", u.velocity(), d.pos.stribeck_velocity_m_s, d.neg.stribeck_velocity_m_s, dip);
  o << "<tr><td>offset</td><td colspan=\"2\">" << (m.load.offset_N != 0 ? stated(m.load.offset_N) : "not in the model")
    << "</td><td>" << html(u.force) << "</td></tr>\n";
  if (m.load.gravity_N != 0)
    o << "<tr><td>gravity G cos(q - q<sub>0</sub>)</td><td>G " << stated(m.load.gravity_N) << "</td><td>q<sub>0</sub> "
      << stated(m.load.gravity_angle0_rad) << " rad</td><td>" << html(u.force) << "</td></tr>\n";
  o << "</table>\n";
  return o.str();
}

/// The held-out gap before and after each effect forward selection added
/// (a step chart against the noise floor) and the same as a table.
std::string gap_steps_html(const DiagnoseResult& r) {
  const Units& u = r.base.units;
  PlotSpec p;
  p.id = "steps";
  p.title = "Held-out gap as effects are added";
  const double last = static_cast<double>(r.effects.size()) + 0.25;
  p.x = {"effects added (0: the base model; the table names each)", false, -0.25, last};
  p.y = {"held-out RMS force residual (" + u.force + ")", false, 0.0};
  PlotSeries gap = scatter("held-out RMS", {0.0}, {r.rms_base_N}, "#d62728");
  gap.line = true;
  for (std::size_t k = 0; k < r.effects.size(); ++k) {
    gap.x.push_back(static_cast<double>(k + 1));
    gap.y.push_back(r.effects[k].heldout_rms_N);
  }
  PlotSeries floor;
  floor.label = "noise floor";
  floor.x = {-0.25, last};
  floor.y = {r.noise_floor_N, r.noise_floor_N};
  floor.color = "#1f77b4";
  floor.markers = false;
  floor.dashed = true;
  p.series = {gap, floor};
  p.width_px = 1000;
  p.height_px = 320;
  p.legend = "below";
  std::ostringstream o;
  o << "<h2>The gap before and after each added effect</h2>\n" << render_svg(p)
    << "<table>\n<tr><th>step</th><th>model</th><th>held-out RMS (" << html(u.force) << ")</th><th>closes (of the excess "
       "over the noise floor)</th><th>z when added</th></tr>\n<tr><td>0</td><td>base model</td><td>"
    << rms_text(r.rms_base_N, r.blocks_heldout) << "</td><td>&ndash;</td><td>&ndash;</td></tr>\n";
  std::string model = "base";
  for (std::size_t k = 0; k < r.effects.size(); ++k) {
    const NamedEffect& e = r.effects[k];
    model += " + " + e.kind;
    o << "<tr><td>" << k + 1 << "</td><td>" << html(model) << "</td><td>" << rms_text(e.heldout_rms_N, r.blocks_heldout)
      << "</td><td>" << pct0(e.closed_fraction) << " %</td><td>" << z_text(e.z_statistic) << "</td></tr>\n";
  }
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
  if (!t.error.empty()) return "";
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
  const CircleResult cr = run_circle(c);
  if (!cr.error.empty()) return o.str() + "<p>Circle test not run: " + html(cr.error) + "</p>\n";
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

namespace {
/// The page's head: every figure takes the page's width (the SVGs scale
/// with their viewBox), tables as the diagnosis's.
std::string page_head(const std::string& title) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" + html(title) +
         "</title>\n<style>\nbody{font-family:Helvetica,Arial,sans-serif;max-width:1000px;margin:2em auto;color:#222}\n"
         "table{border-collapse:collapse;margin:0.5em 0 1.5em}td,th{border:1px solid #ccc;padding:4px 8px;text-align:left;"
         "vertical-align:top}th{background:#f4f4f4}\nsvg{display:block;width:100%;height:auto;margin:0.5em 0}\n"
         "</style>\n</head>\n<body>\n";
}

bool create_dir(const std::string& dir, std::string& error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) error = dir + ": cannot create: " + ec.message();
  return !ec;
}

/// The diagnosis's sections: verdict, where, the gap step by step, the
/// candidates, the held-out residual with the "where" windows, the base model.
std::string diagnosis_sections(const DiagnoseResult& r) {
  std::ostringstream o;
  o << "<h2>Verdict</h2>\n" << verdict_html(r) << where_and_candidates_html(r) << gap_steps_html(r);
  if (!r.model_given) {
    PlotSpec curve = friction_curve_plot(r.base);
    curve.id = "curve";
    curve.width_px = 1000;
    o << "<h2>Friction curve</h2>\n" << render_svg(curve);
  }
  o << "<h2>Held-out residual over time</h2>\n" << residual_panels(r, r.block_t, "time (s)", "t", "time");
  o << "<h2>Held-out residual over velocity</h2>\n"
    << residual_panels(r, r.block_v, "velocity (" + r.base.units.velocity() + ")", "v", "velocity");
  o << "<h2>Held-out residual over position</h2>\n"
    << residual_panels(r, r.block_x, "position (" + r.base.units.position + ")", "x", "position");
  if (r.model_given) return o.str() + given_model_html(r.given_model, r.base.units);
  return o.str() + base_model_html(r.base) + compensation_html(r.base);
}
}  // namespace

bool write_diagnosis_report(const DiagnoseResult& r, const std::string& dir, const std::string& source,
                            const std::string& command, std::string& error) {
  if (!create_dir(dir, error)) return false;
  std::ostringstream o;
  o << page_head("feedid diagnosis: " + source);
  o << "<h1>Sim-to-real gap diagnosis</h1>\n<p>Trace <code>" << html(source) << "</code>, made by <code>" << html(command)
    << "</code>. docs/diagnosis.md explains every quantity.</p>\n";
  o << diagnosis_sections(r) << "</body>\n</html>\n";
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

// The signal names come from the code that draws the page, never from input:
// an unknown one is a programming error, not an error to report.
const ReplaySignal& replay_signal(const std::string& name) {
  for (const ReplaySignal& s : kReplaySignals)
    if (name == s.name) return s;
  throw std::logic_error("no replay signal '" + name + "'");
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

namespace {

/// Every `every`-th compared sample of y (at most about 4000 points).
std::vector<double> thinned(const std::vector<double>& y, std::size_t every) {
  std::vector<double> out;
  for (std::size_t k = 0; k < y.size(); k += every) out.push_back(y[k]);
  return out;
}

std::size_t thinning(const ReplayResult& r) { return std::max<std::size_t>(1, r.t.size() / 4000); }

/// A replay figure (%) to three significant digits.
std::string figure_text(double v) {
  if (!std::isfinite(v)) return "&ndash;";
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}

/// A table of replay figures: a labelled row each (label HTML), a column per signal.
std::string figures_table(const std::string& corner, const std::vector<std::pair<std::string, const ReplayFigures*>>& rows) {
  std::ostringstream o;
  o << "<table><tr><th>" << corner << "</th>";
  for (const ReplaySignal& s : kReplaySignals) o << "<th>" << s.name << "</th>";
  for (const auto& [label, f] : rows) {
    o << "</tr>\n<tr><td>" << label << "</td>";
    for (const ReplaySignal& s : kReplaySignals) o << "<td>" << figure_text((*f).*s.figure) << "</td>";
  }
  o << "</tr></table>\n";
  return o.str();
}

}  // namespace

PlotSpec replay_plot(const ReplayResult& r, const std::string& signal, const std::string& title) {
  const ReplaySignal& s = replay_signal(signal);
  const std::size_t every = thinning(r);
  PlotSeries meas = line_series("measured", "#1f77b4", false), sim = line_series("simulated", "#d62728", true);
  meas.x = sim.x = thinned(r.t, every);
  meas.y = thinned(r.*s.measured, every);
  sim.y = thinned(r.*s.simulated, every);
  PlotSpec p;
  p.title = title;
  p.id = signal;
  p.x = {"time (s)", false};
  p.y = {std::string(s.name) + " (" + s.unit(r.units) + ")", false};
  p.series = {meas, sim};
  p.width_px = 1000;
  p.legend = "below";
  p.note = "relative error " + figure_text(r.error_pct.*s.figure) + " % (both sides processed alike: " +
           figure_text(r.same_processing_pct.*s.figure) + " %)";
  return p;
}

PlotSpec replay_residual_plot(const std::vector<const ReplayResult*>& runs, const std::vector<std::string>& labels,
                              const std::string& signal, const std::string& title) {
  const ReplaySignal& s = replay_signal(signal);
  const char* colors[] = {"#7f7f7f", "#d62728", "#2ca02c"};
  PlotSpec p;
  p.title = title;
  p.id = signal + "_residual";
  p.x = {"time (s)", false};
  p.y = {"measured - simulated " + std::string(s.name) + " (" + s.unit(runs.front()->units) + ")", false};
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const ReplayResult& r = *runs[i];
    const std::size_t every = thinning(r);
    PlotSeries d = line_series(labels[i], colors[i % 3], false);
    d.x = thinned(r.t, every);
    for (std::size_t k = 0; k < r.t.size(); k += every) d.y.push_back((r.*s.measured)[k] - (r.*s.simulated)[k]);
    p.series.push_back(d);
  }
  p.width_px = 1000;
  p.height_px = 320;
  p.legend = "below";
  return p;
}

bool write_replay_report(const ReplayResult& r, const std::string& dir, const std::string& source,
                         const std::string& command, std::string& error) {
  if (!create_dir(dir, error)) return false;
  std::ostringstream o;
  o << page_head("feedid replay: " + source);
  o << "<h1>Closed-loop replay</h1>\n<p>Run <code>" << html(source) << "</code>, made by <code>" << html(command)
    << "</code>. docs/reference.md (\"replay\") defines every figure.</p>\n";
  o << figures_table("relative error (%)",
                      {{"measured processed, simulated from the plant's state (published comparison)", &r.error_pct},
                       {"both sides processed alike", &r.same_processing_pct},
                       {"the processing alone (simulated state against simulated processed)", &r.processing_pct}});
  for (const ReplaySignal& s : kReplaySignals)
    o << "<h2>" << s.name << "</h2>\n" << render_svg(replay_plot(r, s.name, std::string("Replay: ") + s.name))
      << render_svg(replay_residual_plot({&r}, {"measured - simulated"}, s.name, std::string("Residual: ") + s.name));
  o << "</body>\n</html>\n";
  error = write_whole_file(dir + "/report.html", o.str());
  return error.empty();
}

namespace {

/// The replay's held-out figures before and after the causes, and how the comparison was judged.
std::string model_gap_replay_table(const ModelGap& g) {
  std::ostringstream o;
  o << "<h2>Replay in the drive's loop, held-out time</h2>\n<p>" << g.heldout_samples << " of "
    << g.before.samples_compared << " compared samples lie in held-out folds; the effects were fitted on the others. "
       "Relative error 100 &Vert;y &minus; y<sub>sim</sub>&Vert; / &Vert;y&Vert; (%).</p>\n"
    << figures_table("", {{"before (the model as given)", &g.before_pct},
                          {"&nbsp;&nbsp;both sides processed alike", &g.before_same_pct},
                          {"&nbsp;&nbsp;the processing alone", &g.processing_pct},
                          {"with the named effects in the plant", &g.after_effects_pct},
                          {"&nbsp;&nbsp;both sides processed alike", &g.after_same_pct},
                          {"<b>after</b> (every named cause)", &g.after_pct}})
    << "<p>The comparison (the measurement is processed, the simulation is not) "
    << (g.comparison_named ? "<b>is named a cause</b>" : "is not a cause here") << ": processing the simulation alike removes "
    << pct0(g.comparison_share[0]) << " % of the velocity's and " << pct0(g.comparison_share[1])
    << " % of the acceleration's held-out error energy, z " << z_text(g.comparison_z[0]) << " and "
    << z_text(g.comparison_z[1]) << " against " << z_text(g.comparison_significance_z) << " needed.</p>\n<ul>\n";
  for (const PlantEffect& p : g.plant) o << "<li>" << html(p.kind) << ": " << html(p.note) << "</li>\n";
  return o.str() + "</ul>\n";
}

/// Measured against the simulation before and after the causes, and both residuals, for each signal.
std::string model_gap_replay_figures(const ModelGap& g) {
  std::ostringstream o;
  for (const ReplaySignal& s : kReplaySignals) {
    PlotSpec p = replay_plot(g.before, s.name, std::string("Replay: ") + s.name);
    p.series[1].label = "simulated, the model as given";
    PlotSeries after = line_series("simulated, with the named effects", "#2ca02c", true);
    const std::size_t every = thinning(g.after);
    after.x = thinned(g.after.t, every);
    after.y = thinned(g.after.*s.simulated, every);
    p.series.push_back(after);
    p.note = "whole run; held-out figures in the table above";
    o << "<h3>" << s.name << "</h3>\n" << render_svg(p)
      << render_svg(replay_residual_plot({&g.before, &g.after}, {"the model as given", "with the named effects"}, s.name,
                                         std::string("Residual: ") + s.name));
  }
  return o.str();
}

}  // namespace

bool write_model_gap_report(const ModelGap& g, const std::string& dir, const std::string& source,
                            const std::string& command, std::string& error) {
  if (!create_dir(dir, error)) return false;
  const DiagnoseResult& r = g.diagnosis;
  std::ostringstream o;
  o << page_head("feedid diagnose --model: " + source);
  o << "<h1>The gap of a given model</h1>\n<p>Model <code>" << html(r.given_model.source) << "</code> on <code>"
    << html(source) << "</code>, made by <code>" << html(command)
    << "</code>. docs/diagnosis.md (4b) explains every quantity.</p>\n";
  if (g.replayed) o << model_gap_replay_table(g) << "<h2>Replay overlay and residual</h2>\n" << model_gap_replay_figures(g);
  o << diagnosis_sections(r) << "</body>\n</html>\n";
  error = write_whole_file(dir + "/report.html", o.str());
  return error.empty();
}

namespace {

/// The parameters a fleet page sets side by side: the column stem and its units key.
const char* const kFleetTerms[] = {"sigma", "fc", "fs", "vs"};

/// A row's number under `key`; NaN where it is missing or null (a failed log).
double fleet_number(const nlohmann::json& row, const std::string& key) {
  const auto it = row.find(key);
  return it != row.end() && it->is_number() ? it->get<double>() : std::numeric_limits<double>::quiet_NaN();
}

std::string fleet_text(const nlohmann::json& row, const std::string& key) {
  const auto it = row.find(key);
  return it != row.end() && it->is_string() ? it->get<std::string>() : "";
}

/// Whether the row marks the parameter not identifiable (`<key>_identifiable` false).
bool fleet_unidentifiable(const nlohmann::json& row, const std::string& key) {
  const auto it = row.find(key + "_identifiable");
  return it != row.end() && it->is_boolean() && !it->get<bool>();
}

/// A figure cell: value +- se with the digits the se justifies, greyed and
/// said where the data cannot tell it (no "Fs 0 +- 540" read as a finding);
/// blank where there is none.
std::string fleet_cell(const nlohmann::json& row, const std::string& key) {
  const double v = fleet_number(row, key);
  if (!std::isfinite(v)) return "<td></td>";
  const std::string text = with_se(v, fleet_number(row, key + "_se"));
  if (fleet_unidentifiable(row, key)) return "<td class=\"ni\">" + text + " (not identifiable)</td>";
  return "<td class=\"num\">" + text + "</td>";
}

/// A log's name in the table: each file's name (the folder is in the title, shown on hover).
std::string fleet_log_name(const std::string& path) {
  std::string shown;
  std::size_t from = 0;
  for (;;) {
    const std::size_t plus = path.find(" + ", from);
    const std::string one = path.substr(from, plus == std::string::npos ? std::string::npos : plus - from);
    shown += (shown.empty() ? "" : " + ") + std::filesystem::path(one).filename().string();
    if (plus == std::string::npos) break;
    from = plus + 3;
  }
  return "<code title=\"" + html(path) + "\">" + html(shown) + "</code>";
}

/// The first row's units dict that is there (failed logs have none).
nlohmann::json fleet_units(const nlohmann::json& rows) {
  for (const auto& r : rows)
    if (r.contains("units") && r.at("units").is_object()) return r.at("units");
  return nlohmann::json::object();
}

std::string fleet_table(const nlohmann::json& rows, const nlohmann::json& units) {
  const auto unit = [&](const char* k) { return units.contains(k) ? " (" + html(units.at(k).get<std::string>()) + ")" : ""; };
  std::ostringstream o;
  o << "<style>td.num{white-space:nowrap}td.ni{white-space:nowrap;color:#999}</style>\n"
    << "<div style=\"overflow-x:auto\"><table>\n<tr><th>#</th><th>log</th><th>status</th><th>m" << unit("m") << "</th>";
  for (const char* t : kFleetTerms) o << "<th>pos " << t << unit(t) << "</th><th>neg " << t << unit(t) << "</th>";
  o << "<th>error</th></tr>\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const nlohmann::json& r = rows[i];
    o << "<tr><td>" << i + 1 << "</td><td>" << fleet_log_name(fleet_text(r, "path")) << "</td><td>"
      << html(fleet_text(r, "status")) << "</td>" << fleet_cell(r, "m");
    for (const char* t : kFleetTerms) o << fleet_cell(r, std::string("pos_") + t) << fleet_cell(r, std::string("neg_") + t);
    o << "<td>" << html(fleet_text(r, "error")) << "</td></tr>\n";
  }
  o << "</table></div>\n";
  return o.str();
}

/// Each axis's estimate of `key` at x = its row number (+ shift) and its
/// +-1 standard error as a vertical bar (a broken line per axis): those the
/// data can tell (`identifiable`) or those it cannot, drawn apart in grey.
void fleet_series(const nlohmann::json& rows, const std::string& key, bool identifiable, std::string label,
                  std::string color, double shift, PlotSpec& p) {
  if (!identifiable) color = "#aaaaaa";
  PlotSeries points, bars;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const bool shown = fleet_unidentifiable(rows[i], key) != identifiable;
    const double v = shown ? fleet_number(rows[i], key) : nan;
    const double se = fleet_number(rows[i], key + "_se"), x = double(i + 1) + shift;
    points.x.push_back(x);
    points.y.push_back(v);
    if (!std::isfinite(v) || !std::isfinite(se)) continue;
    bars.x.insert(bars.x.end(), {x, x, nan});
    bars.y.insert(bars.y.end(), {v - se, v + se, nan});
  }
  p.series.push_back(scatter(label, points.x, points.y, color));
  bars.color = color;
  bars.markers = false;
  p.series.push_back(bars);
}

PlotSpec fleet_plot(const nlohmann::json& rows, const std::string& term, const nlohmann::json& units) {
  PlotSpec p;
  p.id = "fleet_" + term;
  p.title = term + " per axis (+-1 standard error)";
  p.width_px = 1000;
  p.height_px = 320;
  p.x = {"axis (row # in the table)", false, 0.5, double(rows.size()) + 0.5};
  p.y = {term + (units.contains(term) ? " (" + units.at(term).get<std::string>() + ")" : ""), false};
  p.legend = "below";
  if (term == "m") {
    fleet_series(rows, "m", true, "m", "#1f77b4", 0.0, p);
    fleet_series(rows, "m", false, "not identifiable", "", 0.0, p);
    return p;
  }
  fleet_series(rows, "pos_" + term, true, "positive direction", "#1f77b4", -0.08, p);
  fleet_series(rows, "neg_" + term, true, "negative direction", "#d62728", 0.08, p);
  fleet_series(rows, "pos_" + term, false, "not identifiable", "", -0.08, p);
  fleet_series(rows, "neg_" + term, false, "", "", 0.08, p);
  return p;
}
}  // namespace

bool write_fleet_report(const nlohmann::json& rows, const std::string& dir, const std::string& command,
                        std::string& error) {
  if (!rows.is_array()) {
    error = "fleet report: the rows must be a list of objects (one per log)";
    return false;
  }
  if (!create_dir(dir, error)) return false;
  const nlohmann::json units = fleet_units(rows);
  std::ostringstream o;
  o << page_head("feedid fleet: " + std::to_string(rows.size()) + " axes");
  o << "<h1>Fleet: " << rows.size() << " axes side by side</h1>\n<p>Made by <code>" << html(command)
    << "</code>. One row per log; docs/python.md (\"A fleet\") defines every column.</p>\n";
  o << fleet_table(rows, units);
  o << "<h2>m</h2>\n" << render_svg(fleet_plot(rows, "m", units));
  for (const char* t : kFleetTerms) o << "<h2>" << t << "</h2>\n" << render_svg(fleet_plot(rows, t, units));
  o << "</body>\n</html>\n";
  error = write_whole_file(dir + "/report.html", o.str());
  return error.empty();
}

}  // namespace feedid::host
