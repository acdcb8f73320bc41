// Which logged forces belong to an interval of motion: the one pairing rule
// of the project. The core, the host pipeline, the batch oracle and the
// baselines all call it. Freestanding.
//
// Drives log force and velocity under different conventions (NOTES.md): a
// held command describes the period after its tick, a filtered current the
// period before it; a backward-difference velocity is half a period late, a
// moving average of k differences k/2 periods late. What matters to the
// model is only how far the logged force lags the logged velocity:
//
//   lag (sample periods) = delay of the force - delay of the velocity.
//
// The interval [t_{k-1}, t_k] is described by v_{k-1}, v_k; the force that
// goes with it is the trapezoid of the force signal shifted by the lag,
//   (u(k-1+lag) + u(k+lag)) / 2,   u(.) linear between samples,
// which for lag = -(n + f), n integer, 0 <= f < 1, is the three-tap filter
//   (1-f)/2 u_{k-n} + 1/2 u_{k-n-1} + f/2 u_{k-n-2}.
// Named conventions: held force with backward-difference velocity -1,
// held force with instantaneous velocity -1/2, both instantaneous 0.
// A positive lag (force later than velocity: an averaged current against a
// zero-phase velocity, or a physical delay) needs future forces: delay the
// velocity by whole samples first (docs/method.md says how).
#pragma once

#include <stdint.h>

namespace feedid {

/// Named force/velocity logging conventions (their lags are below).
enum class ForceAlignment : uint8_t {
  held_force_backward_velocity = 0,  ///< setpoint log, v = (x_k - x_{k-1})/dt: lag -1
  held_force_instant_velocity = 1,   ///< setpoint log, v at t_k (zero-phase): lag -1/2
  trapezoid = 2,                     ///< force and velocity both at t_k: lag 0
};

template <typename T> constexpr T force_lag_of(ForceAlignment a) {
  return a == ForceAlignment::held_force_backward_velocity  ? T(-1)
         : a == ForceAlignment::held_force_instant_velocity ? T(-0.5)
                                                            : T(0);
}

/// The three taps of the pairing rule for one lag, computed once at init().
template <typename T> struct ForcePairing {
  /// Forces kept (power of two): the oldest tap is at most history - 1 back.
  static constexpr int history = 8;
  /// Most negative lag the taps can reach (sample periods).
  static constexpr int max_lead = history - 3;

  // Two members only: the estimator's RAM budget counts every byte.
  T w_oldest = T(0);        ///< f/2; the newest tap weighs 1/2 - f/2, the middle one 1/2
  uint8_t newest_age = 0;   ///< n: age of the newest tap (0 = this sample)

  /// False (and taps unchanged) when the lag is not finite or outside [-max_lead, 0].
  bool init(T lag_samples) {
    if (!(lag_samples <= T(0) && lag_samples >= -T(max_lead))) return false;
    const T lead = -lag_samples;
    const int n = static_cast<int>(lead);  // lead == max_lead: n = max_lead, f = 0
    const T f = lead - T(n);
    newest_age = static_cast<uint8_t>(n);
    w_oldest = T(0.5) * f;
    return true;
  }

  /// The interval force from a function age -> logged force (age 0 is the
  /// sample that ends the interval).
  template <typename ForceAt> T interval_force(const ForceAt& force_at) const {
    return mix(force_at(newest_age), force_at(newest_age + 1), force_at(newest_age + 2));
  }

  /// The same from a contiguous history: `newest` points at the force of
  /// age 0, newest[-k] is the one k samples back (k < history).
  T interval_force_of(const T* newest) const {
    const T* const tap = newest - newest_age;
    return mix(tap[0], tap[-1], tap[-2]);
  }

  /// The same within a chain that began `oldest_age` samples ago: taps
  /// older than its start take its first force (no force from before a gap).
  template <typename ForceAt> T interval_force_in_chain(const ForceAt& force_at, int oldest_age) const {
    return interval_force([&force_at, oldest_age](int age) { return force_at(age < oldest_age ? age : oldest_age); });
  }

 private:
  /// (1/2 - w) a + b/2 + w c for the taps a (newest), b, c, with one
  /// multiply fewer on the servo path.
  T mix(T a, T b, T c) const { return T(0.5) * (a + b) + w_oldest * (c - a); }
};

}  // namespace feedid
