// unit_phasor against the library's sin and cos (host_sim/diagnose/phasor.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "diagnose/phasor.hpp"

namespace feedid::test {
namespace {

using host::diag::kPhasorReducedMax;
using host::diag::unit_phasor;
using host::diag::unit_phasors;

double worst_error_up_to(double scale, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> theta(-scale, scale);
  double worst = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const double t = theta(rng);
    const std::complex<double> z = unit_phasor(t);
    worst = std::max({worst, std::fabs(z.real() - std::cos(t)), std::fabs(z.imag() - std::sin(t))});
  }
  return worst;
}

TEST(UnitPhasor, AgreesWithTheLibraryToTheLastBitsAtEveryScale) {
  std::mt19937_64 rng(7);
  // From a fraction of a turn to the reduction's limit: 1e-15 is a few
  // units in the last place of an entry of size one.
  for (const double scale : {0.5, 4.0, 100.0, 1e4, 0.99 * kPhasorReducedMax})
    EXPECT_LT(worst_error_up_to(scale, rng), 1e-15) << "|theta| up to " << scale;
}

TEST(UnitPhasor, EachQuadrantAndItsEdgesAreTurnedRight) {
  for (int quarter = -8; quarter <= 8; ++quarter)
    for (const double off : {-0.78, -1e-9, 0.0, 1e-9, 0.78}) {
      const double t = quarter * M_PI / 2 + off;
      const std::complex<double> z = unit_phasor(t);
      EXPECT_NEAR(z.real(), std::cos(t), 1e-15) << t;
      EXPECT_NEAR(z.imag(), std::sin(t), 1e-15) << t;
    }
}

TEST(UnitPhasor, BeyondTheReductionItIsTheLibrarysAndNonFiniteStaysSo) {
  for (const double t : {2.0 * kPhasorReducedMax, -5e12}) {
    EXPECT_EQ(unit_phasor(t), std::polar(1.0, t)) << t;
  }
  EXPECT_TRUE(std::isnan(unit_phasor(std::nan("")).real()));
  EXPECT_TRUE(std::isnan(unit_phasor(INFINITY).imag()));
}

// One angle alone (a Brent step's period) takes the scalar way: the same
// bits, also beyond the reduction and at an infinity.
TEST(UnitPhasor, OneAngleAloneIsTheScalarOne) {
  for (const double theta : {0.3, -2.0e5, 2.0 * kPhasorReducedMax, double(INFINITY)}) {
    const double k = 1.0;
    double re = 0.0, im = 0.0;
    unit_phasors(&k, theta, 1, &re, &im);
    const std::complex<double> z = unit_phasor(theta);
    if (std::isinf(theta)) {
      EXPECT_TRUE(std::isnan(re) && std::isnan(z.real()));
      continue;
    }
    EXPECT_EQ(re, z.real()) << theta;
    EXPECT_EQ(im, z.imag()) << theta;
  }
}

// Side by side (a ripple grid's periods at one position) the phasors are
// unit_phasor's to the bit, in range and where one angle is beyond the
// reduction or not finite (then every angle of the call takes the scalar way).
TEST(UnitPhasor, SideBySideTheyAreTheScalarOnesToTheBit) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> k(1.0, 2e4);
  std::vector<double> ks(37);
  for (double& v : ks) v = k(rng);
  for (const double x : {0.0, 1e-3, -0.37, 12.5, 2.0 * kPhasorReducedMax / 2e4, std::nan("")}) {
    std::vector<double> re(ks.size()), im(ks.size());
    unit_phasors(ks.data(), x, ks.size(), re.data(), im.data());
    for (std::size_t j = 0; j < ks.size(); ++j) {
      const std::complex<double> z = unit_phasor(ks[j] * x);
      if (std::isnan(x)) {
        EXPECT_TRUE(std::isnan(re[j]) && std::isnan(im[j]));
        continue;
      }
      EXPECT_EQ(re[j], z.real()) << "x " << x << " k " << ks[j];
      EXPECT_EQ(im[j], z.imag()) << "x " << x << " k " << ks[j];
    }
  }
}

}  // namespace
}  // namespace feedid::test
