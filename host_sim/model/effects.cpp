// The effect table (effects.hpp).
#include "effects.hpp"

namespace feedid::host {

const std::array<EffectInfo, kEffectCount>& effect_table() {
  static const std::array<EffectInfo, kEffectCount> t = {{
      {Effect::offset, "offset", "offset", "force_N", "N", "", ""},
      {Effect::position_ripple, "position_ripple", "ripple", "period_m", "m", "amplitude_N", "N"},
      {Effect::position_friction, "position_friction", "pos_fric", "x_min_m..x_max_m (error / width)", "m", "delta_N",
       "N"},
      {Effect::thermal_drift, "thermal_drift", "drift", "time_constant_s", "s", "viscous_change_Ns_m", "N s/m"},
      {Effect::quadratic_viscous, "quadratic_viscous", "quadratic", "c2", "N s^2/m^2", "", ""},
      {Effect::presliding_hysteresis, "presliding_hysteresis", "presliding", "distance_m", "m", "force_N", "N"},
      {Effect::compliance, "compliance", "compliance", "frequency_hz", "Hz", "load_mass_kg", "kg"},
      {Effect::delay, "delay", "delay", "delay_s", "s", "", ""},
      {Effect::disturbance, "disturbance", "disturbance", "disturbance_amplitude_N", "N", "disturbance_frequency_hz",
       "Hz"},
      {Effect::wander, "wander", "wander", "wander_force_N", "N", "wander_time_constant_s", "s"},
  }};
  return t;
}

const EffectInfo& effect_info(Effect e) { return effect_table()[static_cast<std::size_t>(e)]; }

const EffectInfo* find_effect(const std::string& name) {
  for (const EffectInfo& i : effect_table())
    if (name == i.name) return &i;
  return nullptr;
}

const std::vector<std::string>& effect_kinds() {
  static const std::vector<std::string> k = [] {
    std::vector<std::string> v;
    for (int i = 0; i < kCatalogueCount; ++i) v.push_back(effect_table()[static_cast<std::size_t>(i)].name);
    return v;
  }();
  return k;
}

}  // namespace feedid::host
