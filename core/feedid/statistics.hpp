// The fixed-memory sufficient statistics that solve() works from, and the
// velocity band layout they are binned on. Everything the estimator keeps
// about the past is in Statistics: its size is a compile-time function of
// the band and candidate counts, never of the number of samples or sections.
#pragma once

#include "feedid/types.hpp"
#include "feedid_port/math.hpp"

namespace feedid {

/// Compensated (Neumaier) running sum. Totals are folded from per-section
/// partial sums, so each total sees only a few thousand additions per hour;
/// compensation keeps float totals at double-like accuracy anyway.
template <typename T> struct Sum {
  T value = T(0);
  T carry = T(0);
  void add(T x) {
    const T t = value + x;
    if (port::abs(value) >= port::abs(x)) carry += (value - t) + x;
    else carry += (x - t) + value;
    value = t;
  }
  T get() const { return value + carry; }
};

/// Log-spaced velocity bands over [velocity_min, velocity_max], the same for
/// both directions (on |v|). Log spacing puts narrow bands where the
/// Stribeck exponential bends and wide ones where friction is linear.
template <typename T, int Bands> struct BandLayout {
  static_assert(Bands >= 8, "need at least 8 bands to fit four friction parameters");
  T edge[Bands + 1] = {};    ///< edge[j] <= |v| < edge[j+1] is band j (m/s)
  T center[Bands] = {};      ///< geometric centre (m/s): expansion point of projections

  void init(T v_min, T v_max) {
    const T ratio = port::exp(port::log(v_max / v_min) / T(Bands));
    edge[0] = v_min;
    for (int j = 1; j <= Bands; ++j) edge[j] = edge[j - 1] * ratio;
    edge[Bands] = v_max;
    for (int j = 0; j < Bands; ++j) center[j] = port::sqrt(edge[j] * edge[j + 1]);
  }

  /// Band of a speed |v| >= edge[0]: binary search, ~log2(Bands) compares.
  /// Speeds above the top edge go to the top band. Context: ISR-safe.
  int index(T speed) const {
    int lo = 0, hi = Bands;  // invariant: edge[lo] <= speed, answer < hi
    while (hi - lo > 1) {
      const int mid = (lo + hi) / 2;
      if (speed >= edge[mid]) lo = mid;
      else hi = mid;
    }
    return lo;
  }
};

/// Per band and direction, over every valid interval with |v| >= velocity_min.
/// Negative-direction quantities are mirrored (u -> -u, v -> |v|, dv -> -dv)
/// so both directions share the form  u' = m a' + Fc + Fs e(|v|) + sigma |v|.
template <typename T> struct BandSums {
  Sum<T> time_s;        ///< integral dt
  Sum<T> speed;         ///< integral |v| dt        (m)
  Sum<T> speed2;        ///< integral v^2 dt        (m^2/s)
  Sum<T> force;         ///< integral u' dt         (N s)
  Sum<T> dvel;          ///< sum of dv' inside the band (m/s): residual inertia m*dvel
  // Mass windows projected on their velocity change dv'_w (see mass_equation()):
  Sum<T> proj_time;     ///< sum_w dv'_w * integral_w dt
  Sum<T> proj_speed;    ///< sum_w dv'_w * integral_w |v| dt
  Sum<T> proj_speed2;   ///< sum_w dv'_w * integral_w v^2 dt
};

/// Per direction, the scalars of the window mass equation and the paper method.
template <typename T, int Candidates> struct DirectionSums {
  // Window mass equation: integral_w u' dt = m dv'_w + integral_w F dt.
  Sum<T> win_dv_force;     ///< sum_w dv'_w * integral_w u' dt
  Sum<T> win_dv2;          ///< sum_w dv'_w^2
  Sum<T> win_tau_dv2;      ///< sum_w tau_w * dv'_w^2 (for the mass standard error)
  // Paper method, one point per complete section s (plain sums over sections):
  Sum<T> sec_xy;           ///< sum_s X_s Y_s with Y_s = integral u a dt, X_s = integral a^2 dt
  Sum<T> sec_xx;           ///< sum_s X_s^2
  Sum<T> sec_yy;           ///< sum_s Y_s^2
  Sum<T> sec_tt, sec_tv, sec_vv, sec_tu, sec_vu, sec_uu;  ///< over T_s, V_s, U_s
  Sum<T> cand_et[Candidates], cand_ev[Candidates], cand_eu[Candidates], cand_ee[Candidates];
  uint32_t sections = 0;
};

template <typename T, int Bands, int Candidates> struct Statistics {
  BandSums<T> band[2][Bands];             ///< [0] positive, [1] negative direction
  DirectionSums<T, Candidates> dir[2];
  Sum<T> noise_d2;                        ///< sum (u_k - 2u_{k-1} + u_{k-2})^2  (N^2)
  uint64_t noise_count = 0;
  Sum<T> total_interval_time;             ///< sum of accepted interval lengths (s)
  uint64_t interval_count = 0;
  T vs_candidate[Candidates] = {};        ///< paper method's bank (m/s), fixed at init
};

/// integral exp(-(v/vs)^2) dt over a band from its moments about the band
/// mean (second-order Taylor). Exact for the linear terms; the neglected
/// third-order term is below 1e-3 of Fs for bands of <= 30 % relative width.
template <typename T> T exp_integral_moments(T time, T speed, T speed2, T vs) {
  if (!(time > T(0))) return T(0);
  const T mean = speed / time;
  const T var = port::max(T(0), speed2 / time - mean * mean);
  const T inv_vs2 = T(1) / (vs * vs);
  const T x2 = mean * mean * inv_vs2;
  const T f = port::exp(-x2);
  // f''/2 = f (2 v^2/vs^4 - 1/vs^2)
  const T corr = T(1) + var * inv_vs2 * (T(2) * x2 - T(1));
  return time * f * port::max(T(0), corr);
}

/// The same integral for window-projected sums, expanded about a fixed band
/// centre so that it stays linear in (time, speed, speed2) and can be applied
/// to sums of dv'_w-weighted window moments.
template <typename T> T exp_integral_about(T center, T time, T speed, T speed2, T vs) {
  const T inv_vs2 = T(1) / (vs * vs);
  const T x2 = center * center * inv_vs2;
  const T f = port::exp(-x2);
  const T d1 = -T(2) * center * inv_vs2 * f;                 // f'(c)
  const T d2h = f * inv_vs2 * (T(2) * x2 - T(1));            // f''(c)/2
  const T m1 = speed - center * time;                        // integral (v-c)
  const T m2 = speed2 - T(2) * center * speed + center * center * time;  // integral (v-c)^2
  return f * time + d1 * m1 + d2h * m2;
}

}  // namespace feedid
