// Named effects, as diagnose writes them ({"kind", "parameters"}) and a
// model file carries them, as the replay's plant draws them: the one rule
// for replay, diagnose --model's replay after the causes, and a model file's
// own effects. Host only.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "drive_sim.hpp"

namespace feedid::host {

/// A named effect and whether the replay's plant simulates it.
struct PlantEffect {
  std::string kind;
  bool simulated = false;
  std::string note;  ///< how it enters the plant, or why it does not
};

/// The named effects as the plant's effects (drive_sim.hpp) and one
/// extra force for those its fixed shapes do not draw; each effect says
/// whether and how it entered.
struct PlantEffects {
  Effects effects;
  ExtraForce extra_force;
  ExtraForceScales extra_scales;  ///< how fast extra_force changes
  std::vector<PlantEffect> list;
  std::string error;  ///< the first effect whose parameters the plant cannot take, and why
};

/// named: a JSON array of {"kind", "parameters"}; a later effect of a kind
/// the plant draws once (a ripple) takes the place of an earlier one.
/// mass_kg: the model's (a compliance's load share).
PlantEffects plant_effects(const nlohmann::json& named, double mass_kg);

}  // namespace feedid::host
