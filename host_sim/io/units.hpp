// The units of an axis and of its force input, for every label the tool
// prints. The estimator itself is unit-free: a rotary log in rad and N m,
// or a drive log in volts, goes through the same arithmetic, and its
// parameters scale exactly as its units do (tests/io/units_test.cpp). Only
// the labels change, and they are written here once. Host only.
#pragma once
#include <algorithm>
#include <array>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

namespace feedid::host {

enum class Axis { linear, rotary };

struct Units {
  std::string position = "m";  ///< m (linear) or rad (rotary)
  std::string force = "N";     ///< N, N m, or a label such as V or A for an unscaled input

  std::string velocity() const { return position + "/s"; }
  std::string acceleration() const { return position + "/s^2"; }
  /// Force per velocity: N s/m, N m s/rad, V s/rad.
  std::string viscous() const { return force + " s/" + position; }
  /// Force per acceleration: kg and kg m^2 where the force is SI, else
  /// e.g. V s^2/rad (SysId's kA).
  std::string mass() const {
    if (force == "N" && position == "m") return "kg";
    if (force == "N m" && position == "rad") return "kg m^2";
    return force + " s^2/" + position;
  }
  bool linear_si() const { return force == "N" && position == "m"; }
};

/// The units of an axis: SI for its kind unless the force input is
/// labelled (force_label non-empty, e.g. "V").
inline Units units_for(Axis axis, const std::string& force_label = "") {
  Units u;
  u.position = axis == Axis::rotary ? "rad" : "m";
  u.force = !force_label.empty() ? force_label : (axis == Axis::rotary ? "N m" : "N");
  return u;
}

/// JSON `units`: per parameter (m, sigma, fc, fs, vs) and per signal.
inline nlohmann::json units_json(const Units& u) {
  return {{"m", u.mass()},          {"sigma", u.viscous()},   {"fc", u.force},   {"fs", u.force},
          {"vs", u.velocity()},     {"position", u.position}, {"force", u.force}, {"velocity", u.velocity()}};
}

/// A unit label as a key's suffix: rad/s -> rad_s, kg m^2 -> kg_m2,
/// V s^2/rad -> V_s2_rad.
inline std::string unit_token(const std::string& label) {
  std::string t;
  for (char c : label) {
    if (c == ' ' || c == '/') t += '_';
    else if (c != '^') t += c;
  }
  return t;
}

namespace detail {
/// The SI linear suffixes and the units they stand for, longest first
/// (_m_s2 before _m_s before _m).
inline std::array<std::pair<std::string, std::string>, 6> si_suffixes(const Units& u) {
  return {{{"_m_s2", u.acceleration()}, {"_m_s", u.velocity()}, {"_Ns_m", u.viscous()},
           {"_kg", u.mass()},           {"_m", u.position},     {"_N", u.force}}};
}
/// key with suffix `from` replaced by `to`; false when it does not end in it.
inline bool swap_suffix(std::string& key, const std::string& from, const std::string& to) {
  if (key.size() <= from.size() || key.compare(key.size() - from.size(), from.size(), from) != 0) return false;
  key = key.substr(0, key.size() - from.size()) + to;
  return true;
}
}  // namespace detail

/// An output key that names an SI linear unit (suffix _m_s2, _m_s, _Ns_m,
/// _kg, _m or _N) named in u's instead, so that no key names a unit its
/// value is not in: velocity_max_m_s is velocity_max_rad_s on a rotary
/// axis, max_force_N is max_force_V for a force in volts. Any other key, or
/// any key in m and N, is unchanged.
inline std::string key_in_units(std::string key, const Units& u) {
  if (u.linear_si()) return key;
  for (const auto& [si, unit] : detail::si_suffixes(u))
    if (detail::swap_suffix(key, si, "_" + unit_token(unit))) break;
  return key;
}

/// Keys whose value is an angle on every axis: named in rad already, so the
/// inverse below must not read their _rad as a rotary position's.
inline bool angle_key(const std::string& key) {
  for (const char* k : {"phase_rad", "angle0_rad", "angle0_se_rad"})
    if (key == k) return true;
  return false;
}

/// The inverse: a key named in u's units back in m and N, for what reads
/// the JSON back (a model file's effects): force_N_m is force_N, phase_rad
/// stays phase_rad.
inline std::string key_in_si(std::string key, const Units& u) {
  if (u.linear_si() || angle_key(key)) return key;
  auto suffixes = detail::si_suffixes(u);
  // The longest unit first: _N_m_s_rad (viscous) before _rad_s before _rad.
  std::sort(suffixes.begin(), suffixes.end(), [](const auto& a, const auto& b) { return a.second.size() > b.second.size(); });
  for (const auto& [si, unit] : suffixes)
    if (detail::swap_suffix(key, "_" + unit_token(unit), si)) break;
  return key;
}

/// j with every key renamed by `rename` (key_in_units or key_in_si), through objects and arrays.
template <typename Rename>
nlohmann::json renamed_keys(const nlohmann::json& j, const Units& u, Rename rename) {
  if (j.is_array()) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& v : j) out.push_back(renamed_keys(v, u, rename));
    return out;
  }
  if (!j.is_object()) return j;
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [key, value] : j.items()) out[rename(key, u)] = renamed_keys(value, u, rename);
  return out;
}
inline nlohmann::json keys_in_units(const nlohmann::json& j, const Units& u) { return renamed_keys(j, u, key_in_units); }
inline nlohmann::json keys_in_si(const nlohmann::json& j, const Units& u) { return renamed_keys(j, u, key_in_si); }

