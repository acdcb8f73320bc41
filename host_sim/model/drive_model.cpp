// The drive model's parameters, F(v) and their JSON form (drive_model.hpp).
#include "drive_model.hpp"

#include <algorithm>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <utility>

namespace feedid::host {

double ModelLoad::at(double x) const {
  return gravity_N != 0.0 ? offset_N + gravity_N * std::cos(x - gravity_angle0_rad) : offset_N;
}

std::string ModelLoad::refusal(const std::string& source, bool has_position) const {
  if (has_position || !depends_on_position()) return {};
  return source + ": the model carries an arm's weight, G cos(q - q0), and the log has no position to place it: "
                  "give the position column";
}

void put_load(nlohmann::json& model, const ModelLoad& load) {
  model["offset_N"] = load.offset_N;
  if (load.gravity_N != 0.0)
    model["gravity"] = {{"form", "angle"}, {"G", load.gravity_N}, {"angle0_rad", load.gravity_angle0_rad}};
}

double sliding_friction(const DirectionFriction& f, double direction, double v_m_s) {
  const double r = v_m_s / f.stribeck_velocity_m_s;
  // The block observations call this per sample, most of them far above
  // vs, where exp is all but 0. Beyond r^2 = 40, exp(-r^2) < 4.3e-18, so
  // for Fs <= 13 |Fc| the dip is below half a unit in the last place of Fc
  // (at least 2^-54 |Fc|) and Fc + dip rounds to Fc: skipping exp changes
  // no bit. Beyond r^2 = 750, exp(-r^2) is exactly 0 in double.
  const bool below_rounding = r * r > 40.0 && f.breakaway_N <= 13.0 * std::fabs(f.coulomb_N);
  // A break-away that is not finite still spoils the force, as the formula's product does.
  const double dip = f.breakaway_N * (below_rounding || r * r > 750.0 ? 0.0 : std::exp(-r * r));
  return direction * (f.coulomb_N + dip) + f.viscous_Ns_m * v_m_s;
}

double stribeck_friction(const DriveParams& p, double v_m_s) {
  if (v_m_s > 0.0) return sliding_friction(p.pos, 1.0, v_m_s);
  if (v_m_s < 0.0) return sliding_friction(p.neg, -1.0, v_m_s);
  return 0.0;
}

feedid::Estimate<double> to_estimate(const DriveParams& p) {
  feedid::Estimate<double> e;
  e.mass_kg = p.mass_kg;
  auto dir = [](const DirectionFriction& f) {
    feedid::DirectionEstimate<double> d;
    d.viscous_Ns_m = f.viscous_Ns_m;
    d.coulomb_N = f.coulomb_N;
    d.breakaway_N = f.breakaway_N;
    d.stribeck_velocity_m_s = f.stribeck_velocity_m_s;
    return d;
  };
  e.pos = dir(p.pos);
  e.neg = dir(p.neg);
  return e;
}

DriveParams to_drive_params(const feedid::Estimate<double>& e) {
  DriveParams p;
  p.mass_kg = e.mass_kg;
  auto dir = [](const feedid::DirectionEstimate<double>& d) {
    // No Stribeck velocity identified: the model has no dip, so Fs is 0 (vs
    // is then irrelevant; 1 m/s keeps F(v) defined). It used to keep Fs with
    // vs = 1e-9, a dip nobody could see, silently.
    if (!(d.stribeck_velocity_m_s > 0)) return DirectionFriction{d.viscous_Ns_m, d.coulomb_N, 0.0, 1.0};
    return DirectionFriction{d.viscous_Ns_m, d.coulomb_N, d.breakaway_N, d.stribeck_velocity_m_s};
  };
  p.pos = dir(e.pos);
  p.neg = dir(e.neg);
  return p;
}

std::string non_physical_parameters(const DriveParams& p, const Units& units) {
  std::string out;
  auto check = [&](bool physical, const std::string& name, double value, const std::string& unit) {
    if (physical) return;
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s%s = %.4g %s", out.empty() ? "" : ", ", name.c_str(), value, unit.c_str());
    out += buf;
  };
  check(p.mass_kg > 0.0, "m", p.mass_kg, units.mass());
  for (int d = 0; d < 2; ++d) {
    const DirectionFriction& f = d == 0 ? p.pos : p.neg;
    const std::string s = d == 0 ? "+" : "-";
    check(f.coulomb_N >= 0.0, "Fc" + s, f.coulomb_N, units.force);
    check(f.viscous_Ns_m >= 0.0, "sigma" + s, f.viscous_Ns_m, units.viscous());
  }
  return out;
}

std::vector<std::string> implausible_parameters(const DriveParams& p, const Units& units, double top_speed) {
  std::vector<std::string> out;
  const bool linear = units.linear_si(), rotary = units.force == "N m" && units.position == "rad";
  if (!(linear || rotary)) return out;
  const double m_lo = linear ? 0.01 : 1e-8, m_hi = linear ? 1e5 : 1e4, v_hi = linear ? 20.0 : 2000.0;
  const double m = p.mass_kg, fc = std::max(std::fabs(p.pos.coulomb_N), std::fabs(p.neg.coulomb_N));
  char buf[320];
  if (m > 0 && (m < m_lo || m > m_hi)) {
    std::snprintf(buf, sizeof buf, "a %s of %.3g %s is implausible for a feed drive (%.0e to %.0e): a position in "
                  "counts (--position-scale, m or rad per count) or a force in amps (--force-scale, N per A) left unscaled?",
                  linear ? "mass" : "inertia", m, units.mass().c_str(), m_lo, m_hi);
    out.push_back(buf);
  }
  if (top_speed > v_hi) {
    std::snprintf(buf, sizeof buf, "a top speed of %.3g %s is implausible for a feed drive: a position in counts or "
                  "in mm or um (--position-scale) left unscaled?", top_speed, units.velocity().c_str());
    out.push_back(buf);
  }
  if (fc > 1e6) {
    std::snprintf(buf, sizeof buf, "a Coulomb force of %.3g %s is implausible for a feed drive: a force in another "
                  "unit (--force-scale, or --force-unit to label it) left unscaled?", fc, units.force.c_str());
    out.push_back(buf);
  }
  return out;
}

double predict_force(const DriveParams& p, double v_m_s, double a_m_s2) {
  return p.mass_kg * a_m_s2 + stribeck_friction(p, v_m_s);
}

std::vector<std::string> flag_names(uint32_t flags) {
  static const std::pair<uint32_t, const char*> names[] = {
      {feedid::flag_no_data, "no_data"},
      {feedid::flag_stribeck_below_resolution, "stribeck_below_resolution"},
      {feedid::flag_stribeck_at_search_bound, "stribeck_at_search_bound"},
      {feedid::flag_stribeck_uncertain, "stribeck_uncertain"},
      {feedid::flag_no_low_speed_data, "no_low_speed_data"},
      {feedid::flag_no_acceleration, "no_acceleration"},
      {feedid::flag_not_physical, "not_physical"},
      {feedid::flag_fit_failed, "fit_failed"},
      {feedid::flag_coulomb_uncertain, "coulomb_uncertain"},
      {feedid::flag_viscous_uncertain, "viscous_uncertain"},
      {feedid::flag_friction_still_falling, "friction_still_falling"},
  };
  std::vector<std::string> out;
  for (const auto& [bit, name] : names)
    if (flags & bit) out.emplace_back(name);
  return out;
}

nlohmann::json model_json(const DriveParams& p, const Units& units) {
  auto dir = [](const DirectionFriction& d) {
    return nlohmann::json{{"sigma", d.viscous_Ns_m}, {"fc", d.coulomb_N}, {"fs", d.breakaway_N}, {"vs", d.stribeck_velocity_m_s}};
  };
  return {{"m", p.mass_kg}, {"pos", dir(p.pos)}, {"neg", dir(p.neg)}, {"units", units_json(units)}};
}

Outcome<nlohmann::json> read_json_file(const std::string& path) {
  std::ifstream f(path);
  if (!f) return refused<nlohmann::json>(path + ": cannot open");
  try {  // nlohmann reports a broken file (line, column) only by its exception
    return {nlohmann::json::parse(f), ""};
  } catch (const nlohmann::json::exception& e) {
    return refused<nlohmann::json>(path + ": not valid JSON: " + e.what());
  }
}

}  // namespace feedid::host
