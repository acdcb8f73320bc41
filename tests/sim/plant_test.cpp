// The plant (host_sim/sim/plant.hpp) at rest and at break-away, where an
// extra force that is friction (a drift's Coulomb part, as the replay's
// named effects draw it) must act as the plant's own Coulomb force does.
#include <gtest/gtest.h>

#include "sim/plant.hpp"

namespace {

using namespace feedid::host;

/// Slides the plant forward at 100 N, lets it stop, then pushes it back at
/// `push` N for 10 ms; how far it went back (m, <= 0).
double pushed_back(const DriveParams& d, const Effects& e, const ExtraForce& extra, double push) {
  const ServiceChange no_change;
  DrivePlant p(d, e, extra, no_change, true);
  p.start_at(0.0);
  double t = 0.0;
  const double h = 1e-4;
  for (int k = 0; k < 100; ++k, t += h) p.step(t, h, 100.0);
  for (int k = 0; k < 10000 && p.v() != 0.0; ++k, t += h) p.step(t, h, 0.0);
  EXPECT_EQ(p.v(), 0.0);
  const double stopped = p.x();
  for (int k = 0; k < 100; ++k, t += h) p.step(t, h, push);
  return p.x() - stopped;
}

// GIVEN a bristle whose dip after a reversal (2 Fp = 30 N) exceeds the
// friction at rest (Fc + Fs = 26 N), and 10 N more Coulomb friction, once
// in the plant's Fc and once as a friction-like extra force (0 at rest)
// THEN a push of 8 N back breaks the axis away in both, by the same
// distance: the band is floored once, after the extra force's step
TEST(Plant, FrictionInTheExtraForceBreaksAwayAsTheCoulombForceDoes) {
  DriveParams d;
  d.mass_kg = 100.0;
  d.pos = {200.0, 20.0, 6.0, 2e-3};
  d.neg = d.pos;
  Effects e;
  e.presliding_force_N = 15.0;
  e.presliding_distance_m = 3e-7;
  const ExtraForce drift = [](double, double, double v) { return v > 0 ? 10.0 : v < 0 ? -10.0 : 0.0; };
  DriveParams heavier = d;
  heavier.pos.coulomb_N += 10.0;
  heavier.neg.coulomb_N += 10.0;
  const double in_fc = pushed_back(heavier, e, ExtraForce{}, -8.0);
  const double in_extra = pushed_back(d, e, drift, -8.0);
  EXPECT_LT(in_fc, -1e-9);
  EXPECT_NEAR(in_extra, in_fc, 1e-6 * std::fabs(in_fc));
}

}  // namespace
