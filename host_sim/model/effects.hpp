// The unmodelled effects, one enum and one table: what the simulator can
// add, what the diagnosis can name (the first eight, NOTES.md's catalogue),
// their names in JSON and on the command line, and each effect's key and
// secondary parameter with its unit. Every stage takes names from here.
// Host only.
#pragma once
#include <array>
#include <string>
#include <vector>

namespace feedid::host {

enum class Effect {
  offset,
  position_ripple,
  position_friction,
  thermal_drift,
  quadratic_viscous,
  presliding_hysteresis,
  compliance,
  delay,
  // Outside the diagnosis's catalogue (the blind bench's "unexplained"):
  disturbance,
  wander,
};
constexpr int kEffectCount = 10;
constexpr int kCatalogueCount = 8;  ///< the first eight are the diagnosis's catalogue

struct EffectInfo {
  Effect effect;
  const char* name;        ///< JSON and command-line name
  const char* short_name;  ///< a table column's name
  const char* key;         ///< the parameter that identifies it (its JSON name; "" for none)
  const char* key_unit;
  const char* second;      ///< the secondary parameter ("" for none)
  const char* second_unit;
};

/// Every effect, in enum order.
const std::array<EffectInfo, kEffectCount>& effect_table();
const EffectInfo& effect_info(Effect e);
inline const char* effect_name(Effect e) { return effect_info(e).name; }
/// The entry of a name, or nullptr when the name is not an effect.
const EffectInfo* find_effect(const std::string& name);
/// The catalogue's names in order (what the diagnosis can name).
const std::vector<std::string>& effect_kinds();

}  // namespace feedid::host
