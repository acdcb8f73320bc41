// Friction compensation tables from an identified model. Host only.
#include "compensate.hpp"
#include "io/output_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "feedid/feedforward.hpp"
#include "identify/identify.hpp"
#include "model/model_file.hpp"

namespace feedid::host {
namespace {

/// Largest |chord - curve| on [a, b], sampled finely enough for the
/// Stribeck dip (the chord is exact at both ends).
double chord_error(const DriveParams& m, int dir, double a, double b) {
  constexpr int kSamples = 64;
  const double fa = model_friction(m, dir, a), fb = model_friction(m, dir, b);
  double worst = 0.0;
  for (int i = 1; i < kSamples; ++i) {
    const double s = a + (b - a) * i / kSamples;
    const double chord = fa + (fb - fa) * (s - a) / (b - a);
    worst = std::max(worst, std::fabs(chord - model_friction(m, dir, s)));
  }
  return worst;
}

/// Breakpoints from 0 to top, each segment reaching as far as its chord
/// stays within eps; empty if more than `segments` segments are needed.
std::vector<double> greedy_breakpoints(const DriveParams& m, int dir, double top, double eps, int segments) {
  std::vector<double> b{0.0};
  while (b.back() < top) {
    if (static_cast<int>(b.size()) > segments) return {};
    const double a = b.back();
    double lo = a, hi = top;
    if (chord_error(m, dir, a, top) <= eps) {
      lo = top;
    } else {
      for (int it = 0; it < 50; ++it) {  // reach of the chord from a: bisection on its end
        const double mid = 0.5 * (lo + hi);
        (chord_error(m, dir, a, mid) <= eps ? lo : hi) = mid;
      }
    }
    if (lo <= a) return {};  // eps below what any segment can hold
    b.push_back(lo);
  }
  return static_cast<int>(b.size()) - 1 <= segments ? b : std::vector<double>{};
}

/// Splits segments of `b` at their middles, the one whose chord strays most
/// first (the widest where none strays: a straight Coulomb + viscous line),
/// until it has `points` breakpoints: a drive's table takes the count it
/// was given, and fewer points (2 for a straight line) read as a failure.
void fill_to_count(const DriveParams& m, int dir, int points, std::vector<double>& b) {
  while (b.size() >= 2 && static_cast<int>(b.size()) < points) {
    std::size_t split = 0;
    double worst = -1.0, widest = -1.0;
    for (std::size_t i = 0; i + 1 < b.size(); ++i) {
      const double e = chord_error(m, dir, b[i], b[i + 1]), w = b[i + 1] - b[i];
      if (e > worst || (e == worst && w > widest)) { worst = e; widest = w; split = i; }
    }
    b.insert(b.begin() + static_cast<std::ptrdiff_t>(split) + 1, 0.5 * (b[split] + b[split + 1]));
  }
}

std::vector<TablePoint> minimax_table(const DriveParams& m, int dir, double top, int points) {
  // The error of the straight line over the whole range is an upper bound.
  double lo = 0.0, hi = chord_error(m, dir, 0.0, top) + 1e-12;
  std::vector<double> best = greedy_breakpoints(m, dir, top, hi, points - 1);
  for (int it = 0; it < 60 && !best.empty(); ++it) {
    const double eps = 0.5 * (lo + hi);
    std::vector<double> b = greedy_breakpoints(m, dir, top, eps, points - 1);
    if (b.empty()) {
      lo = eps;
    } else {
      hi = eps;
      best = std::move(b);
    }
  }
  fill_to_count(m, dir, points, best);
  std::vector<TablePoint> t;
  for (double s : best) t.push_back({s, model_friction(m, dir, s)});
  return t;
}

double scaled(double force_N, const CompensateOptions& o) { return force_N / o.force_scale; }

}  // namespace

double model_friction(const DriveParams& m, int dir, double speed_m_s) {
  const feedid::Estimate<double> e = to_estimate(m);
  return feedid::friction_magnitude(dir == 0 ? e.pos : e.neg, speed_m_s);
}

CompensationTable make_compensation_table(const DriveParams& model, double max_speed_m_s, int points) {
  CompensationTable t;
  if (points < 2 || points > kMaxTablePoints)
    t.error = "--points " + std::to_string(points) + ": a table has 2 to " + std::to_string(kMaxTablePoints) + " points";
  else if (!(max_speed_m_s > 0) || !std::isfinite(max_speed_m_s))
    t.error = "max speed " + std::to_string(max_speed_m_s) + " m/s: must be positive (--max-speed)";
  if (!t.error.empty()) return t;
  t.model = model;
  t.max_speed_m_s = max_speed_m_s;
  for (int d = 0; d < 2; ++d) t.dir[d] = minimax_table(model, d, max_speed_m_s, points);
  t.max_interpolation_error_N = std::max(table_error(t, 0), table_error(t, 1));
  return t;
}

double table_error(const CompensationTable& t, int dir, int n) {
  feedid::FrictionTable<double, kMaxTablePoints> ft;
  const auto& pts = t.dir[dir];
  ft.count[dir] = static_cast<int>(pts.size());  // <= kMaxTablePoints (make_compensation_table)
  for (int k = 0; k < ft.count[dir]; ++k) {
    ft.speed_m_s[dir][k] = pts[k].speed_m_s;
    ft.force_N[dir][k] = pts[k].force_N;
  }
  double worst = 0.0;
  for (int i = 0; i <= n; ++i) {
    const double s = t.max_speed_m_s * i / n;
    worst = std::max(worst, std::fabs(ft.magnitude(dir, s) - model_friction(t.model, dir, s)));
  }
  return worst;
}

nlohmann::json to_json(const CompensationTable& t, const CompensateOptions& opt) {
  const bool drive_units = opt.force_scale != 1.0 || !opt.force_unit.empty();
  const std::string unit = opt.force_unit.empty() ? "N" : opt.force_unit;
  nlohmann::json j;
  for (int d = 0; d < 2; ++d) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& p : t.dir[d]) {
      nlohmann::json e = {{"speed_m_s", p.speed_m_s}, {"force_N", p.force_N}};
      if (drive_units) e["force"] = scaled(p.force_N, opt);
      list.push_back(e);
    }
    j[d == 0 ? "pos" : "neg"] = list;
  }
  j["max_interpolation_error_N"] = t.max_interpolation_error_N;
  j["max_speed_m_s"] = t.max_speed_m_s;
  j["points"] = t.dir[0].size();
  j["rule"] = "per direction, the breakpoints whose largest linear-interpolation error against the model is least "
              "(minimax); magnitudes are positive: the drive adds +force moving positive, -force moving negative; "
              "beyond the last point the last segment continues";
  const auto& m = t.model;
  j["parameter_form"] = {
      {"offset_pos_N", m.pos.coulomb_N},
      {"offset_neg_N", -m.neg.coulomb_N},
      {"viscous_pos_Ns_m", m.pos.viscous_Ns_m},
      {"viscous_neg_Ns_m", m.neg.viscous_Ns_m},
      {"convention", "u_ff = offset_pos + viscous_pos * v while v > 0, offset_neg + viscous_neg * v while v < 0 "
                     "(offset_neg is negative); the Stribeck rise below twice vs is not in this form"}};
  if (drive_units) {
    j["force_unit"] = unit;
    j["force_scale_N_per_unit"] = opt.force_scale;
    j["parameter_form"]["offset_pos"] = scaled(m.pos.coulomb_N, opt);
    j["parameter_form"]["offset_neg"] = scaled(-m.neg.coulomb_N, opt);
    j["parameter_form"]["viscous_pos_per_m_s"] = scaled(m.pos.viscous_Ns_m, opt);
    j["parameter_form"]["viscous_neg_per_m_s"] = scaled(m.neg.viscous_Ns_m, opt);
  }
  return j;
}

