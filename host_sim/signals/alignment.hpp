// Force/velocity timing found from the data (NOTES.md, "Logging
// conventions"). A drive's log does not say whether its force is a held
// command, an instantaneous sample or a period average, nor how its velocity
// was filtered; each shifts force against motion by a fraction of a period
// and biases the parameters. This measures the velocity column against
// the position and applies a force lag; the searches that need the core
// are identify/timing_search.hpp. Host only.
#pragma once
#include <limits>
#include <string>

#include <vector>

#include "signals/condition.hpp"

namespace feedid::host {

/// Lag of the logged velocity behind the backward difference of the logged
/// position, plus that difference's own half period (sample periods): 0.5 for
/// a velocity that is the position difference, about (k+1)/2 for a k-sample
/// moving average. NaN without a usable position column.
double estimate_velocity_lag(const Signals& s);

/// Gain of the velocity column against the position: the slope of the
/// integrated column on the position within windows of about a second,
/// each with its own offset (a filter's delay of a few periods and the
/// encoder's counts hardly move it). 1 for a column in the position's unit
/// per second; -1 for one of the other sign, 9.55 for rpm beside rad, 1000
/// for mm/s beside m. NaN without motion or a position column.
double velocity_column_gain(const Signals& s);

/// Whether a column of that gain is the position's derivative: within a
/// factor kVelocityColumnGainTolerance either way (no unit pair is that
/// close; a low-pass column stays near 1 at the motion's frequencies), or
/// not known (NaN).
constexpr double kVelocityColumnGainTolerance = 1.25;
bool velocity_column_agrees(double gain);

/// v and x of `from` delayed by `delay` whole samples into `to`, which has
/// the other columns of `from` (`to` may be `from`); a source across a time
/// gap is not taken.
void delay_motion(const Signals& from, int delay, Signals& to);
/// The whole samples a positive lag delays the motion by (0 otherwise).
int whole_delay_for(double lag_samples);

/// Sets the lag of `s` (periods): a positive lag delays v and x by whole
/// samples so that what is left for the core's pairing rule is in [-5, 0].
void apply_force_lag(Signals& s, double lag_samples);

/// Nearest named force convention ("held", "instant", "averaged") given the
/// force lag behind velocity and the velocity's own lag (periods); "none"
/// when the force delay is more than a quarter period from all three.
std::string nearest_force_convention(double force_lag_samples, double velocity_lag_samples);

}  // namespace feedid::host
