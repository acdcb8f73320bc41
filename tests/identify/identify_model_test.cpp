// The identified model as simulator parameters (identify.hpp,
// to_drive_params). GIVEN a direction without an identified Stribeck
// velocity, THEN the model has no dip (Fs = 0) instead of keeping Fs behind
// an invisible vs = 1e-9 m/s, and F(v) stays finite.
#include <gtest/gtest.h>

#include <cmath>

#include "identify/identify.hpp"

namespace feedid::test {
namespace {

TEST(ToDriveParams, NoStribeckVelocityMeansNoDip) {
  feedid::Estimate<double> e;
  e.mass_kg = 50.0;
  e.pos = {};
  e.pos.viscous_Ns_m = 600.0;
  e.pos.coulomb_N = 20.0;
  e.pos.breakaway_N = 7.0;
  e.pos.stribeck_velocity_m_s = 0.0;  // not identified
  e.neg = e.pos;
  e.neg.stribeck_velocity_m_s = 2e-3;
  const host::DriveParams p = host::to_drive_params(e);
  EXPECT_EQ(p.pos.breakaway_N, 0.0);
  EXPECT_DOUBLE_EQ(host::stribeck_friction(p, 1e-4), 20.0 + 600.0 * 1e-4);
  EXPECT_EQ(p.neg.breakaway_N, 7.0);
  EXPECT_DOUBLE_EQ(p.neg.stribeck_velocity_m_s, 2e-3);
}

}  // namespace
}  // namespace feedid::test