std::string to_csv(const CompensationTable& t, const CompensateOptions& opt, const Units& units) {
  const bool drive_units = opt.force_scale != 1.0 || !opt.force_unit.empty();
  const std::string unit = opt.force_unit.empty() ? "unit" : opt.force_unit;
  std::ostringstream o;
  o.precision(10);
  // The header names the model's units, as the JSON's keys do (a SysId
  // model's table is in rad/s and V, not m/s and N).
  o << "direction," << key_in_units("speed_m_s", units) << "," << key_in_units("force_N", units)
    << (drive_units ? ",force_" + unit : "") << "\n";
  for (int d = 0; d < 2; ++d)
    for (const auto& p : t.dir[d]) {
      o << (d == 0 ? "pos" : "neg") << "," << p.speed_m_s << "," << p.force_N;
      if (drive_units) o << "," << scaled(p.force_N, opt);
      o << "\n";
    }
  return o.str();
}

std::string unusable_model(const nlohmann::json& mj) {
  // The one model reader's rules (model/model_file.hpp): identify did not
  // solve it, a key is missing, or it is not physical (it would push with the motion).
  const ModelFile file = model_file_from_json(mj, "model");
  return file.error.empty() ? "" : file.error + ": no compensation written";
}

namespace {
/// Where --max-speed takes the table beyond what the model was identified
/// on, or ends it inside the Stribeck dip (beyond its last point the drive
/// continues the last segment, at a slope the model does not have there).
std::vector<std::string> table_range_warnings(const nlohmann::json& mj, const DriveParams& m, double max_speed,
                                              const std::string& top_speed_key, const Units& u) {
  std::vector<std::string> out;
  char buf[320];
  const std::string speed = u.velocity();
  if (mj.contains("config") && mj["config"].contains(top_speed_key) && mj["config"][top_speed_key].is_number()) {
    const double identified = mj["config"][top_speed_key].get<double>();
    if (identified > 0.0 && max_speed > 1.5 * identified) {
      std::snprintf(buf, sizeof buf, "--max-speed %.4g %s is %.3g times the fastest speed the model was identified at "
                    "(config.%s %.4g %s): the table above that extrapolates the model", max_speed, speed.c_str(),
                    max_speed / identified, top_speed_key.c_str(), identified, speed.c_str());
      out.push_back(buf);
    }
  }
  for (const auto* d : {&m.pos, &m.neg}) {
    if (!(d->breakaway_N > 0.0) || !(max_speed < 2.0 * d->stribeck_velocity_m_s)) continue;
    std::snprintf(buf, sizeof buf, "--max-speed %.4g %s ends the table inside the Stribeck dip (%s vs %.4g %s): beyond "
                  "it the last segment continues at a slope the model does not have", max_speed, speed.c_str(),
                  d == &m.pos ? "pos" : "neg", d->stribeck_velocity_m_s, speed.c_str());
    out.push_back(buf);
    break;
  }
  return out;
}
}  // namespace

