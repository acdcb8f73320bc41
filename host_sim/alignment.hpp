// Force/velocity timing found from the data (NOTES.md, "Logging
// conventions"). A drive's log does not say whether its force is a held
// command, an instantaneous sample or a period average, nor how its velocity
// was filtered; each shifts force against motion by a fraction of a period
// and biases the parameters. This finds the shift from the trace itself.
// Host only.
#pragma once
#include <string>

#include "identify.hpp"

namespace feedid::host {

/// Searched range of the force lag behind the logged velocity (sample periods).
constexpr double kForceLagMin = -5.0;
constexpr double kForceLagMax = 2.0;

struct LagEstimate {
  double lag_samples = 0.0;  ///< force lag behind the velocity (periods)
  double se_samples = 0.0;   ///< its standard error (periods)
  int evaluations = 0;       ///< identifications run for the search
  bool ok = false;           ///< false: no motion to judge timing by (lag left at 0)
};

/// The lag that minimises the residual of the identified model over short
/// blocks of motion (the inertia identity integral(u - F) = m dv is exact only
/// for the right pairing; a wrong one leaves about lag * (change of force)
/// in every block). Grid over [kForceLagMin, kForceLagMax], then a parabola
/// through the best point and its neighbours; the standard error from its
/// curvature and the block residual variance. `cfg` is the core
/// configuration for the trace (its lag is ignored).
LagEstimate estimate_force_lag(const Signals& s, const feedid::Config<double>& cfg);

/// Lag of the logged velocity behind the backward difference of the logged
/// position, plus that difference's own half period (sample periods): 0.5 for
/// a velocity that is the position difference, about (k+1)/2 for a k-sample
/// moving average. NaN without a usable position column.
double estimate_velocity_lag(const Signals& s);

/// Sets the lag of `s` (periods): a positive lag delays v and x by whole
/// samples so that what is left for the core's pairing rule is in [-5, 0].
void apply_force_lag(Signals& s, double lag_samples);

/// Nearest named force convention ("held", "instant", "averaged") given the
/// force lag behind velocity and the velocity's own lag (periods); "none"
/// when the force delay is more than a quarter period from all three.
std::string nearest_force_convention(double force_lag_samples, double velocity_lag_samples);

}  // namespace feedid::host
