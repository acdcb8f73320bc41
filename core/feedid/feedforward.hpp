// Friction feed-forward for the drive's setpoint path: the friction the
// identified model predicts at the reference velocity, plus m*a_ref if
// asked, from an estimate or from a speed -> force table (the form CNCs
// take). Freestanding, fixed memory, no heap.
//
//   feedid::FeedforwardConfig<float> ff{0.002f, 0.0f};   // 2 mm/s zero band, friction only
//   if (feedid::check_feedforward(ff) != feedid::Status::ok) ...
//   const feedid::EstimateFriction<float> model{axis.estimate()};
//   u_cmd += feedid::feedforward(model, ff, v_ref, a_ref);   // each servo period (ISR)
#pragma once

#include "feedid/types.hpp"
#include "feedid_port/math.hpp"

namespace feedid {

/// Friction magnitude (N) of one direction at a speed >= 0 (m/s): the model
/// of types.hpp, Fc + Fs exp(-(s/vs)^2) + sigma s. No dip without a vs.
template <typename T> T friction_magnitude(const DirectionEstimate<T>& d, T speed_m_s) {
  T dip = T(0);
  if (d.stribeck_velocity_m_s > T(0)) {
    const T r = speed_m_s / d.stribeck_velocity_m_s;
    dip = d.breakaway_N * port::exp(-r * r);
  }
  return d.coulomb_N + dip + d.viscous_Ns_m * speed_m_s;
}

/// The friction of an estimate, as a feed-forward reads it.
template <typename T> struct EstimateFriction {
  const Estimate<T>& estimate;
  /// dir 0: moving positive, 1: negative; speed >= 0 (m/s). Magnitude (N).
  T magnitude(int dir, T speed_m_s) const { return friction_magnitude(dir == 0 ? estimate.pos : estimate.neg, speed_m_s); }
};

/// A speed -> friction table per direction, positive magnitudes, at most
/// Points breakpoints; speeds start at 0 and increase. Linear between
/// breakpoints, and beyond the last along the last segment (the viscous
/// slope continues).
template <typename T, int Points> struct FrictionTable {
  static_assert(Points >= 2, "a table needs two points per direction");
  T speed_m_s[2][Points] = {};
  T force_N[2][Points] = {};
  int count[2] = {0, 0};

  T magnitude(int dir, T speed_m_s_in) const {
    const T* s = speed_m_s[dir];
    const T* f = force_N[dir];
    int hi = 1;  // the segment [hi-1, hi] that holds the speed, or the last one
    while (hi < count[dir] - 1 && s[hi] < speed_m_s_in) ++hi;
    const T w = (speed_m_s_in - s[hi - 1]) / (s[hi] - s[hi - 1]);
    return f[hi - 1] + w * (f[hi] - f[hi - 1]);
  }
};

/// Invalid_config unless each direction has 2..Points breakpoints whose
/// speeds start at 0 and increase, with finite forces.
template <typename T, int Points> Status check_table(const FrictionTable<T, Points>& t) {
  for (int d = 0; d < 2; ++d) {
    if (t.count[d] < 2 || t.count[d] > Points || !(t.speed_m_s[d][0] == T(0))) return Status::invalid_config;
    for (int k = 0; k < t.count[d]; ++k) {
      if (!port::is_finite(t.force_N[d][k]) || !port::is_finite(t.speed_m_s[d][k])) return Status::invalid_config;
      if (k > 0 && !(t.speed_m_s[d][k] > t.speed_m_s[d][k - 1])) return Status::invalid_config;
    }
  }
  return Status::ok;
}

template <typename T> struct FeedforwardConfig {
  /// Below this reference speed (m/s, > 0) the friction force goes linearly
  /// through zero instead of switching sign: a reference that dithers at
  /// standstill then moves the command by at most F_pos + F_neg across the
  /// band, never in a step.
  T zero_band_m_s = T(0);
  T mass_kg = T(0);  ///< m of m*a_ref (kg, >= 0); 0: friction only
};

/// Invalid_config unless zero_band_m_s > 0 and mass_kg >= 0, both finite.
template <typename T> Status check_feedforward(const FeedforwardConfig<T>& c) {
  const bool ok = port::is_finite(c.zero_band_m_s) && c.zero_band_m_s > T(0) && port::is_finite(c.mass_kg) &&
                  c.mass_kg >= T(0);
  return ok ? Status::ok : Status::invalid_config;
}

/// Feed-forward force (N) for the reference velocity (m/s) and acceleration
/// (m/s^2). Outside the zero band: sign(v) F_dir(|v|) + m a. Inside it, the
/// straight line from -F_neg(band) at -band to +F_pos(band) at +band, so
/// the force is continuous through v = 0. Friction: EstimateFriction or a
/// FrictionTable. Always finite: where the force would not be (a NaN or
/// infinite reference, a model or table that is not finite, an unchecked
/// config), it is 0, the command without feed-forward, so that one corrupt
/// reference never reaches the current loop. Constant time, no state:
/// callable from the servo ISR.
template <typename T, class Friction>
T feedforward(const Friction& friction, const FeedforwardConfig<T>& c, T v_ref, T a_ref) {
  const T band = c.zero_band_m_s;
  T f;
  if (v_ref >= band) {
    f = friction.magnitude(0, v_ref);
  } else if (v_ref <= -band) {
    f = -friction.magnitude(1, -v_ref);
  } else {
    const T up = friction.magnitude(0, band), down = friction.magnitude(1, band);
    f = -down + (v_ref + band) * (up + down) / (T(2) * band);
  }
  const T out = f + c.mass_kg * a_ref;
  return port::is_finite(out) ? out : T(0);
}

}  // namespace feedid