/// The units a command's JSON states (its top-level "units": position and
/// force); m and N when it states none.
inline Units stated_units(const nlohmann::json& j) {
  Units u;
  if (!j.is_object() || !j.contains("units") || !j.at("units").is_object()) return u;
  const nlohmann::json& s = j.at("units");
  if (s.contains("position") && s.at("position").is_string()) u.position = s.at("position").get<std::string>();
  if (s.contains("force") && s.at("force").is_string()) u.force = s.at("force").get<std::string>();
  return u;
}

/// A command's JSON as it is written: its keys named in the units it states
/// (keys_in_units). Every JSON output goes through this once.
inline nlohmann::json json_as_written(const nlohmann::json& j) { return keys_in_units(j, stated_units(j)); }

/// Why a model JSON cannot be applied to a log read in `run`'s units: its
/// `units` (identify writes them) name another position or force unit, e.g.
/// a rotary model (rad, N m) on a linear log (m, N), whose friction and
/// inertia would be read in the wrong unit with no other sign. Empty when
/// they agree, or when the model states no units (a hand-written file is
/// taken in the log's units).
/// `run_is` and `remedy` word the other side for a caller whose units are
/// not a log's (the circle test's simulated axes).
inline std::string model_units_mismatch(const nlohmann::json& model, const Units& run,
                                        const std::string& run_is = "the log is read in",
                                        const std::string& remedy =
                                            ": give the log's --axis and --force-unit as the model was identified with "
                                            "(--axis rotary for rad), or a model of this axis") {
  if (!model.is_object() || !model.contains("units") || !model.at("units").is_object()) return "";
  const nlohmann::json& u = model.at("units");
  auto stated = [&u](const char* key) { return u.contains(key) && u.at(key).is_string() ? u.at(key).get<std::string>() : ""; };
  const std::string position = stated("position"), force = stated("force");
  if ((position.empty() || position == run.position) && (force.empty() || force == run.force)) return "";
  return "the model is in " + (position.empty() ? run.position : position) + " and " + (force.empty() ? run.force : force) +
         ", " + run_is + " " + run.position + " and " + run.force + remedy;
}

}  // namespace feedid::host
