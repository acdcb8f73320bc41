// Baseline identifiers that the benchmark (feedid bench, docs/benchmarks.md)
// runs side by side with the streaming core, on the same trace and for the
// same nine parameters. Host only; none of this goes into core/.
//
//   batch_lm  nonlinear least squares over every moving sample, Eigen's
//             Levenberg-Marquardt (unsupported/Eigen/NonLinearOptimization,
//             row-by-row "optimum storage" variant);
//   ga        differential evolution over the nine parameters, the global
//             optimiser the seed paper compares against (it used a GA);
//   rls       recursive least squares with forgetting on the part that is
//             linear in the parameters, with a bank of parallel filters over
//             candidate Stribeck velocities.
//
// The batch methods minimise the equation error of every moving sample
// interval [t_{k-1}, t_k],
//   r_k = u_k - m a_k - F(v_k; theta),
// with v_k the interval's mean velocity, a_k = (v_k - v_{k-1}) / dt the
// velocity difference across it (a central difference about its midpoint)
// and u_k the interval's force by the same alignment rule the core uses
// (docs/method.md section 1). Optionally (filter_hz > 0) velocity and force
// are first low-passed by a zero-phase 4th-order Butterworth. Samples with |v| < velocity_min (the
// core's, from auto_config) or a reversal inside the interval are left out:
// F(v) has a sign discontinuity at v = 0 and stiction is not described by it.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "sim/drive_sim.hpp"
#include "identify/identify.hpp"
#include "io/trace.hpp"

namespace feedid::host {

/// How the bench conditions `trace` for every method. Default: as identify
/// does, the force lag and the velocity cut-off searched. `stated`: both
/// stated as a user who knows the drive would (--alignment held-backward,
/// the simulator's held command; --velocity-filter-hz at 0.4/sqrt(2) of the
/// rate, the top of the scan but one), so that the two runs tell what the
/// searches cost every method (docs/benchmarks.md, issue 29).
IdentifyOptions bench_identify_options(const Trace& trace, bool stated);

/// The nine parameters in a fixed order: m, sigma+, Fc+, Fs+, vs+, sigma-, Fc-, Fs-, vs-.
using ParamVector = std::array<double, 9>;
extern const char* const kParamNames[9];
ParamVector param_vector(const DriveParams& p);

/// Largest |estimate/truth - 1| over the nine parameters; `worst` (optional)
/// receives the index into kParamNames.
double max_rel_error(const DriveParams& estimate, const DriveParams& truth, int* worst = nullptr);

/// R^2 of the identified friction curve against the true one (the paper's
/// accuracy figure), per direction on 200 log-spaced speeds from v_lo to
/// v_hi (m/s); returns the smaller of the two directions.
double friction_curve_r2(const DriveParams& estimate, const DriveParams& truth, double v_lo, double v_hi);

struct BaselineOptions {
  /// Cut-off (Hz) of a zero-phase 4th-order Butterworth on velocity and
  /// force before the acceleration is taken (batch_lm, ga); capped at 0.4 x
  /// sample rate. 0 (the default): no low-pass, the acceleration is the
  /// plain difference across each interval -- on the benchmark's drives
  /// every low-pass cut-off tried smeared the few-sample Stribeck
  /// transitions more than it removed noise (docs/benchmarks.md, sweep).
  double filter_hz = 0.0;
  /// Samples slower than this (m/s) are left out; 0 = the core's choice (auto_config).
  double velocity_min_m_s = 0.0;
  /// The signals' conventions stated, not searched (bench_identify_options).
  bool stated_conventions = false;

  // batch_lm
  int lm_max_evaluations = 200;   ///< MINPACK maxfev: residual-vector evaluations
  /// Start of batch_lm: false = linear_start() (Fs, vs from the low-speed
  /// residual); true = the plain textbook guess: linear least squares with
  /// Fs = 0, then Fs = 0.2 Fc and vs = median moving speed.
  bool lm_naive_start = false;
  double lm_tolerance = 1e-10;    ///< ftol = xtol

  // ga: differential evolution DE/rand/1/bin, F = 0.6, CR = 0.9
  int ga_population = 36;
  int ga_generations = 150;       ///< budget = population x (generations + 1) cost evaluations
  std::uint64_t ga_seed = 1;

  // rls
  double rls_memory_s = 60.0;     ///< forgetting factor lambda = 1 - dt / rls_memory_s
  int rls_filters = 16;           ///< parallel filters, log grid of vs over the core's search range
  double rls_initial_covariance = 1e6;  ///< P0 = this x identity

  std::function<void(double)> progress;  ///< fraction done, optional
};

struct BaselineResult {
  std::string method;             ///< "batch_lm", "ga" or "rls"
  bool ok = false;                ///< an estimate was produced
  bool converged = false;         ///< the method's own convergence test was met
  std::string status;             ///< why it stopped, readable
  DriveParams params{};           ///< the estimate
  DriveParams start{};            ///< batch_lm: starting point; ga: centre of the search box
  double seconds = 0.0;           ///< wall time from the trace to the estimate (s)
  std::size_t rows = 0;           ///< samples that entered the fit
  long evaluations = 0;           ///< full passes over the rows (residual or cost evaluations)
  long iterations = 0;            ///< LM iterations / GA generations / RLS updates
  std::size_t working_bytes = 0;  ///< arrays the method holds while fitting (bytes), analytic
  std::size_t state_bytes = 0;    ///< state carried from sample to sample (rls), bytes
  double rms_residual_N = 0.0;    ///< RMS of u - m a - F(v) over the rows at the estimate (N); 0 for rls
};

/// Rows of the batch fit (exposed for tests and plots): positive-direction
/// rows first, then negative.
struct RegressionRows {
  std::vector<double> v, a, u;    ///< m/s, m/s^2, N
  std::size_t n_pos = 0;
  double velocity_min_m_s = 0.0, velocity_max_m_s = 0.0;
  double stribeck_lo_m_s = 0.0, stribeck_hi_m_s = 0.0;  ///< the core's Stribeck search range for this trace
  double filter_hz = 0.0;         ///< cut-off actually used
  double sample_rate_hz = 0.0;
};
RegressionRows regression_rows(const Trace& trace, const BaselineOptions& opt);

/// The signals of a trace the bench apparatus simulated itself: one that
/// does not condition is the apparatus's bug, not an input to report, so
/// it throws std::logic_error.
Signals simulated_signals(const Trace& trace, const IdentifyOptions& io);

/// The sensible start shared by batch_lm and ga: linear least squares for
/// m, Fc+-, sigma+- with Fs = 0, then per direction Fs and vs read off the
/// low-speed residual (its largest band mean, and the speed where it falls
/// to 1/e of that).
DriveParams linear_start(const RegressionRows& rows);
/// The plain guess: linear least squares with Fs = 0, Fs = 0.2 Fc, vs = median |v| of the rows.
DriveParams naive_start(const RegressionRows& rows);

BaselineResult batch_lm(const Trace& trace, const BaselineOptions& opt);
BaselineResult genetic_algorithm(const Trace& trace, const BaselineOptions& opt);
BaselineResult recursive_least_squares(const Trace& trace, const BaselineOptions& opt);

}  // namespace feedid::host
