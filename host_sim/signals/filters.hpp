// Signal conditioning for traces that lack velocity: a zero-phase
// 4th-order Butterworth low-pass (forward-backward, like MATLAB's filtfilt)
// and central differences, as in the EMPS reference protocol. Host only.
#pragma once
#include <algorithm>
#include <string>
#include <vector>

namespace feedid::host {

/// Median time step of t (s); 0 for fewer than two samples.
double median_step(const std::vector<double>& t);

/// Longest step within one stretch of samples (s): ten median periods, at
/// least 1 ms. A longer step is a gap (another run, a cut, a logger pause)
/// that no filter, block, integral or force pairing crosses.
inline double max_step_s(double median_period_s) { return 10.0 * median_period_s > 1e-3 ? 10.0 * median_period_s : 1e-3; }

/// Zero-phase low-pass: 4th-order Butterworth (two biquads) run forward then
/// backward, so the magnitude response is squared and the phase is zero.
/// Ends are padded by odd reflection (3 cut-off periods) with the filter
/// state started at steady state, which keeps edge transients small.
std::vector<double> filtfilt_butter4(const std::vector<double>& x, double cutoff_hz, double rate_hz);

/// Central difference dy/dt at each sample ((y[k+1]-y[k-1])/(t[k+1]-t[k-1]),
/// one-sided at the ends): the derivative at t_k, without lag.
std::vector<double> central_difference(const std::vector<double>& y, const std::vector<double>& t);

/// The uniform grid at rate_hz from t.front() through t.back() that a
/// stretch logged with uneven steps is filtered on: the filter runs on
/// sample indices, so uneven time stamps (a PC-side logger: 0.3-9.8 ms
/// steps around 5 ms; rows dropped) would turn into derivative noise of the
/// size of the steps' spread. Empty when every step of t is within 1 % of
/// 1/rate_hz (or t has fewer than 3 samples): the samples are the grid.
std::vector<double> uniform_grid(const std::vector<double>& t, double rate_hz);

/// Whether every step of t is within 1 % of 1/rate_hz (or t has fewer than
/// 3 samples): the samples are their own grid (uniform_grid, clock_grid).
bool evenly_stamped(const std::vector<double>& t, double rate_hz);
/// The same on t[0, n).
bool evenly_stamped(const double* t, std::size_t n, double rate_hz);

/// The same stretch's own clock: from t.front() through t.back() in the
/// whole number of steps nearest 1/rate_hz, so that where the stamps sit
/// on a clock the grid's points sit on them and a dropped row is the one
/// slot interpolated. uniform_grid's steps of exactly 1/rate_hz drift off
/// the stamps where the clock's period is not the median step: on EMPS
/// (steps of 0.99997 and 1.000008 ms, mean 1 ms) by 0.2 periods over the
/// run, and validate's error moved by 4.7 % for one dropped row. Empty
/// where uniform_grid is.
std::vector<double> clock_grid(const std::vector<double>& t, double rate_hz);

/// y (sampled at increasing t) at time q, linear between the samples and
/// held beyond the ends.
double interpolate(const std::vector<double>& t, const std::vector<double>& y, double q);
/// The same at every time of q.
std::vector<double> resample(const std::vector<double>& t, const std::vector<double>& y, const std::vector<double>& q);

/// The cut-off a zero-phase Butterworth is applied at for a requested one
/// (Hz): at most 0.4 of the rate, where the bilinear design still passes
/// what it should (at half the rate it is undefined). What reports a
/// cut-off reports this one, and says where it differs from the request.
inline double applied_cutoff_hz(double requested_hz, double rate_hz) { return std::min(requested_hz, 0.4 * rate_hz); }
/// Why a cut-off was applied below the one requested (`filtered`: what it
/// filtered, e.g. "the position"), or empty where it was applied as asked
/// within the rate's rounding (a rate from time stamps is 1999.99999999 Hz,
/// not 2000). One text for every command that reports a cut-off.
std::string cutoff_note(double requested_hz, double applied_hz, const char* filtered);

/// Velocity from position without lag: filtfilt_butter4 at cutoff_hz, then
/// central differences, on each stretch between steps longer than
/// max_step_s (a gap between recordings), so that no filter rings across a
/// restarted clock or a jump of position; a stretch logged unevenly is
/// filtered on its uniform_grid and read back at its own times.
std::vector<double> zero_phase_velocity(const std::vector<double>& x, const std::vector<double>& t, double cutoff_hz,
                                        double rate_hz, double max_step_s);
/// The same into v, whose storage is reused: the cut-off scan derives the
/// whole log's velocity at every candidate, and fresh buffers of its length
/// (first touched page by page) cost more than the filter.
void zero_phase_velocity(const std::vector<double>& x, const std::vector<double>& t, double cutoff_hz, double rate_hz,
                         double max_step_s, std::vector<double>& v);

/// Position from a logged velocity, 0 at the start: x[k] = x[k-1] + v[k] (t[k] - t[k-1]),
/// the inverse of the backward difference, so a position-difference log
/// gives the encoder's positions back exactly and a filtered log gives the
/// position seen through the filter. A step longer than max_step_s (a gap
/// between recordings) adds nothing: no motion is invented across it.
std::vector<double> integrate_velocity(const std::vector<double>& v, const std::vector<double>& t, double max_step_s);

}  // namespace feedid::host
