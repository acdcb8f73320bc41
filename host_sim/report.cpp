#include "report.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "svg_plot.hpp"

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

/// Held-out blocks' residual before and after against one block quantity.
bool residual_plot(const DiagnoseResult& r, const std::vector<double>& q, const std::string& xlabel,
                   const std::string& title, const std::string& path, std::string& error) {
  std::vector<double> x, before, after;
  for (std::size_t i = 0; i < q.size(); ++i)
    if (r.block_heldout[i]) {
      x.push_back(q[i]);
      before.push_back(r.block_r_base[i]);
      after.push_back(r.block_r_aug[i]);
    }
  PlotSpec p;
  p.title = title;
  p.x = {xlabel, false};
  p.y = {"force residual, 5 ms block mean (N)", false};
  p.series.push_back(scatter("base model", x, before, "#b0b0b0"));
  if (r.effect != "none" && r.effect != "unexplained")
    p.series.push_back(scatter("with " + r.effect, x, after, "#d62728"));
  p.legend = "top-right";
  p.note = "held-out blocks only";
  return write_svg(path, p, error);
}

}  // namespace

bool write_friction_curve_svg(const IdentifyResult& r, const std::string& path, std::string& error) {
  PlotSpec p;
  p.title = "Friction curve: measured band means and identified model";
  p.x = {"speed |v| (m/s)", true};
  p.y = {"friction magnitude (N)", false};
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
  return write_svg(path, p, error);
}

bool write_diagnosis_report(const DiagnoseResult& r, const std::string& dir, const std::string& source,
                            std::string& error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) { error = dir + ": cannot create: " + ec.message(); return false; }
  if (!write_friction_curve_svg(r.base, dir + "/friction_curve.svg", error)) return false;
  if (!residual_plot(r, r.block_v, "velocity (m/s)", "Held-out residual over velocity", dir + "/residual_velocity.svg", error)) return false;
  if (!residual_plot(r, r.block_x, "position (m)", "Held-out residual over position", dir + "/residual_position.svg", error)) return false;
  if (!residual_plot(r, r.block_t, "time (s)", "Held-out residual over time", dir + "/residual_time.svg", error)) return false;

  std::ostringstream md;
  md << "# Sim-to-real gap diagnosis\n\n";
  md << "Trace: `" << source << "`. Made by `feedid diagnose --in " << source << " --report " << dir << "`.\n\n";
  md << "## Verdict\n\n";
  md << "| | |\n|---|---|\n";
  md << "| effect | **" << r.effect << "** |\n";
  if (r.effect_parameters.is_object())
    for (auto it = r.effect_parameters.begin(); it != r.effect_parameters.end(); ++it)
      md << "| " << it.key() << " | " << it.value().dump() << " |\n";
  char buf[256];
  std::snprintf(buf, sizeof buf, "| held-out RMS, base model | %.4g N |\n| held-out RMS, with the effect | %.4g N |\n"
                "| noise floor | %.4g N |\n| share of the excess gap closed | %.0f %% |\n",
                r.rms_base_N, r.rms_augmented_N, r.noise_floor_N, 100 * r.closed_fraction);
  md << buf << "\n";
  md << "## Where the residual lies\n\nShare of held-out residual energy against share of held-out time.\n\n";
  md << "| domain | range | energy | time |\n|---|---|---|---|\n";
  for (const auto& w : r.where) {
    std::snprintf(buf, sizeof buf, "| %s | %s | %.1f %% | %.1f %% |\n", w.domain.c_str(), w.range.c_str(), 100 * w.share,
                  100 * w.time_share);
    md << buf;
  }
  md << "\n## Candidates\n\nEach fitted with the base model on the identification folds, judged on the held-out folds.\n\n";
  md << "| effect | held-out RMS (N) | closes | z | verdict | parameters |\n|---|---|---|---|---|---|\n";
  for (const auto& c : r.candidates) {
    std::snprintf(buf, sizeof buf, "| %s | %.4g | %.0f %% | %.1f | %s | ", c.kind.c_str(), c.heldout_rms_N,
                  100 * c.closed_fraction, c.z_statistic,
                  c.indistinguishable ? "indistinguishable from base" : c.significant ? "significant" : "not significant");
    md << buf << "`" << c.parameters.dump() << "` |\n";
  }
  for (const auto& c : r.candidates)
    if (!c.note.empty()) md << "\n*" << c.kind << "*: " << c.note << "\n";
  md << "\n## Pictures\n\n";
  md << "![friction curve](friction_curve.svg)\n\n![residual over velocity](residual_velocity.svg)\n\n"
        "![residual over position](residual_position.svg)\n\n![residual over time](residual_time.svg)\n\n";
  md << "## Base model (identification folds)\n\n```\n" << summary(r.base) << "```\n";
  std::ofstream f(dir + "/report.md");
  if (!f) { error = dir + "/report.md: cannot write"; return false; }
  f << md.str();
  return static_cast<bool>(f);
}

bool write_force_plot_svg(const ValidateResult& r, const std::string& path, const std::string& title,
                          std::string& error) {
  PlotSpec p;
  p.title = title;
  p.x = {"time (s)", false};
  p.y = {"force (N)", false};
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
  std::snprintf(buf, sizeof buf, "relative error %.3f %% (decimated by the protocol), RMS %.3g N", r.relative_error_pct, r.rms_error_N);
  p.note = buf;
  return write_svg(path, p, error);
}

}  // namespace feedid::host
