// Named effects as the plant's (named_effects.hpp).
#include "named_effects.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "model/constants.hpp"

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

/// An effect's parameters as the plant reads them: a value present must be
/// of the type and range the plant needs, or `error` names the first that
/// is not (a model file is the user's: a wrong value is an input error,
/// never an exception or a NaN in the figures).
struct Parameters {
  const nlohmann::json& p;
  std::string error;

  bool fail(const std::string& why) {
    if (error.empty()) error = why;
    return false;
  }
  static bool finite_number(const nlohmann::json& v) { return v.is_number() && std::isfinite(v.get<double>()); }
  /// o[key], or `fallback` where absent.
  double number_in(const nlohmann::json& o, const std::string& where, const char* key, double fallback) {
    if (!o.is_object() || !o.contains(key)) return fallback;
    if (finite_number(o.at(key))) return o.at(key).get<double>();
    fail("'" + where + key + "' must be a finite number");
    return fallback;
  }
  double number(const char* key, double fallback) { return number_in(p, "", key, fallback); }
  /// p[key], which the effect cannot do without (its size, where it acts):
  /// a file without it is refused, not replayed as if the effect were nil.
  double required(const char* key) {
    if (!p.is_object() || !p.contains(key)) fail(std::string("'") + key + "' is missing");
    return number(key, 0.0);
  }
  double required_positive(const char* key) {
    const double x = required(key);
    if (p.contains(key) && !(x > 0.0)) fail(std::string("'") + key + "' must be > 0");
    return x;
  }
  std::string text(const char* key) {
    if (!p.contains(key)) return "";
    if (p.at(key).is_string()) return p.at(key).get<std::string>();
    fail(std::string("'") + key + "' must be a string");
    return "";
  }
  /// o[key] as a list of finite numbers (empty, with the error, otherwise).
  std::vector<double> numbers_in(const nlohmann::json& o, const std::string& where, const char* key) {
    std::vector<double> out;
    if (!o.is_object() || !o.contains(key) || !o.at(key).is_array()) {
      fail("'" + where + key + "' must be a list of numbers");
      return out;
    }
    for (const nlohmann::json& v : o.at(key)) {
      if (!finite_number(v)) {
        fail("'" + where + key + "' must hold finite numbers only");
        return {};
      }
      out.push_back(v.get<double>());
    }
    return out;
  }
};

/// A position-friction profile per direction (shape "spline"): its
/// profile plus each direction's level, against the motion; its knots'
/// shortest spacing into `scales`. Empty (with the reason in `in`) where
/// the profile cannot be interpolated.
Drag profile_drag(Parameters& in, ExtraForceScales& scales) {
  const nlohmann::json none = nlohmann::json::object();
  const nlohmann::json& prof = in.p.contains("profile") ? in.p.at("profile") : none;
  const std::vector<double> x = in.numbers_in(prof, "profile.", "x_m"), pos = in.numbers_in(prof, "profile.", "positive_N"),
                            neg = in.numbers_in(prof, "profile.", "negative_N");
  if (!in.p.at("level_N").is_object()) in.fail("'level_N' must be an object {\"positive\", \"negative\"}");
  const double lp = in.number_in(in.p.at("level_N"), "level_N.", "positive", 0.0);
  const double ln = in.number_in(in.p.at("level_N"), "level_N.", "negative", 0.0);
  if (x.empty() || pos.size() != x.size() || neg.size() != x.size())
    in.fail("'profile' needs x_m, positive_N and negative_N of one length, at least one point");
  for (std::size_t i = 1; i < x.size(); ++i)
    if (!(x[i] > x[i - 1])) in.fail("'profile.x_m' must increase");
  if (!in.error.empty()) return {};
  for (std::size_t i = 1; i < x.size(); ++i) scales.length_m = std::min(scales.length_m, x[i] - x[i - 1]);
  return [x, pos, neg, lp, ln](double, double q, double v) {
    if (v > 0) return interpolate(x, pos, q) + lp;
    if (v < 0) return -(interpolate(x, neg, q) + ln);
    return 0.0;
  };
}

