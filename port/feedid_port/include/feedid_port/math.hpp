// Elementary functions for the freestanding core: <cmath> is not part of a
// freestanding C++ implementation, and on a Cortex-M4F a libm call to the
// double-precision exp would drag software floating point into the firmware.
// These are range-reduced polynomials, templated on the scalar so float code
// stays in float. Accuracy (checked on host against <cmath> in
// tests/core/port_math_test.cpp over the ranges the core uses):
//   exp: relative error < 2e-15 (double), < 3e-7 (float) for x in [-80, 80]
//   log: absolute error < 2e-15 (double), < 3e-7 (float) times max(1, |ln x|)
//        for x in [1e-30, 1e30] (the spacing of the results themselves grows with |ln x|)
//   sqrt: relative error < 1e-15 (double), < 2e-7 (float)
// Context: any (no state, no allocation); safe in an ISR.
#pragma once

#include <stdint.h>

namespace feedid::port {

namespace detail {
template <typename T> struct FloatBits;
template <> struct FloatBits<float> {
  using UInt = uint32_t;
  static constexpr int mantissa_bits = 23;
  static constexpr int exponent_bias = 127;
  static constexpr int max_exponent = 127;
  static constexpr uint32_t exponent_mask = 0xFFu;
};
template <> struct FloatBits<double> {
  using UInt = uint64_t;
  static constexpr int mantissa_bits = 52;
  static constexpr int exponent_bias = 1023;
  static constexpr int max_exponent = 1023;
  static constexpr uint64_t exponent_mask = 0x7FFu;
};

template <typename T> typename FloatBits<T>::UInt to_bits(T x) {
  typename FloatBits<T>::UInt u;
  __builtin_memcpy(&u, &x, sizeof u);
  return u;
}
template <typename T> T from_bits(typename FloatBits<T>::UInt u) {
  T x;
  __builtin_memcpy(&x, &u, sizeof x);
  return x;
}

/// 2^k for an integer k in the normal range, built from the exponent bits.
template <typename T> T pow2i(int k) {
  using B = FloatBits<T>;
  using U = typename B::UInt;
  return from_bits<T>(static_cast<U>(static_cast<U>(k + B::exponent_bias) << B::mantissa_bits));
}
}  // namespace detail

template <typename T> constexpr bool is_nan(T x) { return x != x; }
template <typename T> constexpr bool is_finite(T x) {
  // NaN fails both comparisons; +-Inf fails one.
  return x - x == x - x;
}
/// True if a, b and c are all finite, with one test: x - x is 0 for a finite
/// x and NaN for +-Inf or NaN, and a sum of such terms is NaN exactly when one
/// of them is. (Testing is_finite(a + b + c) instead would not be safe: finite
/// fields near the top of the range can add up to Inf.)
template <typename T> constexpr bool all_finite(T a, T b, T c) {
  const T z = (a - a) + (b - b) + (c - c);
  return z == z;
}
template <typename T> constexpr T abs(T x) { return x < T(0) ? -x : x; }
// Floating-point |x| clears the sign bit: one instruction, no branch or
// select. (Differs from the generic form only for -0, which gives +0.)
constexpr float abs(float x) { return __builtin_fabsf(x); }
constexpr double abs(double x) { return __builtin_fabs(x); }
template <typename T> constexpr T min(T a, T b) { return b < a ? b : a; }
template <typename T> constexpr T max(T a, T b) { return a < b ? b : a; }
template <typename T> constexpr T clamp(T x, T lo, T hi) { return x < lo ? lo : (hi < x ? hi : x); }

/// e^x. Underflows to 0 below about -87 (float) / -708 (double), saturates above.
template <typename T> T exp(T x) {
  using B = detail::FloatBits<T>;
  constexpr T ln2 = T(0.6931471805599453094);
  constexpr T inv_ln2 = T(1.4426950408889634074);
  const T lowest = T(-(B::exponent_bias - 1)) * ln2;  // smallest normal result
  const T highest = T(B::max_exponent) * ln2;
  if (is_nan(x)) return x;
  if (x < lowest) return T(0);
  if (x > highest) x = highest;
  // x = k*ln2 + r with |r| <= ln2/2, so e^x = 2^k * e^r.
  const T kf = x * inv_ln2;
  const int k = static_cast<int>(kf < T(0) ? kf - T(0.5) : kf + T(0.5));
  // Cody-Waite split of ln2 keeps r accurate for large |k|.
  constexpr T ln2_hi = sizeof(T) == 4 ? T(0.693145752f) : T(0.693147180369123816490);
  constexpr T ln2_lo = sizeof(T) == 4 ? T(1.42860677e-6f) : T(1.90821492927058770002e-10);
  const T r = (x - T(k) * ln2_hi) - T(k) * ln2_lo;
  // Taylor series of e^r, Horner form; 7 terms suffice for float, 13 for double.
  constexpr int terms = sizeof(T) == 4 ? 7 : 13;
  T p = T(1);
  for (int n = terms; n >= 1; --n) p = T(1) + p * r / T(n);
  // Split 2^k so k near the exponent limits cannot overflow the bias.
  const int k1 = k / 2;
  return p * detail::pow2i<T>(k1) * detail::pow2i<T>(k - k1);
}

/// Natural logarithm for x > 0 (returns -huge for x <= 0, NaN for NaN).
template <typename T> T log(T x) {
  using B = detail::FloatBits<T>;
  using U = typename B::UInt;
  if (is_nan(x)) return x;
  if (!(x > T(0))) return -T(1e30) * T(1e8);  // -inf in double, large negative in float
  int e_adjust = 0;
  // Subnormals: scale into the normal range first.
  if (x < detail::pow2i<T>(-(B::exponent_bias - 1))) {
    x *= detail::pow2i<T>(B::mantissa_bits);
    e_adjust = -B::mantissa_bits;
  }
  const U bits = detail::to_bits(x);
  int e = static_cast<int>((bits >> B::mantissa_bits) & B::exponent_mask) - B::exponent_bias;
  // Mantissa m in [1, 2); fold to [sqrt(1/2), sqrt(2)) so the series converges fast.
  const U mant_mask = (U(1) << B::mantissa_bits) - 1;
  T m = detail::from_bits<T>((bits & mant_mask) | (U(B::exponent_bias) << B::mantissa_bits));
  if (m > T(1.41421356237309504880)) {
    m *= T(0.5);
    ++e;
  }
  // log m = 2 atanh(s), s = (m-1)/(m+1), |s| <= 0.1716.
  const T s = (m - T(1)) / (m + T(1));
  const T s2 = s * s;
  constexpr int terms = sizeof(T) == 4 ? 5 : 11;
  T p = T(0);
  for (int n = terms; n >= 1; --n) p = T(1) / T(2 * n - 1) + s2 * p;
  constexpr T ln2 = T(0.6931471805599453094);
  return T(2) * s * p + T(e + e_adjust) * ln2;
}

/// Square root for x >= 0 (0 for x <= 0): Newton from an exponent-halved guess.
template <typename T> T sqrt(T x) {
  if (is_nan(x)) return x;
  if (!(x > T(0))) return T(0);
  if (!is_finite(x)) return x;
  // Initial guess: halve the exponent via the log2 of the bit pattern.
  using B = detail::FloatBits<T>;
  using U = typename B::UInt;
  const U bits = detail::to_bits(x);
  const U guess = (bits >> 1) + (U(B::exponent_bias) << (B::mantissa_bits - 1));
  T y = detail::from_bits<T>(guess);
  // Quadratic convergence from a guess within ~6 %: 4 steps reach double precision.
  constexpr int steps = sizeof(T) == 4 ? 3 : 5;
  for (int i = 0; i < steps; ++i) y = T(0.5) * (y + x / y);
  return y;
}

}  // namespace feedid::port
