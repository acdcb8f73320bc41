// Monte Carlo check of the reported standard errors (feedid coverage): many
// simulated drives logged under every force convention and velocity filter,
// identified as a user would; how often estimate +- 1.96 se holds the truth,
// and each parameter's RMSE against batch Levenberg-Marquardt on the same
// traces. docs/coverage.md is its output. Host only.
#pragma once
#include <cstdint>
#include <functional>
#include <string>

#include "io/outcome.hpp"

namespace feedid::host {

struct CoverageOptions {
  int seeds = 50;             ///< traces per drive and force convention
  double duration_s = 30.0;   ///< length of each trace (s)
  int lm_every = 5;           ///< batch LM on every n-th trace (0: never)
  int threads = 2;
  std::uint64_t first_seed = 1;
  std::string json_path, markdown_path;
  std::function<void(double)> progress;
};

/// Runs the Monte Carlo, prints the tables, writes JSON / Markdown if asked.
/// The outputs it could not write are in the RunEnd (io/outcome.hpp).
RunEnd run_coverage(const CoverageOptions& opt);

}  // namespace feedid::host
