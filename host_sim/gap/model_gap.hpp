// The gap of a given model on a new run (issue 28, part 2): the diagnosis
// with the model as its base (DiagnoseOptions::model), and, given the
// drive's controller, the model replayed in the drive's loop before and
// after the named causes, judged on the held-out folds' time only.
//
// A cause is a catalogue effect the diagnosis names, added to the replay's
// plant where the plant draws it (plant_effects), or the comparison itself:
// the protocol compares a processed measurement with the plant's raw state,
// and when processing the simulation alike lowers a signal's error energy
// significantly across the held-out folds (a z test, as the effects are
// judged), the processing is named a cause and the figures after are taken
// with both sides processed alike. Host only.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "diagnose/diagnose.hpp"
#include "replay/replay.hpp"
#include "sim/named_effects.hpp"

namespace feedid::host {

/// The named effects as diagnose writes them ({"kind", "parameters"}), for
/// plant_effects (sim/named_effects.hpp) and a model file's "effects".
nlohmann::json named_effects_json(const std::vector<NamedEffect>& named);

/// A model file with the diagnosis's named effects (diagnose --model-out):
/// the given model's JSON (null: the base identify fitted on the
/// identification folds, as identify writes it) with "effects" set to the
/// effects named now, keys in m and N (the writer names them in the
/// file's units). replay simulates them (ModelFile::effects).
nlohmann::json model_with_effects(const DiagnoseResult& r, const nlohmann::json& given);

struct ModelGap {
  /// Why there is no gap to report: an input's own error, the diagnosis's,
  /// or a replay's; empty when the figures hold (io/outcome.hpp).
  std::string error;
  DiagnoseResult diagnosis;
  bool replayed = false;
  std::size_t heldout_samples = 0;  ///< replayed samples in held-out folds (after the first drop_first)
  /// Held-out figures (%), relative_error_pct's definition: before and
  /// after the named causes; after_effects: the effects alone, compared as
  /// the protocol does; same_processing: both sides processed alike;
  /// processing: the processing's own share (before).
  ReplayFigures before_pct, after_pct, after_effects_pct, before_same_pct, after_same_pct, processing_pct;
  bool comparison_named = false;
  /// Velocity [0] and acceleration [1]: the share of held-out error energy
  /// processing alike removes, 1 - (e_alike / e)^2, and its fold-wise z
  /// (named when either z reaches comparison_significance_z, the diagnosis's significance_z).
  double comparison_share[2] = {0.0, 0.0}, comparison_z[2] = {0.0, 0.0};
  double comparison_significance_z = 0.0;
  std::vector<PlantEffect> plant;
  ReplayResult before, after;  ///< the whole replays (series for plots)
};

/// Diagnoses `trace` against opt.model (required) and, when `c` and `run`
/// are given, replays before and after; `error` when either cannot run.
ModelGap model_gap(const Trace& trace, const DiagnoseOptions& opt, const Controller* c, const LoggedRun* run,
                   const ReplayOptions& ropt);

nlohmann::json to_json(const ModelGap& g);
std::string summary(const ModelGap& g);

}  // namespace feedid::host
