// Sim-to-real gap diagnosis: fit the base model on part of a trace, measure
// the force residual on the held-out rest, say where it lies, which
// unmodelled effect explains it, and how far adding that effect shrinks the
// held-out gap. docs/diagnosis.md gives the method. Host only.
#pragma once
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "identify/identify.hpp"
#include "io/trace.hpp"
#include "model/effects.hpp"
#include "model/model_file.hpp"

namespace feedid::host {

struct DiagnoseResult;
struct NamedEffect;

struct DiagnoseOptions {
  IdentifyOptions identify;       ///< how the base model is identified (columns, filters)
  double block_s = 0.005;         ///< residual block length (s): force residual is averaged per block
  int folds = 40;                 ///< at most this many time folds (each spans two motion cycles); odd ones are held out
  /// Held-out improvement over its noise-only spread (improvement_z in
  /// diagnose.cpp) a candidate must exceed; calibrated in docs/diagnosis.md.
  double significance_z = 5.0;
  double min_closed_fraction = 0.5;  ///< share of the gap's excess energy the named effects together must explain
  /// Share of the gap's excess energy left at a step that an effect added
  /// there must explain (forward selection, docs/diagnosis.md).
  double min_step_energy_share = 0.4;
  double unexplained_ratio = 1.4;    ///< held-out RMS / noise floor above which a gap is real
  int max_effects = 3;               ///< forward selection stops after this many
  /// A Coulomb asymmetry |Fc+ - Fc-|/2 above this share of the mean Coulomb
  /// force is reported as ambiguous with an offset (indistinguishable while moving).
  double offset_asymmetry_ratio = 0.1;
  /// A held-out observation whose leverage under the base fit exceeds this
  /// (its prediction variance above half the noise variance) lies where the
  /// identification folds do not reach; it is set aside, not scored.
  double max_leverage = 0.5;
  /// Families evaluated at once at each selection step (0: the machine's
  /// hardware threads): the result is the same on any number; more threads
  /// only shorten the wall time. Unless 1, where the base's gap lies is
  /// found on one thread more, beside them.
  int threads = 0;
  std::function<void(double)> progress;  ///< called from the caller's thread only
  /// A model to diagnose as given (`diagnose --model`): its mass, friction
  /// and offset are the base model, not refitted; only the effects are
  /// fitted on the identification folds, and the gap is judged on the
  /// held-out ones. Empty: the base model is fitted on the identification folds.
  std::optional<ModelFile> model;
  /// Called once on the caller's thread when the named effects are final
  /// (after the verdict), before the diagnosis's last reports (where the
  /// gap is left, the kept series): diagnose --controller starts its
  /// replay with the effects there, so that the two run side by side.
  std::function<void(const DiagnoseResult&)> on_effects_final;
  /// Called on the caller's thread at each step after the first, with the
  /// effects named so far and their parameters as they would be reported
  /// were this step to name none: diagnose --controller starts its replay
  /// after the causes on them there, and keeps it where they are final.
  std::function<void(const std::vector<NamedEffect>&)> on_effects_provisional;
};

struct Candidate {
  std::string kind;
  nlohmann::json parameters;      ///< fitted on the identification part, SI names
  double heldout_rms_N = 0.0;     ///< held-out RMS with this effect added
  double closed_fraction = 0.0;   ///< of the excess gap over the noise floor
  double z_statistic = 0.0;       ///< held-out improvement over its noise-only spread
  double energy_share = 0.0;      ///< of the excess gap energy this effect explains
  bool significant = false;
  bool indistinguishable = false; ///< its term is (almost) a combination of the base model's terms here
  std::string note;
};

/// One effect named by forward selection, with the gap after adding it.
struct NamedEffect {
  std::string kind;
  nlohmann::json parameters;      ///< from the joint fit with every named effect
  double heldout_rms_N = 0.0;     ///< held-out RMS with this and the effects before it
  double closed_fraction = 0.0;   ///< of the base model's excess gap, cumulative
  double z_statistic = 0.0;       ///< at the step it was added; a pair's member: given the other
  /// The other member where it was named in a pair (neither passed the z
  /// test alone; docs/diagnosis.md), else empty: the first step's table
  /// then shows each alone, not significant, and its z there differs.
  std::string named_with;
};

struct WhereEntry {
  std::string domain;   ///< velocity, position, time, after_reversal, acceleration_change, frequency
  std::string range;    ///< human-readable range with units
  double lo = 0.0, hi = 0.0;  ///< numeric range in the domain's SI unit
  double share = 0.0;         ///< share of held-out residual energy in this range
  double time_share = 0.0;    ///< share of held-out time in this range
};

struct DiagnoseResult {
  std::string error;
  IdentifyResult base;            ///< the core's identification on the identification part
  double time_origin_s = 0.0;     ///< what the times (the where) count from (Trace::time_origin_s)
  std::string effect;             ///< none, unexplained, or the first of effects
  nlohmann::json effect_parameters;
  std::vector<NamedEffect> effects;  ///< forward selection, in the order added
  bool gap_remains = false;       ///< a significant gap is left after the named effects (unexplained)
  double rms_base_N = 0.0;        ///< held-out RMS force residual of the base model
  double rms_augmented_N = 0.0;   ///< held-out RMS with every named effect (= base when none)
  double noise_floor_N = 0.0;     ///< RMS a perfect model would leave (white block noise)
  /// RMS a point-sampled force log adds at acceleration steps (0 for period-mean logs);
  /// with noise_floor_N it sets the floor of the test for a remaining gap.
  double sampling_floor_N = 0.0;
  double closed_fraction = 0.0;   ///< of the excess gap, by every named effect
  std::vector<WhereEntry> where;  ///< of the base model's held-out residual
  std::vector<WhereEntry> where_left;  ///< of what the named effects leave (when a gap remains)
  std::vector<Candidate> candidates;  ///< first step, ranked, best first
  std::vector<std::vector<Candidate>> steps;  ///< every forward-selection step's candidates, ranked
  /// Effects the data cannot tell from the base model's own terms, e.g. an
  /// offset from Coulomb friction that differs by direction.
  nlohmann::json ambiguities = nlohmann::json::array();
  /// The base model refitted jointly with the named effects on the
  /// identification folds (valid when has_augmented_model).
  DriveParams augmented_model{};
  bool has_augmented_model = false;
  std::size_t blocks_identification = 0, blocks_heldout = 0;
  std::size_t heldout_beyond_identification = 0;  ///< held-out observations set aside (max_leverage)
  double force_lag_s = 0.0;               ///< lag the base model pairs force with (s)
  double lag_beyond_conventions_s = 0.0;  ///< estimated lag beyond the conventions, left to `delay` (s)
  std::string position_origin = "measured";  ///< or how it was obtained (integrated from velocity)
  ForceOutliers force_outliers;  ///< forces beyond the data's limit, bridged as identify bridges them
  bool model_given = false;  ///< the base model is DiagnoseOptions::model, not fitted
  ModelFile given_model;     ///< that model (when model_given)
  std::vector<double> fold_edges;  ///< interior fold edges on the trace's clock (s); odd folds are held out
  int folds = 0;  ///< time folds used (at most DiagnoseOptions::folds; each spans two motion cycles)
  // Series for the report (observations): centre time, position, velocity, residual before/after.
  std::vector<double> block_t, block_x, block_v, block_r_base, block_r_aug;
  std::vector<bool> block_heldout;
};

DiagnoseResult diagnose(const Trace& trace, const DiagnoseOptions& opt);
nlohmann::json to_json(const DiagnoseResult& r);
std::string summary(const DiagnoseResult& r);

}  // namespace feedid::host
