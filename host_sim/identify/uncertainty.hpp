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
#include <memory>
#include <vector>

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
  std::array<double, 9> cutoff_se{};      ///< spread over the velocity cut-offs the data cannot tell apart
  std::array<double, 9> model_se{};       ///< what the core reported
};

/// Each parameter's spread over the velocity cut-offs that the block
/// residual could not tell from the chosen one (Signals::
/// velocity_filter_rivals_hz): the RMS of its change when the core's
/// velocity is derived at each of them instead; 0 without rivals. Which
/// cut-off fits best is itself an estimate, and on a short, slow log
/// (200 Hz SysId) the mass moved by half between two such cut-offs. Each
/// rival keeps the friction law chosen on the data (`refitted`: the
/// directions refitted with Coulomb + viscous), as the jackknife does.
/// Whole-trace identification only: the streamed one has no term for it.
std::array<double, 9> cutoff_standard_errors(const Signals& s, const feedid::Config<double>& cfg, feedid::Method method,
                                             const std::array<double, 9>& theta, const std::array<bool, 2>& refitted);

/// Replaces the standard errors of r.estimate by sqrt(jackknife^2 + timing^2 + cut-off^2)
/// (the core's own where the jackknife could not run) and re-applies the
/// core's identifiability rules to them.
Uncertainty widen_standard_errors(IdentifyResult& r, const IdentifyOptions& opt);
/// Which directions' friction is model selection's Coulomb + viscous refit.
std::array<bool, 2> refitted_directions(const IdentifyResult& r);

/// Each parameter's timing term: its sensitivity to the force lag (one
/// identification of s at a probe lag) times the lag's uncertainty, which
/// goes to lag_se_periods (0 for a stated lag).
std::array<double, 9> timing_standard_errors(const Signals& s, const feedid::Config<double>& cfg, feedid::Method method,
                                             const std::array<double, 9>& theta, double& lag_se_periods);

/// Delete-one-group jackknife over cores that each saw one group of the
/// data: sqrt((K-1)/K sum (theta_-i - mean)^2), theta_-i solved from the
/// pooled statistics of the others. `se` gets it; returns the solves that
/// succeeded (0 when fewer than half did).
/// refitted[d]: direction d's full estimate is the Coulomb + viscous refit
/// of model selection, and each delete-one solve is refitted the same way,
/// so the spread is that of the reported law.
/// C: Core, or BandsCore for the bands method.
template <typename C>
int jackknife_over(const std::vector<std::unique_ptr<C>>& groups, feedid::Method method, std::array<double, 9>& se,
                   const std::array<bool, 2>& refitted = {false, false});
extern template int jackknife_over(const std::vector<std::unique_ptr<Core>>&, feedid::Method, std::array<double, 9>&,
                                   const std::array<bool, 2>&);
extern template int jackknife_over(const std::vector<std::unique_ptr<BandsCore>>&, feedid::Method, std::array<double, 9>&,
                                   const std::array<bool, 2>&);

/// The rule of widen_standard_errors, applied to an estimate: resolved
/// parameters take sqrt(jackknife^2 + timing^2) (the core's own when
/// chunks_used is 0), unresolved keep at least the core's; then the
/// identifiability flags those standard errors imply.
void apply_standard_errors(feedid::Estimate<double>& e, const Uncertainty& u);

}  // namespace feedid::host
