// The gap of a given model on a new run (model_gap.hpp).
#include "model_gap.hpp"

#include "diagnose/diagnose_fit.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <stdexcept>

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
bool into_plant(const NamedEffect& e, double mass_kg, Effects& fx, std::vector<Drag>& drags, std::string& note) {
  const nlohmann::json& p = e.parameters;
  if (e.kind == effect_name(Effect::offset)) {
    fx.offset_N += p.value("force_N", 0.0);
    note = "a constant load force";
  } else if (e.kind == effect_name(Effect::quadratic_viscous)) {
    fx.quadratic_c2_Ns2_m2 = p.value("c2", 0.0);
    note = "c2 v|v| in the friction";
  } else if (e.kind == effect_name(Effect::position_ripple)) {
    fx.ripple_amplitude_N = p.value("amplitude_N", 0.0);
    fx.ripple_period_m = p.value("period_m", 1.0);
    fx.ripple_phase_rad = p.value("phase_rad", 0.0);
    note = p.value("harmonics", 1) > 1 ? "its fundamental only (the plant's ripple is one sine)" : "a load force sine in position";
  } else if (e.kind == effect_name(Effect::position_friction)) {
    if (p.value("shape", std::string()) == "spline" && p.contains("level_N")) {
      drags.push_back(profile_drag(p));
      note = "its profile per direction, interpolated in position";
    } else {
      fx.position_friction_N = p.value("delta_N", 0.0);
      fx.position_friction_x_min_m = p.value("x_min_m", 0.0);
      fx.position_friction_x_max_m = p.value("x_max_m", 0.0);
      note = "friction changed on its range of positions";
    }
  } else if (e.kind == effect_name(Effect::thermal_drift)) {
    drags.push_back(drift_drag(p));
    note = "friction decaying from the run's start, per direction";
  } else if (e.kind == effect_name(Effect::presliding_hysteresis)) {
    if (p.contains("elements") || p.value("resets", std::string()) != "at reversals") {
      note = "not simulated: the plant's bristle element is one, reset at reversals only";
      return false;
    }
    fx.presliding_force_N = p.value("force_N", 0.0);
    fx.presliding_distance_m = p.value("distance_m", 1e-5);
    note = "a bristle element reset at reversals";
  } else if (e.kind == effect_name(Effect::compliance)) {
    const double m2 = p.value("load_mass_kg", 0.0);
    if (!(m2 > 0 && m2 < mass_kg)) {
      note = "not simulated: its load mass is outside (0, m)";
      return false;
    }
    fx.compliance_frequency_hz = p.value("frequency_hz", 0.0);
    fx.compliance_mass_fraction = m2 / mass_kg;
    fx.compliance_damping_ratio = p.value("damping_ratio", 0.05);
    note = "a load mass behind a spring (two-mass plant)";
  } else {
    note = "not simulated: a delay of the logged force is the log's, not the plant's";
    return false;
  }
  return true;
}

/// Whether each compared sample lies in a held-out fold (odd fold index).
std::vector<char> heldout_samples(const std::vector<double>& t, const std::vector<double>& edges) {
  std::vector<char> keep(t.size());
  for (std::size_t k = 0; k < t.size(); ++k)
    keep[k] = static_cast<char>((std::upper_bound(edges.begin(), edges.end(), t[k]) - edges.begin()) % 2 == 1);
  return keep;
}

/// 1 - (b/a)^2: the share of a's error energy that b no longer has.
double energy_removed(double a, double b) { return a > 0 && std::isfinite(b) ? 1.0 - (b / a) * (b / a) : 0.0; }

/// How surely processing the simulation alike lowers a signal's error on
/// held-out time: the z the effects are judged by (diag::improvement_z),
/// with the raw comparison's error as the current residual and the error
/// processed alike as the candidate's.
double comparison_z(const std::vector<char>& keep, const std::vector<double>& y, const std::vector<double>& raw,
                    const std::vector<double>& processed) {
  std::vector<std::size_t> ho;
  for (std::size_t k = 0; k < keep.size() && k < y.size(); ++k)
    if (keep[k] && std::isfinite(y[k] - raw[k]) && std::isfinite(y[k] - processed[k])) ho.push_back(k);
  return diag::improvement_z(ho.size(), [&](std::size_t k) { return std::make_pair(y[ho[k]] - raw[ho[k]], y[ho[k]] - processed[ho[k]]); });
}

/// The comparison as a cause: velocity's and acceleration's (the signals
/// the processing touches) energy share and fold-wise z.
void judge_comparison(const ReplayResult& r, const std::vector<char>& keep, double significance_z, ModelGap& g) {
  g.comparison_share[0] = energy_removed(g.before_pct.velocity, g.before_same_pct.velocity);
  g.comparison_share[1] = energy_removed(g.before_pct.acceleration, g.before_same_pct.acceleration);
  g.comparison_z[0] = comparison_z(keep, r.v, r.v_sim, r.v_sim_processed);
  g.comparison_z[1] = comparison_z(keep, r.a, r.a_sim, r.a_sim_processed);
  g.comparison_significance_z = significance_z;
  g.comparison_named = g.comparison_z[0] >= significance_z || g.comparison_z[1] >= significance_z;
}