/// A thermal drift per direction: (sigma change v + Fc change s) exp(-t / tc),
/// t from the run's start (the replay's clock starts there); its slope in
/// velocity and time constant into `scales`.
Drag drift_drag(Parameters& in, ExtraForceScales& scales) {
  const double tc = in.required_positive("time_constant_s");
  bool any_change = false;
  const auto side = [&](const char* d, const char* key) {
    const nlohmann::json& o = in.p.contains(d) ? in.p.at(d) : in.p;
    any_change = any_change || (o.is_object() && o.contains(key));
    return in.number_in(o, in.p.contains(d) ? std::string(d) + "." : std::string(), key, 0.0);
  };
  const double vp = side("positive", "viscous_change_Ns_m"), cp = side("positive", "coulomb_change_N");
  const double vn = side("negative", "viscous_change_Ns_m"), cn = side("negative", "coulomb_change_N");
  if (!any_change) in.fail("'viscous_change_Ns_m' and 'coulomb_change_N' are missing (shared, or under 'positive' and 'negative')");
  if (!in.error.empty()) return {};
  scales.viscous_Ns_m += std::max(std::fabs(vp), std::fabs(vn));
  scales.time_s = std::min(scales.time_s, tc);
  return [=](double t, double, double v) {
    const double decay = std::exp(-t / tc);
    return v > 0 ? (vp * v + cp) * decay : (v < 0 ? (vn * v - cn) * decay : 0.0);
  };
}

/// A ripple's harmonics above the fundamental (the plant's own ripple is
/// one sine): the load sum over h >= 2 of A_h sin(2 pi h x / P + phase_h),
/// from harmonic_amplitudes_N and harmonic_phases_rad; each harmonic's
/// period / 2 pi and stiffness 2 pi h A_h / P into `scales`. Empty where
/// the file gives no phases (written before they were reported).
/// Harmonics a model file's ripple may have (diagnose reports up to 3).
constexpr int kMaxRippleHarmonics = 64;

Drag ripple_harmonics_drag(Parameters& in, double period_m, double harmonics, ExtraForceScales& scales) {
  if (!in.p.contains("harmonic_phases_rad")) return {};
  const std::vector<double> amp = in.numbers_in(in.p, "", "harmonic_amplitudes_N"),
                            phase = in.numbers_in(in.p, "", "harmonic_phases_rad");
  if (amp.size() != phase.size() || amp.empty())
    in.fail("'harmonic_amplitudes_N' and 'harmonic_phases_rad' must be lists of one length");
  else if (static_cast<double>(amp.size()) != harmonics)
    in.fail("'harmonics' is " + std::to_string(static_cast<long long>(harmonics)) + " but the lists give " + std::to_string(amp.size()) +
            " (diagnose writes one amplitude and phase per harmonic, the fundamental first)");
  if (!in.error.empty() || amp.size() < 2) return {};
  const double k = 2.0 * kPi / period_m;
  for (std::size_t h = 1; h < amp.size(); ++h) {
    const double kh = k * static_cast<double>(h + 1);
    scales.length_m = std::min(scales.length_m, 1.0 / kh);
    scales.stiffness_N_m += kh * std::fabs(amp[h]);
  }
  return [amp, phase, k](double, double x, double) {
    double f = 0.0;
    for (std::size_t h = 1; h < amp.size(); ++h) f += amp[h] * std::sin(k * static_cast<double>(h + 1) * x + phase[h]);
    return f;
  };
}

/// The plant has one ripple: its harmonics' drag and their scales, held
/// apart from the other drags so that a later ripple replaces an earlier
/// one whole (its steps included).
struct RippleSlot {
  Drag harmonics;
  ExtraForceScales scales;
};

/// The plant's effects and the extra force's drags, with their scales.
struct Into {
  Effects& fx;
  std::vector<Drag>& drags;
  ExtraForceScales& scales;
  RippleSlot& ripple;
};