ModelCompensation compensate_model(const nlohmann::json& mj, CompensateOptions opt, const std::string& source) {
  ModelCompensation c;
  const ModelFile file = model_file_from_json(mj, source);
  if (!file.error.empty()) {
    c.error = file.error + ": no compensation written";  // the reader's error names the source
    return c;
  }
  // identify names the key in the model's units (velocity_max_rad_s on a rotary axis)
  const std::string top_speed = key_in_units("velocity_max_m_s", stated_units(mj));
  if (opt.max_speed_m_s <= 0 && mj.contains("config") && mj["config"].contains(top_speed))
    opt.max_speed_m_s = mj["config"][top_speed].get<double>();
  // The table's forces are magnitudes the drive adds along the motion: a
  // negative scale made them negative, and loaded so they doubled the
  // friction instead of cancelling it (exit 0, no word).
  if (!(opt.force_scale > 0.0) || !std::isfinite(opt.force_scale)) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "--force-scale %g: must be finite and > 0 (N per drive unit; the table's forces are "
                  "magnitudes, and a drive whose command has the other sign takes them negated)", opt.force_scale);
    c.error = buf;
    return c;
  }
  // --force-scale converts N to a drive unit: a model identified in that
  // unit already (identify --force-unit A) was divided by it a second time,
  // 12.5 times too small, beside a force_A key holding the right values.
  const Units units = stated_units(mj);
  const bool si_force = units.force == "N" || units.force == "N m";  // a linear or a rotary axis's
  if (!si_force && (opt.force_scale != 1.0 || (!opt.force_unit.empty() && opt.force_unit != units.force))) {
    c.error = source + " is in " + units.force + " already (units.force): its table is in " + units.force +
              "; --force-scale and --force-unit convert a model in N (or N m) to a drive unit";
    return c;
  }
  if (opt.max_speed_m_s <= 0) {
    c.error = source + " states no top speed (config." + top_speed + ", which identify writes; a model written by hand "
              "or by diagnose --model-out has none): give --max-speed";
    return c;
  }
  c.table = make_compensation_table(file.drive, opt.max_speed_m_s, opt.points);
  c.error = c.table.error;
  if (!c.error.empty()) return c;
  c.warnings = file.warnings;
  c.units = units;
  if (si_force && !opt.force_unit.empty() && opt.force_scale == 1.0)
    c.warnings.push_back("--force-unit " + opt.force_unit + " without --force-scale: the force_" + opt.force_unit +
                         " values are the " + units.force + " values (1 " + units.force + " per " + opt.force_unit + ")");
  for (const std::string& w : table_range_warnings(mj, file.drive, opt.max_speed_m_s, top_speed, units))
    c.warnings.push_back(source + ": " + w);
  if (file.load.any())
    c.warnings.push_back(source + ": the model's load (a constant force or an arm's weight) is not friction and is not "
                         "in the table: feed it forward on its own");
  if (!file.effects.empty())
    c.warnings.push_back(source + ": the model's " + std::to_string(file.effects.size()) + " effect(s) (diagnose "
                         "--model-out) are not in the table, which holds the friction F(v) alone");
  c.json = to_json(c.table, opt);
  if (mj.contains("units")) c.json["units"] = mj["units"];  // the table's speeds and forces are in these (its keys are named in them)
  c.force_negated = mj.contains("input") && mj["input"].value("force_sign", 1) < 0;
  return c;
}

}  // namespace feedid::host
