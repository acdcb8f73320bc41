// The host's one error form (issue 29): a result carries its error.
//
// Every host function that can fail on what it is given returns a result
// with an `error` string, empty when it did not fail: IdentifyResult,
// CsvResult, ModelFile, Controller, ValidateResult, ... Outcome<T> is that
// result for a plain value (a parsed name, a JSON document). A broken
// precondition of the code itself (a filter asked for a cut-off its caller
// never checked) is a bug and stays an exception.
//
// Nothing below host_sim/cli prints an error or chooses an exit code: the
// CLI prints "error: " and the message, and exits 2 for bad input, 1 for an
// output that could not be written (README, "Exit status"). Host only.
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace feedid::host {

template <typename T>
struct Outcome {
  T value{};
  std::string error;  ///< why there is no value; empty when there is one
  bool ok() const { return error.empty(); }
};

/// How a whole run that prints its own tables as it goes (a benchmark, a
/// coverage study) ended: what was refused, what could not be written, and
/// whether a bar it checks was missed. The CLI says it and picks the exit
/// code (host_sim/cli: 2, 1, 3).
struct RunEnd {
  std::string bad_input;                 ///< an option or input refused; nothing was run
  std::vector<std::string> not_written;  ///< outputs that could not be written, one message each
  bool bar_missed = false;               ///< a bar the run checks was not met
  static RunEnd refused(std::string why) {
    RunEnd e;
    e.bad_input = std::move(why);
    return e;
  }
  /// Records the error of a write (empty: it was written).
  void written(const std::string& error) {
    if (!error.empty()) not_written.push_back(error);
  }
};

/// An Outcome without a value, for `why`.
template <typename T>
Outcome<T> refused(std::string why) {
  Outcome<T> o;
  o.error = std::move(why);
  return o;
}

}  // namespace feedid::host