void replay_before_after(const DiagnoseOptions& opt, const Controller& c, const LoggedRun& run, const ReplayOptions& ropt,
                         ModelGap& g) {
  g.before = replay(*opt.model, c, run, ropt);
  PlantEffects pe = plant_effects(g.diagnosis.effects, opt.model->drive.mass_kg);
  g.plant = pe.list;
  ReplayOptions with = ropt;
  with.effects = pe.effects;
  with.extra_force = pe.extra_force;
  g.after = replay(*opt.model, c, run, with);
  const std::vector<char> keep = heldout_samples(g.before.t, g.diagnosis.fold_edges);
  g.heldout_samples = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), 1));
  if (g.heldout_samples < 100) throw std::invalid_argument(run.source + ": too few held-out samples to replay on");
  g.before_pct = figures_where(g.before, keep, false);
  g.before_same_pct = figures_where(g.before, keep, true);
  g.processing_pct = processing_where(g.before, keep);
  g.after_effects_pct = figures_where(g.after, keep, false);
  g.after_same_pct = figures_where(g.after, keep, true);
  judge_comparison(g.before, keep, opt.significance_z, g);
  g.after_pct = g.comparison_named ? g.after_same_pct : g.after_effects_pct;
  g.replayed = true;
}

nlohmann::json figures_json(const ReplayFigures& f) {
  auto n = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  return {{"position", n(f.position)}, {"velocity", n(f.velocity)}, {"acceleration", n(f.acceleration)}, {"force", n(f.force)}};
}

void print_figures(std::ostringstream& o, const char* label, const ReplayFigures& f) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "  %-46s %9.4g %9.4g %12.4g %8.4g\n", label, f.position, f.velocity, f.acceleration, f.force);
  o << buf;
}

}  // namespace

PlantEffects plant_effects(const std::vector<NamedEffect>& named, double mass_kg) {
  PlantEffects out;
  std::vector<Drag> drags;
  for (const NamedEffect& e : named) {
    PlantEffect p;
    p.kind = e.kind;
    p.simulated = into_plant(e, mass_kg, out.effects, drags, p.note);
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

ModelGap model_gap(const Trace& trace, const DiagnoseOptions& opt, const Controller* c, const LoggedRun* run,
                   const ReplayOptions& ropt) {
  if (!opt.model) throw std::invalid_argument("model_gap: no model given");
  ModelGap g;
  g.diagnosis = diagnose(trace, opt);
  if (!g.diagnosis.error.empty() || !c || !run) return g;
  replay_before_after(opt, *c, *run, ropt, g);
  return g;
}

nlohmann::json to_json(const ModelGap& g) {
  nlohmann::json j = to_json(g.diagnosis);
  if (!g.replayed || !g.diagnosis.error.empty()) return j;
  nlohmann::json plant = nlohmann::json::array();
  for (const PlantEffect& p : g.plant) plant.push_back({{"kind", p.kind}, {"simulated", p.simulated}, {"note", p.note}});
  j["replay"] = {
      {"before_pct", figures_json(g.before_pct)},
      {"after_pct", figures_json(g.after_pct)},
      {"after_effects_only_pct", figures_json(g.after_effects_pct)},
      {"before_same_processing_pct", figures_json(g.before_same_pct)},
      {"after_same_processing_pct", figures_json(g.after_same_pct)},
      {"processing_alone_pct", figures_json(g.processing_pct)},
      {"comparison_named", g.comparison_named},
      {"comparison_energy_share", {{"velocity", g.comparison_share[0]}, {"acceleration", g.comparison_share[1]}}},
      {"comparison_z", {{"velocity", g.comparison_z[0]}, {"acceleration", g.comparison_z[1]}}},
      {"comparison_rule", "the comparison is a cause when processing the simulation as the measurement lowers the "
                          "error energy of velocity or acceleration significantly on held-out time: the decrease over "
                          "its noise-only spread in 20 contiguous groups (comparison_z, the statistic effects are "
                          "judged by) at least " +
                              std::to_string(g.comparison_significance_z).substr(0, 4) +
                              "; after_pct then compares both sides processed alike"},
      {"plant_effects", plant},
      {"heldout_samples", g.heldout_samples},
      {"samples_compared", g.before.samples_compared},
      {"definition", "100 ||y - y_sim|| / ||y|| over the samples of held-out folds (relative_error_pct of feedid replay); "
                     "effects fitted on the identification folds"}};
  return j;
}

std::string summary(const ModelGap& g) {
  std::ostringstream o;
  o << summary(g.diagnosis);
  if (!g.replayed || !g.diagnosis.error.empty()) return o.str();
  o << "replay in the drive's loop, held-out time (" << g.heldout_samples << " of " << g.before.samples_compared
    << " samples), relative error (%):\n";
  char buf[200];
  std::snprintf(buf, sizeof buf, "  %-46s %9s %9s %12s %8s\n", "", "position", "velocity", "acceleration", "force");
  o << buf;
  print_figures(o, "before (the model as given)", g.before_pct);
  print_figures(o, "  both sides processed alike", g.before_same_pct);
  print_figures(o, "  the processing alone", g.processing_pct);
  print_figures(o, "with the named effects in the plant", g.after_effects_pct);
  print_figures(o, "  both sides processed alike", g.after_same_pct);
  print_figures(o, "after (every named cause)", g.after_pct);
  for (const PlantEffect& p : g.plant) o << "  " << p.kind << ": " << p.note << "\n";
  std::snprintf(buf, sizeof buf, "energy processing alike removes: velocity %.0f %% (z %.1f), acceleration %.0f %% (z %.1f); "
                "a cause at z >= %.3g on held-out time",
                100 * g.comparison_share[0], g.comparison_z[0], 100 * g.comparison_share[1], g.comparison_z[1],
                g.comparison_significance_z);
  o << (g.comparison_named ? "  cause: the comparison (the measurement is processed, the simulation is not): "
                           : "  the comparison's processing is not a cause here: ")
    << buf << "\n";
  return o.str();
}

}  // namespace feedid::host
