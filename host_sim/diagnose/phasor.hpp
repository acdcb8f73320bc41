#pragma once
// e^{i theta} without the library's sincos: the ripple family draws one per
// segment and period tried (two million on the 25 s EMPS PULSES run with a
// given model, a seventh of diagnose's time), and glibc's sincos spends
// most of each call saving and restoring the rounding mode.

#include <cmath>
#include <complex>
#include <cstddef>

namespace feedid::host::diag {

/// Above this |theta| (rad) the reduction below loses its exactness
/// (n * kPio2Hi is exact while n < 2^20), and the library is called.
constexpr double kPhasorReducedMax = 1.0e6;

/// e^{i theta} for |theta| < kPhasorReducedMax only (beyond, n no longer
/// fits the reduction or an int: reduced_or_library checks): theta reduced by n pi/2
/// (Cody and Waite, pi/2 in three parts as fdlibm's __ieee754_rem_pio2
/// splits it), then fdlibm's kernel polynomials on [-pi/4, pi/4]. Branch
/// free, so that a loop of them vectorizes (unit_phasors).
inline void reduced_unit_phasor(double theta, double& re, double& im) {
  constexpr double kTwoOverPi = 6.36619772367581382433e-01;
  constexpr double kPio2Hi = 1.57079632673412561417e+00;   // first 33 bits of pi/2
  constexpr double kPio2Mid = 6.07710050630396597660e-11;  // next 33 bits
  constexpr double kPio2Lo = 2.02226624879595063154e-21;   // the rest
  // Rounded to the nearest integer by adding and taking away 1.5 * 2^52
  // (round to nearest is the mode these run in): nearbyint is a library
  // call on the baseline x86-64 the host builds for.
  constexpr double kRoundingShift = 6755399441055744.0;
  const double n = (theta * kTwoOverPi + kRoundingShift) - kRoundingShift;
  const double r = ((theta - n * kPio2Hi) - n * kPio2Mid) - n * kPio2Lo;
  const double z = r * r;
  const double sin_r =
      r + r * z *
              (-1.66666666666666324348e-01 +
               z * (8.33333333332248946124e-03 +
                    z * (-1.98412698298579493134e-04 +
                         z * (2.75573137070700676789e-06 + z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
  const double cos_r =
      1.0 - 0.5 * z +
      z * z *
          (4.16666666666666019037e-02 +
           z * (-1.38888888888741095749e-03 +
                z * (2.48015872894767294178e-05 +
                     z * (-2.75573143513906633035e-07 + z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
  // The quadrant q = n mod 4 turns (cos r, sin r) by q quarter turns:
  // selected, not branched on (the quadrants of successive segments follow
  // no pattern a branch predictor learns). |n| < 2^20: an int holds it.
  const int q = static_cast<int>(n) & 3;
  const bool odd = (q & 1) != 0;
  re = (odd ? sin_r : cos_r) * (((q + 1) & 2) != 0 ? -1.0 : 1.0);
  im = (odd ? cos_r : sin_r) * ((q & 2) != 0 ? -1.0 : 1.0);
}

/// e^{i theta} into re, im: reduced_unit_phasor, or the library's beyond its range.
inline void reduced_or_library(double theta, double& re, double& im) {
  if (std::fabs(theta) < kPhasorReducedMax) return reduced_unit_phasor(theta, re, im);
  const std::complex<double> z = std::polar(1.0, theta);
  re = z.real(), im = z.imag();
}

/// e^{i theta}: within 2e-16 of the library's sin and cos for |theta| up
/// to kPhasorReducedMax, the library's beyond (tests/diagnose/phasor_test.cpp).
inline std::complex<double> unit_phasor(double theta) {
  double re, im;
  reduced_or_library(theta, re, im);
  return {re, im};
}

/// e^{i k_j x} for j < n into re[j], im[j]: unit_phasor's values, side by
/// side (a ripple grid's periods at one position), as one vectorized loop
/// where every angle is in the reduction's range.
inline void unit_phasors(const double* k, double x, std::size_t n, double* re, double* im) {
  if (n == 1) {  // one period (a Brent step): the vector loop's checks would cost more than the phasor
    reduced_or_library(k[0] * x, re[0], im[0]);
    return;
  }
  bool reduced = true;
  for (std::size_t j = 0; j < n; ++j) reduced &= std::fabs(k[j] * x) < kPhasorReducedMax;
  if (!reduced) {
    for (std::size_t j = 0; j < n; ++j) reduced_or_library(k[j] * x, re[j], im[j]);
    return;
  }
  for (std::size_t j = 0; j < n; ++j) reduced_unit_phasor(k[j] * x, re[j], im[j]);
}

}  // namespace feedid::host::diag
