// The units of an axis and of its force input, for every label the tool
// prints. The estimator itself is unit-free: a rotary log in rad and N m,
// or a drive log in volts, goes through the same arithmetic, and its
// parameters scale exactly as its units do (tests/io/units_test.cpp). Only
// the labels change, and they are written here once. Host only.
#pragma once
#include <string>

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

/// Why a model JSON cannot be applied to a log read in `run`'s units: its
/// `units` (identify writes them) name another position or force unit, e.g.
/// a rotary model (rad, N m) on a linear log (m, N), whose friction and
/// inertia would be read in the wrong unit with no other sign. Empty when
/// they agree, or when the model states no units (a hand-written file is
/// taken in the log's units).
inline std::string model_units_mismatch(const nlohmann::json& model, const Units& run) {
  if (!model.is_object() || !model.contains("units") || !model.at("units").is_object()) return "";
  const nlohmann::json& u = model.at("units");
  auto stated = [&u](const char* key) { return u.contains(key) && u.at(key).is_string() ? u.at(key).get<std::string>() : ""; };
  const std::string position = stated("position"), force = stated("force");
  if ((position.empty() || position == run.position) && (force.empty() || force == run.force)) return "";
  return "the model is in " + (position.empty() ? run.position : position) + " and " + (force.empty() ? run.force : force) +
         ", the log is read in " + run.position + " and " + run.force +
         ": give the log's --axis and --force-unit as the model was identified with (--axis rotary for rad), or a model of this axis";
}

}  // namespace feedid::host