/// One named effect into the plant: true when it entered (note says how), false with the reason.
bool into_plant(const std::string& kind, Parameters& in, double mass_kg, Into out, std::string& note) {
  Effects& fx = out.fx;
  if (kind == effect_name(Effect::offset)) {
    fx.load.offset_N += in.required("force_N");
    note = "a constant load force";
  } else if (kind == effect_name(Effect::quadratic_viscous)) {
    fx.quadratic_c2_Ns2_m2 = in.required("c2");
    note = "c2 v|v| in the friction";
  } else if (kind == effect_name(Effect::position_ripple)) {
    fx.ripple_amplitude_N = in.required("amplitude_N");
    fx.ripple_period_m = in.required_positive("period_m");
    fx.ripple_phase_rad = in.required("phase_rad");
    note = "a load force sine in position";
    out.ripple = RippleSlot{};
    const double count = in.number("harmonics", 1.0);
    if (!(count >= 1.0 && count <= kMaxRippleHarmonics && count == std::floor(count)))
      in.fail("'harmonics' must be a whole number from 1 to " + std::to_string(kMaxRippleHarmonics));
    if (in.error.empty() && (count > 1.0 || in.p.contains("harmonic_amplitudes_N"))) {
      out.ripple.harmonics = ripple_harmonics_drag(in, fx.ripple_period_m, count, out.ripple.scales);
      if (count > 1.0)
        note = out.ripple.harmonics ? "a load force sine in position, with its harmonics"
                                    : "its fundamental only (the file gives no harmonic_phases_rad)";
    }
  } else if (kind == effect_name(Effect::position_friction)) {
    if (in.text("shape") == "spline" && in.p.contains("level_N")) {
      if (Drag d = profile_drag(in, out.scales)) out.drags.push_back(std::move(d));
      note = "its profile per direction, interpolated in position";
    } else {
      fx.position_friction_N = in.required("delta_N");
      fx.position_friction_x_min_m = in.required("x_min_m");
      fx.position_friction_x_max_m = in.required("x_max_m");
      if (in.error.empty() && !(fx.position_friction_x_max_m > fx.position_friction_x_min_m))
        in.fail("'x_max_m' must be above 'x_min_m' (a range of positions)");
      note = "friction changed on its range of positions";
    }
  } else if (kind == effect_name(Effect::thermal_drift)) {
    if (Drag d = drift_drag(in, out.scales)) out.drags.push_back(std::move(d));
    note = "friction decaying from the run's start, per direction";
  } else if (kind == effect_name(Effect::presliding_hysteresis)) {
    // "resets" absent is the plant's own kind (a hand-written file); what
    // diagnose names with several elements, or reset from rest too, is not.
    if (in.p.contains("elements") || (in.p.contains("resets") && in.text("resets") != "at reversals")) {
      note = "not simulated: the plant's bristle element is one, reset at reversals only";
      return false;
    }
    fx.presliding_force_N = in.required("force_N");
    fx.presliding_distance_m = in.required_positive("distance_m");
    note = "a bristle element reset at reversals";
  } else if (kind == effect_name(Effect::compliance)) {
    const double m2 = in.required("load_mass_kg");
    if (!in.error.empty()) return false;
    if (!(m2 > 0 && m2 < mass_kg)) {
      note = "not simulated: its load mass is outside (0, m)";
      return false;
    }
    fx.compliance_frequency_hz = in.required_positive("frequency_hz");
    fx.compliance_mass_fraction = m2 / mass_kg;
    fx.compliance_damping_ratio = in.number("damping_ratio", 0.05);
    if (fx.compliance_damping_ratio < 0.0) in.fail("'damping_ratio' must be >= 0");
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
  RippleSlot ripple;
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::size_t ripple_entry = kNone;
  for (const nlohmann::json& e : named) {
    PlantEffect p;
    p.kind = e.value("kind", std::string());
    const nlohmann::json parameters = e.contains("parameters") ? e.at("parameters") : nlohmann::json::object();
    Parameters in{parameters, ""};
    if (!parameters.is_object()) in.fail("its parameters must be an object");
    p.simulated = in.error.empty() &&
                  into_plant(p.kind, in, mass_kg, {out.effects, drags, out.extra_scales, ripple}, p.note);
    if (p.simulated && p.kind == effect_name(Effect::position_ripple)) {
      if (ripple_entry != kNone) {
        out.list[ripple_entry].simulated = false;
        out.list[ripple_entry].note = "not simulated: replaced by a later position_ripple (the plant has one ripple)";
      }
      ripple_entry = out.list.size();
    }
    if (!in.error.empty() && out.error.empty()) out.error = "effect \"" + p.kind + "\": " + in.error;
    out.list.push_back(p);
  }
  if (ripple.harmonics) {
    drags.push_back(std::move(ripple.harmonics));
    ExtraForceScales& sc = out.extra_scales;
    sc.length_m = std::min(sc.length_m, ripple.scales.length_m);
    sc.stiffness_N_m += ripple.scales.stiffness_N_m;
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
