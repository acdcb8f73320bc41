// Standard errors that hold on real logs (issue: coverage of estimate
// +- 1.96 se). The core's own standard errors assume white, independent
// band residuals; force noise shaped by the control loop, quantised and
// filtered velocity and a lag known only to within its own error are
// neither. The host therefore widens them with
//   * a delete-one-chunk jackknife over contiguous stretches of the trace,
//     from the core's additive statistics (one more pass over the data):
//     it sees whatever correlation and misfit the data has;
//   * a timing term: the parameters' sensitivity to the force lag times the
//     lag's uncertainty (its standard error, and no less than the accuracy
//     the lag search shows on logs of known convention, kLagAccuracy).
// docs/method.md derives both; `feedid coverage` checks them. Host only.
#pragma once
#include <array>

#include "identify.hpp"

namespace feedid::host {

/// Accuracy of an estimated lag (sample periods): the largest error of the
/// lag search on simulated logs of each convention (docs/coverage.md).
constexpr double kLagAccuracy = 0.1;

/// The nine standard errors of an estimate in the order m, sigma+, Fc+,
/// Fs+, vs+, sigma-, Fc-, Fs-, vs-.
std::array<double, 9> standard_errors(const feedid::Estimate<double>& e);
std::array<double, 9> parameters(const feedid::Estimate<double>& e);

/// What the widening found, for the JSON.
/// The timing term's probe: a second pairing this far from the estimated
/// lag (periods; well above rounding, within the lag search's parabola), on
/// the side the pairing rule can reach. Sensitivity x the lag's standard
/// error is each parameter's timing term.
constexpr double kTimingProbeStep = 0.5;
double timing_probe_lag(const Signals& s);

struct Uncertainty {
  int chunks_used = 0;                    ///< leave-one-out solves that succeeded
  std::array<double, 9> jackknife_se{};   ///< 0 where not available
  std::array<double, 9> timing_se{};      ///< sensitivity to the lag x its uncertainty
  std::array<double, 9> model_se{};       ///< what the core reported
};

/// Replaces the standard errors of r.estimate by sqrt(jackknife^2 + timing^2)
/// (the core's own where the jackknife could not run) and re-applies the
/// core's identifiability rules to them.
Uncertainty widen_standard_errors(IdentifyResult& r, const IdentifyOptions& opt);

}  // namespace feedid::host
