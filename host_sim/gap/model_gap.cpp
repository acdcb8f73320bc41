// The gap of a given model on a new run (model_gap.hpp).
#include "model_gap.hpp"

#include "diagnose/diagnose_fit.hpp"
#include "identify/gravity.hpp"
#include "io/beside.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace feedid::host {
namespace {

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

/// The base of the replays: the model's mass, friction and load, as the
/// diagnosis's is; effects a model file carries (an earlier diagnosis's)
/// are named anew.
ModelFile replay_base(const ModelFile& model) {
  ModelFile base = model;
  base.effects = nlohmann::json::array();
  return base;
}

/// The replay after the named causes (`after`: started on the effects named
/// so far and kept because they were the final ones, or started once they
/// were final) and the held-out figures of both; g.before, the base's
/// replay, set.
void replay_after(const DiagnoseOptions& opt, const LoggedRun& run, std::future<ReplayResult> after, ModelGap& g) {
  g.error = g.before.error;
  if (!g.error.empty()) return;  // the same loop fails with the effects too
  if (!after.valid()) {
    g.error = run.source + ": the diagnosis ended without naming its effects final (no replay after them)";
    return;
  }
  g.after = after.get();
  g.error = g.after.error;
  if (!g.error.empty()) return;
  const std::vector<char> keep = heldout_samples(g.before.t, g.diagnosis.fold_edges);
  g.heldout_samples = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), 1));
  if (g.heldout_samples < 100) {
    g.error = run.source + ": too few held-out samples to replay on";
    return;
  }
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

nlohmann::json named_effects_json(const std::vector<NamedEffect>& named) {
  nlohmann::json out = nlohmann::json::array();
  for (const NamedEffect& e : named) out.push_back({{"kind", e.kind}, {"parameters", e.parameters}});
  return out;
}

nlohmann::json model_with_effects(const DiagnoseResult& r, const nlohmann::json& given) {
  nlohmann::json j;
  if (!given.is_null()) {
    j = keys_in_si(given, stated_units(given));
  } else {
    // The base refitted beside the effects (the core's own fit on the
    // identification folds holds part of a drift or a position friction
    // already: with the effects beside it, that part would count twice).
    j = model_json(r.has_augmented_model ? r.augmented_model : to_drive_params(r.base.estimate), r.base.units);
    put_load(j, gravity_load(r.base.gravity));
    j["comment"] = "diagnose --model-out: the base refitted beside the named effects, on the identification folds";
  }
  j["effects"] = named_effects_json(r.effects);
  return j;
}

ModelGap model_gap(const Trace& trace, const DiagnoseOptions& opt, const Controller* c, const LoggedRun* run,
                   const ReplayOptions& ropt) {
  ModelGap g;
  for (const std::string* e : {opt.model ? &opt.model->error : nullptr, c ? &c->error : nullptr, run ? &run->error : nullptr})
    if (e && g.error.empty()) g.error = *e;
  if (!opt.model) g.error = "model_gap: no model given";
  if (!g.error.empty()) return g;
  // The replay before the causes depends on the model and the run alone:
  // it runs beside the diagnosis where threads are allowed.
  const ModelFile base = replay_base(*opt.model);
  std::atomic<bool> before_failed{false};  // declared before the futures, which are joined first
  std::future<ReplayResult> before, after;
  if (c && run)
    before = run_beside(opt.threads != 1, [&] {
      ReplayResult r = replay(base, *c, *run, ropt);
      before_failed = !r.error.empty();
      return r;
    });
  // The replay after the causes needs only the named effects. It is
  // started on those named so far at each step after the first (a guess:
  // they are final unless the step names more), and again once they are
  // final where the guess was wrong; with one thread only then. Not where
  // the replay before them has failed already: it would too.
  nlohmann::json guessed;
  std::vector<std::future<ReplayResult>> spent;  ///< wrong guesses, joined before return
  std::future<ReplayResult> guess;
  const auto replay_with = [&](const PlantEffects& pe) {
    return run_beside(opt.threads != 1, [&, with = with_plant_effects(ropt, pe)] { return replay(base, *c, *run, with); });
  };
  DiagnoseOptions with_replay = opt;
  if (c && run) {
    with_replay.on_effects_provisional = [&](const std::vector<NamedEffect>& named) {
      if (opt.on_effects_provisional) opt.on_effects_provisional(named);
      if (before_failed || opt.threads == 1) return;
      if (guess.valid()) spent.push_back(std::move(guess));
      guessed = named_effects_json(named);
      guess = replay_with(plant_effects(guessed, base.drive.mass_kg));
    };
    with_replay.on_effects_final = [&](const DiagnoseResult& d) {
      if (opt.on_effects_final) opt.on_effects_final(d);
      const nlohmann::json effects = named_effects_json(d.effects);
      const PlantEffects pe = plant_effects(effects, base.drive.mass_kg);
      g.plant = pe.list;
      if (guess.valid() && effects == guessed) {
        after = std::move(guess);
        return;
      }
      if (guess.valid()) spent.push_back(std::move(guess));
      if (!before_failed) after = replay_with(pe);
    };
  }
  g.diagnosis = diagnose(trace, with_replay);
  g.error = g.diagnosis.error;
  if (!g.error.empty() || !c || !run) return g;
  g.before = before.get();
  replay_after(opt, *run, std::move(after), g);
  return g;
}

nlohmann::json to_json(const ModelGap& g) {
  nlohmann::json j = to_json(g.diagnosis);
  if (!g.error.empty()) j["error"] = g.error;
  if (!g.replayed || !g.error.empty()) return j;
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
  if (!g.replayed || !g.error.empty()) return o.str();
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
