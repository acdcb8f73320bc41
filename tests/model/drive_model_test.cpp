// F(v) of the drive model (host_sim/model/drive_model.hpp). The block
// observations evaluate it at every sample of every pass, so it skips the
// Stribeck exp where that underflows (issue 29); the skip must change no bit.
#include <gtest/gtest.h>

#include <cmath>

#include "model/drive_model.hpp"

namespace {

using namespace feedid::host;

/// F(v) as written in the model (NOTES.md), with the exp always taken.
double friction_as_written(const DirectionFriction& f, double direction, double v) {
  const double r = v / f.stribeck_velocity_m_s;
  return direction * (f.coulomb_N + f.breakaway_N * std::exp(-r * r)) + f.viscous_Ns_m * v;
}

TEST(DriveModel, FrictionEqualsTheFormulaBitForBitAcrossTheUnderflow) {
  // GIVEN a drive with the paper's vs and speeds from inside the dip to
  // 40 vs, through r^2 = 750 where the exp is skipped
  DriveParams p;
  p.pos = {705.0, 25.8, 7.5, 1.4e-4};
  p.neg = {690.0, 24.1, 6.9, 1.3e-4};
  for (double r = 0.0; r <= 40.0; r += 0.013) {
    for (int d : {1, -1}) {
      const DirectionFriction& f = d > 0 ? p.pos : p.neg;
      const double v = d * r * f.stribeck_velocity_m_s;
      if (v == 0.0) continue;
      // WHEN F(v) is evaluated THEN it is the formula's value exactly
      EXPECT_EQ(stribeck_friction(p, v), friction_as_written(f, d, v)) << "v = " << v;
    }
  }
  // AND so for a break-away far above the Coulomb force (the skip's bound
  // is 13 |Fc|) and for no Coulomb force at all, where exp is never skipped
  // before it underflows
  for (const DirectionFriction& f : {DirectionFriction{0.0, 1.27, 31.9, 1.4e-4},
                                     DirectionFriction{700.0, 2.45, 31.85, 1.4e-4},  // Fs = 13 Fc: skipped
                                     DirectionFriction{0.0, 31.9 / 13.0, 31.9, 1.4e-4},
                                     DirectionFriction{0.0, 0.0, 5.0, 1.4e-4}}) {
    DriveParams q = p;
    q.pos = f;
    for (double r = 6.0; r <= 30.0; r += 0.0011)
      EXPECT_EQ(stribeck_friction(q, r * f.stribeck_velocity_m_s), friction_as_written(f, 1, r * f.stribeck_velocity_m_s))
          << "Fc = " << f.coulomb_N << ", r = " << r;
  }
  // AND a break-away that is not finite still spoils the force, as the formula's product does
  p.pos.breakaway_N = std::nan("");
  EXPECT_TRUE(std::isnan(stribeck_friction(p, 100.0 * p.pos.stribeck_velocity_m_s)));
}

}  // namespace
