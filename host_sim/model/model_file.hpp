// A model file as a user brings it to replay or diagnose: the JSON that
// `feedid identify --json` writes, or a hand-written one with at least
//
//     {"m": 95.1, "pos": {"sigma": 203.5, "fc": 20.4[, "fs": 0, "vs": 1e-3]},
//                 "neg": {...}[, "offset_N": -3.16]
//      [, "gravity": {"G": 30.2, "angle0_rad": 0.41}]}
//
// (the drive model of NOTES.md plus a constant load force). The one reader
// for every stage that takes a model (validate, replay, diagnose,
// compensate, circle). A "comment" key (a citation, say) and "units" are
// allowed. Host only.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "drive_model.hpp"

namespace feedid::host {

struct ModelFile {
  DriveParams drive;
  /// The load the drive holds at rest and in motion, u = m a + F(v) + load:
  /// the file's "offset_N" (F0; the EMPS reference model's "offset"), and
  /// the gravity term identify --gravity wrote ("gravity": a constant G adds
  /// to F0; G cos(q - angle0_rad) is the arm's weight). None when the file
  /// has neither.
  ModelLoad load;
  /// Effects diagnose named, as it writes them ([{"kind", "parameters"}]):
  /// replay simulates them in the model's plant (sim/named_effects.hpp).
  /// Empty when the file has none.
  nlohmann::json effects = nlohmann::json::array();
  /// Keys the reader did not use, as "model.json: unknown key 'foo' (ignored)":
  /// a typo must not silently leave a parameter at its default.
  std::vector<std::string> warnings;
  std::string source;  ///< file name, for messages
  /// The file's "units" as identify writes them (null when it states none):
  /// checked against the log's with model_units_mismatch (io/units.hpp).
  nlohmann::json units;
  /// Why the file holds no usable model, naming the file and the key; empty
  /// when it does (the host's one error form, io/outcome.hpp).
  std::string error;
};

/// Reads a model from parsed JSON; `source` names it in messages.
/// Required: m (> 0), pos and neg objects with sigma and fc. fs and vs are
/// optional together (no Stribeck dip when fs is absent or 0); a vs without
/// fs, or fs > 0 without vs > 0, is an error. A JSON written by identify
/// (it has "status" and "standard_errors") may carry its report keys
/// beside the model; in any other file an unknown key is a warning.
/// A file that cannot be read sets `error`, naming the source and the key.
ModelFile model_file_from_json(const nlohmann::json& j, const std::string& source);

/// The same from a file (read_json_file's errors for a missing or broken file).
ModelFile read_model_file(const std::string& path);

}  // namespace feedid::host
