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
  // Fast lookup (index()): est = ((key(|v|) - fast_base) * fast_mul + fast_add) >> 40
  // is the band or the band above it, for every |v| >= edge[0]; fast_mul == 0
  // if init() could not guarantee that (a velocity range of a few octaves only).
  typename port::detail::FloatBits<T>::UInt fast_base = 0;  ///< key(edge[0])
  uint32_t fast_mul = 0;
  uint64_t fast_add = 0;

  void init(T v_min, T v_max) {
    const T ratio = port::exp(port::log(v_max / v_min) / T(Bands));
    edge[0] = v_min;
    for (int j = 1; j <= Bands; ++j) edge[j] = edge[j - 1] * ratio;
    edge[Bands] = v_max;
    init_fast(T(Bands) * T(0.6931471805599453) / port::log(v_max / v_min));
  }

  /// Geometric centre of band j (m/s): expansion point of projections.
  /// Computed when asked (solve() only), not stored: 4 bytes per band of RAM.
  T center(int j) const { return port::sqrt(edge[j] * edge[j + 1]); }

  /// Band of a speed |v| >= edge[0]; speeds above the top edge go to the top
  /// band: the largest j < Bands with edge[j] <= speed. Context: ISR-safe.
  int index(T speed) const {
    if (fast_mul != 0) {
      // The bit pattern of a positive float is, to within 0.09, 2^23 log2 of
      // it plus a constant, and it grows with the value: est is a monotone
      // approximation of the band coordinate, which init_fast() has checked
      // to be the band or one above at every band edge, hence everywhere.
      // One exact comparison decides. About 10 instructions, no loop.
      const uint64_t est = ((key(speed) - fast_base) * uint64_t(fast_mul) + fast_add) >> 40;
      const int j = est < uint64_t(Bands - 1) ? static_cast<int>(est) : Bands - 1;
      return speed < edge[j] ? j - 1 : j;
    }
    int lo = 0, hi = Bands;  // binary search; invariant: edge[lo] <= speed, answer < hi
    while (hi - lo > 1) {
      const int mid = (lo + hi) / 2;
      if (speed >= edge[mid]) lo = mid;
      else hi = mid;
    }
    return lo;
  }

 private:
  using Bits = port::detail::FloatBits<T>;
  /// Top bits of the representation (sign 0, exponent, 23 mantissa bits):
  /// non-decreasing in x >= 0 and below 2^36, so products with fast_mul < 2^24 fit.
  static uint64_t key(T x) {
    return static_cast<uint64_t>(port::detail::to_bits(x) >> (Bits::mantissa_bits - 23));
  }
  using Key = typename Bits::UInt;

  /// Chooses fast_mul (bands per unit of key, scaled by 2^40) and the
  /// smallest offset fast_add with est(edge[j]) >= j for every band j, then
  /// checks est <= j + 1 just below edge[j+1]. est and the band are both
  /// non-decreasing in the speed, so these checks at the edges bound
  /// band <= est <= band + 1 everywhere. Otherwise fast_mul stays 0.
  void init_fast(T bands_per_log2) {
    fast_base = static_cast<Key>(key(edge[0]));
    fast_mul = 0;
    fast_add = 0;
    const T mul = bands_per_log2 * T(131072);  // 2^(40 - 23)
    if (!(mul >= T(1) && mul < T(16777216))) return;
    const uint64_t m = static_cast<uint32_t>(mul);
    const int64_t one = int64_t(1) << 40;
    int64_t lo = 0, hi = int64_t(1) << 62;
    for (int j = 0; j < Bands; ++j) {
      const int64_t at_edge = static_cast<int64_t>((key(edge[j]) - fast_base) * m);
      if (j * one - at_edge > lo) lo = j * one - at_edge;
      if (j + 1 < Bands) {
        const T below = port::detail::from_bits<T>(port::detail::to_bits(edge[j + 1]) - 1);
        const int64_t at_below = static_cast<int64_t>((key(below) - fast_base) * m);
        if ((j + 2) * one - 1 - at_below < hi) hi = (j + 2) * one - 1 - at_below;
      }
      if (j > 0 && !(edge[j] > edge[j - 1])) return;  // edges must increase
    }
    if (lo > hi) return;
    fast_mul = static_cast<uint32_t>(m);
    fast_add = static_cast<uint64_t>(lo);
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

/// Calls f(x, y) for every running sum x of `a` and the same sum y of `b`
/// (the one list of them; a and b of the same configuration, either may be
/// const, and they may be one object). Counters and the candidate bank are not sums and are left out.
template <typename A, typename B, typename F> void visit_sums(A& a, B& b, F&& f) {
  for (int d = 0; d < 2; ++d) {
    for (int j = 0; j < static_cast<int>(sizeof a.band[d] / sizeof a.band[d][0]); ++j) {
      auto& x = a.band[d][j];
      auto& y = b.band[d][j];
      f(x.time_s, y.time_s), f(x.speed, y.speed), f(x.speed2, y.speed2), f(x.force, y.force), f(x.dvel, y.dvel);
      f(x.proj_time, y.proj_time), f(x.proj_speed, y.proj_speed), f(x.proj_speed2, y.proj_speed2);
    }
    auto& x = a.dir[d];
    auto& y = b.dir[d];
    f(x.win_dv_force, y.win_dv_force), f(x.win_dv2, y.win_dv2), f(x.win_tau_dv2, y.win_tau_dv2);
    f(x.sec_xy, y.sec_xy), f(x.sec_xx, y.sec_xx), f(x.sec_yy, y.sec_yy), f(x.sec_tt, y.sec_tt);
    f(x.sec_tv, y.sec_tv), f(x.sec_vv, y.sec_vv), f(x.sec_tu, y.sec_tu), f(x.sec_vu, y.sec_vu), f(x.sec_uu, y.sec_uu);
    for (int i = 0; i < static_cast<int>(sizeof x.cand_et / sizeof x.cand_et[0]); ++i)
      f(x.cand_et[i], y.cand_et[i]), f(x.cand_ev[i], y.cand_ev[i]), f(x.cand_eu[i], y.cand_eu[i]), f(x.cand_ee[i], y.cand_ee[i]);
  }
  f(a.noise_d2, b.noise_d2);
  f(a.total_interval_time, b.total_interval_time);
}

/// Adds the sums of `from` into `into` (same configuration: the candidate
/// bank of `into` is kept). Statistics are plain sums, so the statistics of
/// two stretches of data are their sum: the host forms delete-one-chunk
/// jackknife sets this way; a controller may pool axes or sessions.
template <typename T> void add_sum(Sum<T>& into, const Sum<T>& from) {
  into.add(from.value);
  into.add(from.carry);
}
template <typename T, int Bands, int C>
void add_statistics(Statistics<T, Bands, C>& into, const Statistics<T, Bands, C>& from) {
  visit_sums(into, from, [](Sum<T>& x, const Sum<T>& y) { add_sum(x, y); });
  for (int d = 0; d < 2; ++d) into.dir[d].sections += from.dir[d].sections;
  into.noise_count += from.noise_count;
  into.interval_count += from.interval_count;
}

/// True when every running sum is finite: inputs each within range can
/// still overflow a sum of squares (solve() then reports numerical_error).
template <typename T, int Bands, int C> bool finite_statistics(const Statistics<T, Bands, C>& s) {
  T z = T(0);  // (x - x) is 0 for a finite x and NaN otherwise; a sum of them is NaN iff one is
  visit_sums(s, s, [&z](const Sum<T>& x, const Sum<T>&) { z += (x.value - x.value) + (x.carry - x.carry); });
  return z == z;
}

/// exp_integral_moments() from the band's time > 0, squared mean speed
/// mean2 = (speed/time)^2, variance var = max(0, speed2/time - mean2) and
/// inv_vs2 = 1/vs^2: the same operations, for callers that evaluate many vs
/// on one band.
template <typename T> T exp_integral_mean_var(T time, T mean2, T var, T inv_vs2) {
  const T x2 = mean2 * inv_vs2;
  // Far above vs the band's share, exp(-x2) even with the variance term
  // (< 0.2 x2^2 for bands of <= 30 % width), is below the rounding of the
  // band's time in T (float 25: < 2e-9; double 50: < 1e-19): skip the exp.
  // Most bands of a Stribeck search sit there.
  if (x2 > T(sizeof(T) == 4 ? 25 : 50)) return T(0);
  const T f = port::exp(-x2);
  // f''/2 = f (2 v^2/vs^4 - 1/vs^2)
  const T corr = T(1) + var * inv_vs2 * (T(2) * x2 - T(1));
  return time * f * port::max(T(0), corr);
}

/// integral exp(-(v/vs)^2) dt over a band from its moments about the band
/// mean (second-order Taylor). Exact for the linear terms; the neglected
/// third-order term is below 1e-3 of Fs for bands of <= 30 % relative width.
template <typename T> T exp_integral_moments(T time, T speed, T speed2, T vs) {
  if (!(time > T(0))) return T(0);
  const T mean = speed / time;
  return exp_integral_mean_var(time, mean * mean, port::max(T(0), speed2 / time - mean * mean),
                               T(1) / (vs * vs));
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
