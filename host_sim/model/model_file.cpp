// Reading a model file (model_file.hpp).
#include "model_file.hpp"

#include "effects.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

namespace feedid::host {
namespace {

/// Whether j is the report `feedid identify --json` writes: its model keys
/// sit among the report's own (standard errors, counts, input...).
bool written_by_identify(const nlohmann::json& j) { return j.contains("status") && j.contains("standard_errors"); }

/// Records the reader's first refusal (outcome.hpp); the reader returns at
/// its next check, and what a helper returned after it is never used.
void refuse(ModelFile& out, const std::string& what) {
  if (out.error.empty()) out.error = out.source + ": " + what;
}

/// j[key] as a finite number (NaN, refused, where it is not one); `where`
/// is the key's path for messages.
double number_at(const nlohmann::json& j, const char* key, const std::string& where, ModelFile& out) {
  const nlohmann::json* v = j.contains(key) ? &j.at(key) : nullptr;
  if (!v) refuse(out, "missing key '" + where + key + "'");
  else if (!v->is_number() || !std::isfinite(v->get<double>())) refuse(out, "'" + where + key + "' must be a finite number");
  else return v->get<double>();
  return std::numeric_limits<double>::quiet_NaN();
}

/// Keys of j outside `known` (and, in a file identify wrote, outside
/// `report`: what identify writes beside the model), each as a warning.
/// A typo among identify's keys (ofset_N) was passed over with them.
/// `units`: the file's, in which identify named its report keys
/// (mass_from_windows_kg_m2 on a rotary axis, friction_rms_V for a force in V).
void warn_unknown(const nlohmann::json& j, const std::set<std::string>& known, const std::set<std::string>& report,
                  bool from_identify, const Units& units, const std::string& where, ModelFile& out) {
  for (const auto& [key, value] : j.items())
    if (!known.count(key) && !(from_identify && report.count(key_in_si(key, units))))
      out.warnings.push_back(out.source + ": unknown key '" + where + key + "' (ignored)");
}

/// What identify writes beside the model (identify.cpp, to_json; demo adds
/// the simulator's truth), at the top and in each direction.
/// tests/identify/identify_model_test.cpp reads identify's own JSON back
/// without a warning, so that these follow what identify writes.
const std::set<std::string> kIdentifyReportKeys = {
    "config", "counts", "error", "fit", "friction_curve", "input", "m_flags", "m_identifiable", "m_se",
    "mass_from_windows_kg", "method", "model", "not_physical", "not_physical_cause", "physical", "standard_errors",
    "status", "sysid", "truth", "warnings"};
const std::set<std::string> kIdentifyDirectionReportKeys = {
    "bands_used", "fc_se", "flags", "friction_r2", "friction_rms_N", "fs_se", "identifiable", "sections",
    "sigma_se", "time_in_bands_s", "vs_se"};

DirectionFriction direction_from_json(const nlohmann::json& j, const char* name, bool from_identify, ModelFile& out) {
  DirectionFriction f;
  if (!j.contains(name) || !j.at(name).is_object()) {
    refuse(out, std::string("missing object '") + name + "'");
    return f;
  }
  const nlohmann::json& o = j.at(name);
  const std::string w = std::string(name) + ".";
  f.viscous_Ns_m = number_at(o, "sigma", w, out);
  f.coulomb_N = number_at(o, "fc", w, out);
  const bool has_fs = o.contains("fs"), has_vs = o.contains("vs");
  f.breakaway_N = has_fs ? number_at(o, "fs", w, out) : 0.0;
  f.stribeck_velocity_m_s = has_vs ? number_at(o, "vs", w, out) : 0.0;
  if (!out.error.empty()) return f;
  if (has_vs && !has_fs) refuse(out, "'" + w + "vs' given without '" + w + "fs' (the Stribeck dip needs both)");
  // No dip: vs plays no part; 1 m/s keeps F(v) defined (to_drive_params' rule).
  if (f.breakaway_N == 0.0 && !(f.stribeck_velocity_m_s > 0.0)) f.stribeck_velocity_m_s = 1.0;
  if (f.breakaway_N < 0.0) refuse(out, "'" + w + "fs' must be >= 0 (static friction is fc + fs)");
  if (!(f.stribeck_velocity_m_s > 0.0)) refuse(out, "'" + w + "vs' must be > 0 when '" + w + "fs' is given");
  warn_unknown(o, {"sigma", "fc", "fs", "vs"}, kIdentifyDirectionReportKeys, from_identify, stated_units(j), w, out);
  return f;
}

/// What identify flagged in a direction it wrote, as a warning; empty where
/// nothing the model uses was flagged. A direction never seen (no_data)
/// holds zero friction, and a parameter identify called not identifiable
/// is a value the data did not settle: replayed, diagnosed against or
/// loaded into a drive as a compensation table, either passes for the
/// axis's without a word otherwise. fs and vs count only where the dip
/// is in the model (fs > 0).
std::string unidentified_in(const nlohmann::json& j, const char* name, const std::string& source) {
  const nlohmann::json& o = j.at(name);
  const nlohmann::json flags = o.value("flags", nlohmann::json::array());
  const bool unseen = flags.is_array() && std::find(flags.begin(), flags.end(), "no_data") != flags.end();
  if (unseen)
    return source + ": identify never saw the " + (std::string(name) == "pos" ? "positive" : "negative") +
           " direction (" + name + " flag no_data): its friction in the model is a placeholder, not the axis's";
  if (!o.contains("identifiable") || !o.at("identifiable").is_object()) return "";
  const nlohmann::json& id = o.at("identifiable");
  const bool dip = o.value("fs", 0.0) > 0.0;
  std::string list;
  for (const char* key : {"sigma", "fc", "fs", "vs"}) {
    if (!dip && (std::string(key) == "fs" || std::string(key) == "vs")) continue;
    if (id.contains(key) && id.at(key).is_boolean() && !id.at(key).get<bool>())
      list += std::string(list.empty() ? "" : ", ") + name + "." + key;
  }
  if (list.empty()) return "";
  return source + ": identify flagged " + list + " not identifiable (" + name + " flags " + flags.dump() +
         "): the data did not settle " + (list.find(',') == std::string::npos ? "it" : "them");
}

/// The gravity term as identify writes it ({"form": "constant"|"angle"|"none",
/// "G", "angle0_rad", ...}) or by hand ({"G", "angle0_rad"}: the arm form;
/// {"G"} alone: a constant). A constant G is a constant load: it adds to F0.
void read_gravity(const nlohmann::json& g, bool from_identify, ModelFile& out) {
  if (!g.is_object()) return refuse(out, "'gravity' must be an object");
  const std::string form = g.contains("form") && g.at("form").is_string() ? g.at("form").get<std::string>()
                           : g.contains("angle0_rad")                      ? "angle"
                                                                            : "constant";
  if (form == "none") return;
  if (form != "constant" && form != "angle")
    return refuse(out, "'gravity.form' is \"" + form + "\": none, constant or angle");
  const double G = number_at(g, "G", "gravity.", out);
  if (form == "constant") {
    out.load.offset_N += G;
  } else {
    out.load.gravity_N = G;
    out.load.gravity_angle0_rad = number_at(g, "angle0_rad", "gravity.", out);
  }
  if (!from_identify) warn_unknown(g, {"form", "G", "angle0_rad", "G_se", "angle0_se_rad", "units", "note", "rule"}, {},
                                   false, Units{}, "gravity.", out);
}

/// The effects diagnose named (a list of {"kind", "parameters"}), kept for
/// the replay's plant; a kind outside the catalogue is an error (a typo
/// must not silently leave an effect out).
void read_effects(const nlohmann::json& e, const nlohmann::json& j_units, ModelFile& out) {
  if (!e.is_array()) return refuse(out, "'effects' must be a list of {\"kind\", \"parameters\"}");
  for (const nlohmann::json& x : e) {
    if (!x.is_object() || !x.contains("kind") || !x.at("kind").is_string())
      return refuse(out, "each of 'effects' needs a \"kind\" (as diagnose writes them)");
    const std::string kind = x.at("kind").get<std::string>();
    bool known = false;
    for (int i = 0; i < kCatalogueCount; ++i) known = known || kind == effect_name(static_cast<Effect>(i));
    if (!known) return refuse(out, "'effects' names \"" + kind + "\", not an effect diagnose names");
    if (x.contains("parameters") && !x.at("parameters").is_object())
      return refuse(out, "the parameters of effect \"" + kind + "\" must be an object");
    out.effects.push_back(keys_in_si(x, stated_units(j_units)));  // force_N_m of a rotary file is force_N
  }
}

}  // namespace

ModelFile model_file_from_json(const nlohmann::json& j, const std::string& source) {
  ModelFile out;
  out.source = source;
  if (!j.is_object()) {
    refuse(out, "a model file must be a JSON object");
    return out;
  }
  const bool from_identify = written_by_identify(j);
  // Any file with identify's status (not_physical: solved, and refused
  // below by the one physical check).
  if (j.contains("status") && j.at("status") != "ok" && j.at("status") != "not_physical") {
    refuse(out, "identify did not solve it (status " + j.at("status").dump() +
                     (j.contains("error") && j.at("error").is_string() ? ": " + j.at("error").get<std::string>() : std::string()) +
                     "): the file holds no identified model");
    return out;
  }
  out.drive.mass_kg = number_at(j, "m", "", out);
  out.drive.pos = direction_from_json(j, "pos", from_identify, out);
  out.drive.neg = direction_from_json(j, "neg", from_identify, out);
  if (!out.error.empty()) return out;
  // offset_N_m on a rotary axis as the tool writes it; offset_N as a user may
  std::string offset = key_in_units("offset_N", stated_units(j));
  if (!j.contains(offset)) offset = "offset_N";
  if (j.contains(offset)) out.load.offset_N = number_at(j, offset.c_str(), "", out);
  if (j.contains("gravity")) read_gravity(j.at("gravity"), from_identify, out);
  if (j.contains("effects")) read_effects(j.at("effects"), j, out);
  if (!out.error.empty()) return out;
  if (j.contains("simulated_effects"))
    out.warnings.push_back(out.source + ": 'simulated_effects' (what simulate --truth simulated, by name) is not a "
                                        "model's effect list: the model is taken without them");
  if (j.contains("simulated_change"))
    out.warnings.push_back(out.source + ": 'simulated_change' (the step change or warm-up simulate --truth simulated) "
                                        "is not modelled: the model is the drive before it");
  if (j.contains("units")) out.units = j.at("units");
  const std::string unphysical = non_physical_parameters(out.drive, stated_units(j));  // in the file's units
  if (!unphysical.empty()) {
    refuse(out, "the model is not physical: " + unphysical + " (m must be > 0, fc and sigma >= 0)");
    return out;
  }
  warn_unknown(j, {"m", "pos", "neg", offset, "gravity", "effects", "simulated_effects", "simulated_change", "units", "comment"},
               kIdentifyReportKeys, from_identify, stated_units(j), "", out);
  for (const std::string& w : implausible_parameters(out.drive, stated_units(j))) out.warnings.push_back(out.source + ": " + w);
  if (from_identify)
    for (const char* name : {"pos", "neg"})
      if (const std::string w = unidentified_in(j, name, out.source); !w.empty()) out.warnings.push_back(w);
  return out;
}

ModelFile read_model_file(const std::string& path) {
  return read_json_file_as<ModelFile>(path, model_file_from_json);
}

}  // namespace feedid::host
