// Named effects as the plant's (named_effects.hpp).
#include "named_effects.hpp"

#include <algorithm>
#include <cmath>

namespace feedid::host {
namespace {

/// Linear interpolation of y(x) on an ascending grid, held at its ends.
double interpolate(const std::vector<double>& x, const std::vector<double>& y, double q) {
  if (q <= x.front()) return y.front();
  if (q >= x.back()) return y.back();
  const auto i = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), q) - x.begin());
  const double w = (q - x[i - 1]) / (x[i] - x[i - 1]);
  return y[i - 1] + w * (y[i] - y[i - 1]);
}

/// A force against the motion, f(t, x, v), for the extra force's sum.
using Drag = std::function<double(double, double, double)>;

/// A position-friction profile per direction (shape "spline"): its
/// profile plus each direction's level, against the motion.
Drag profile_drag(const nlohmann::json& p) {
  const auto& prof = p.at("profile");
  const std::vector<double> x = prof.at("x_m"), pos = prof.at("positive_N"), neg = prof.at("negative_N");
  const double lp = p.at("level_N").at("positive"), ln = p.at("level_N").at("negative");
  return [x, pos, neg, lp, ln](double, double q, double v) {
    if (v > 0) return interpolate(x, pos, q) + lp;
    if (v < 0) return -(interpolate(x, neg, q) + ln);
    return 0.0;
  };
}

/// A thermal drift per direction: (sigma change v + Fc change s) exp(-t / tc),
/// t from the run's start (the replay's clock starts there).
Drag drift_drag(const nlohmann::json& p) {
  const double tc = p.at("time_constant_s");
  const auto side = [&](const char* d, const char* key) { return p.contains(d) ? p.at(d).value(key, 0.0) : p.value(key, 0.0); };
  const double vp = side("positive", "viscous_change_Ns_m"), cp = side("positive", "coulomb_change_N");
  const double vn = side("negative", "viscous_change_Ns_m"), cn = side("negative", "coulomb_change_N");
  return [=](double t, double, double v) {
    const double decay = std::exp(-t / tc);
    return v > 0 ? (vp * v + cp) * decay : (v < 0 ? (vn * v - cn) * decay : 0.0);
  };
}

/// One named effect into the plant: true when it entered (note says how), false with the reason.
bool into_plant(const std::string& kind, const nlohmann::json& p, double mass_kg, Effects& fx, std::vector<Drag>& drags,
                std::string& note) {
  if (kind == effect_name(Effect::offset)) {
    fx.load.offset_N += p.value("force_N", 0.0);
    note = "a constant load force";
  } else if (kind == effect_name(Effect::quadratic_viscous)) {
    fx.quadratic_c2_Ns2_m2 = p.value("c2", 0.0);
    note = "c2 v|v| in the friction";
  } else if (kind == effect_name(Effect::position_ripple)) {
    fx.ripple_amplitude_N = p.value("amplitude_N", 0.0);
    fx.ripple_period_m = p.value("period_m", 1.0);
    fx.ripple_phase_rad = p.value("phase_rad", 0.0);
    note = p.value("harmonics", 1) > 1 ? "its fundamental only (the plant's ripple is one sine)" : "a load force sine in position";
  } else if (kind == effect_name(Effect::position_friction)) {
    if (p.value("shape", std::string()) == "spline" && p.contains("level_N")) {
      drags.push_back(profile_drag(p));
      note = "its profile per direction, interpolated in position";
    } else {
      fx.position_friction_N = p.value("delta_N", 0.0);
      fx.position_friction_x_min_m = p.value("x_min_m", 0.0);
      fx.position_friction_x_max_m = p.value("x_max_m", 0.0);
      note = "friction changed on its range of positions";
    }
  } else if (kind == effect_name(Effect::thermal_drift)) {
    drags.push_back(drift_drag(p));
    note = "friction decaying from the run's start, per direction";
  } else if (kind == effect_name(Effect::presliding_hysteresis)) {
    if (p.contains("elements") || p.value("resets", std::string()) != "at reversals") {
      note = "not simulated: the plant's bristle element is one, reset at reversals only";
      return false;
    }
    fx.presliding_force_N = p.value("force_N", 0.0);
    fx.presliding_distance_m = p.value("distance_m", 1e-5);
    note = "a bristle element reset at reversals";
  } else if (kind == effect_name(Effect::compliance)) {
    const double m2 = p.value("load_mass_kg", 0.0);
    if (!(m2 > 0 && m2 < mass_kg)) {
      note = "not simulated: its load mass is outside (0, m)";
      return false;
    }
    fx.compliance_frequency_hz = p.value("frequency_hz", 0.0);
    fx.compliance_mass_fraction = m2 / mass_kg;
    fx.compliance_damping_ratio = p.value("damping_ratio", 0.05);
    note = "a load mass behind a spring (two-mass plant)";
  } else if (kind == effect_name(Effect::delay)) {
    note = "not simulated: a delay of the logged force is the log's, not the plant's";
    return false;
  } else {
    note = "not simulated: an effect the plant does not know";
    return false;
  }
  return true;
}

}  // namespace

PlantEffects plant_effects(const nlohmann::json& named, double mass_kg) {
  PlantEffects out;
  std::vector<Drag> drags;
  for (const nlohmann::json& e : named) {
    PlantEffect p;
    p.kind = e.value("kind", std::string());
    const nlohmann::json parameters = e.contains("parameters") ? e.at("parameters") : nlohmann::json::object();
    p.simulated = into_plant(p.kind, parameters, mass_kg, out.effects, drags, p.note);
    out.list.push_back(p);
  }
  if (!drags.empty())
    out.extra_force = [drags](double t, double x, double v) {
      double f = 0.0;
      for (const Drag& d : drags) f += d(t, x, v);
      return f;
    };
  return out;
}

}  // namespace feedid::host
