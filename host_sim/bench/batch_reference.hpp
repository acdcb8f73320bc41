// Batch reference of the streaming core's bookkeeping. Host only.
//
// Recomputes, from a whole array of samples, the sufficient statistics that
// feedid::Estimator<double> holds after push()ing every sample and
// calling solve() once -- written independently as a multi-pass algorithm
// over arrays (no shared state machine with the core):
//
//   1. validate every sample (the rejection rules of types.hpp / push()), and
//      form the per-interval quantities of the accepted samples: interval
//      length with the time of rejected samples added, interval force per
//      ForceAlignment, mean velocity, velocity change; continuity chains
//      split at gaps longer than max_gap_s (with velocity from position, the
//      first sample after the stream start or a gap gives only a position and
//      the next one starts the chain);
//   2. label velocity sections over each chain's velocity array (hysteresis:
//      open at |v| >= section_enter, close after rest_samples consecutive
//      samples below velocity_min or at a reversal beyond section_enter), and
//      mark which start at rest (at a reversal, or after the axis was seen
//      below velocity_min in the chain with no section open);
//   3. cut mass windows (consecutive moving intervals of one direction, at
//      most mass_window_s long, broken by rest, reversal and gaps);
//   4. band, window, noise and interval sums by direct summation in long
//      double;
//   5. fold periods per direction (section starts and ends, max_fold_s,
//      gaps, the final solve()) decide which sections are split (each
//      counted once); the paper method's point of a complete section that
//      started at rest is summed from the section's own moving intervals of
//      its direction.
//
// Threshold decisions on accumulated time (window length >= mass_window_s,
// section length < min_section_s, fold period >= max_fold_s) are evaluated on
// the running double sum in sample order, as the core defines them: a window
// of 40 steps of 0.5 ms is 0.02 s only up to rounding, so another summation
// could flip such a decision on the last bit. Per-interval quantities (dt with
// skipped time, mean velocity, dv, interval force) use the documented
// formulas in double, so band membership and the quasi-steady test are the
// core's exactly. Every value that enters the statistics is summed
// independently (long double, in array order).
//
// The solve step is shared on purpose (analysis::solve_bands / solve_paper):
// this reference checks the bookkeeping, not the solver.
#pragma once

#include <vector>

#include "feedid/feedid.hpp"

namespace feedid::host {

using BatchStatistics = feedid::Estimator<double>::Stats;
using BatchLayout = feedid::Estimator<double>::Layout;

/// Everything the batch recomputation produces.
struct BatchResult {
  BatchStatistics stats{};      ///< the sums (each Sum holds the long double total in .value)
  /// Same layout: every Sum holds the sum of the magnitudes of its terms
  /// (|term|, products as |a|*|b| of magnitude sums). A scale for comparing
  /// sums that cancel (dvel, force near reversals): rounding error of any
  /// summation order is bounded by a small multiple of eps * magnitude.
  BatchStatistics magnitude{};
  feedid::Diagnostics diagnostics{};
  BatchLayout layout{};
  feedid::Config<double> config{};  ///< with defaults resolved (section_enter)
};

/// Throws std::invalid_argument if the configuration is invalid (the core's init() would refuse it).
BatchResult batch_compute(const std::vector<feedid::Sample<double>>& samples, const feedid::Config<double>& cfg);

/// The statistics Estimator<double> holds after pushing `samples` and solve().
BatchStatistics batch_statistics(const std::vector<feedid::Sample<double>>& samples,
                                 const feedid::Config<double>& cfg, feedid::Diagnostics* diag = nullptr);

/// batch_statistics() followed by the core's solver for `method`. `status`, if
/// given, receives the solver's status.
feedid::Estimate<double> batch_estimate(const std::vector<feedid::Sample<double>>& samples,
                                        const feedid::Config<double>& cfg, feedid::Method method,
                                        feedid::Status* status = nullptr);

}  // namespace feedid::host
