// A gravity term beside the friction (host_sim/identify/gravity.hpp, issue 31).
#include <gtest/gtest.h>

#include <cmath>

#include "identify/gravity.hpp"
#include "test_support.hpp"

namespace feedid::host {
namespace {
using test::SimSpec;
using test::simulate;

Trace arm(double G, double q0) { return test::arm_trace(G, q0); }

IdentifyOptions rotary(GravityTerm g) {
  IdentifyOptions o;
  o.units = units_for(Axis::rotary);
  o.gravity = g;
  return o;
}

TEST(Gravity, AnArmsLoadIsFittedAndTheFrictionIsTheUnloadedArms) {
  // GIVEN an arm whose load is 30 N m at 0.4 rad, beside 25 / 26 N m Coulomb friction
  const Trace loaded = arm(30.0, 0.4), unloaded = arm(0.0, 0.4);
  // WHEN identified without a gravity term THEN one direction's Coulomb term takes the load
  const IdentifyResult plain = identify(loaded, rotary(GravityTerm::none));
  EXPECT_GT(std::fabs(plain.estimate.pos.coulomb_N - plain.estimate.neg.coulomb_N), 20.0);
  // WHEN identified with the angle term (and automatically)
  const IdentifyResult ref = identify(unloaded, rotary(GravityTerm::none));
  for (GravityTerm g : {GravityTerm::angle, GravityTerm::automatic}) {
    const IdentifyResult r = identify(loaded, rotary(g));
    ASSERT_TRUE(r.error.empty()) << r.error;
    // THEN the load is found, and the friction and mass are the unloaded arm's
    ASSERT_EQ(r.gravity.form, GravityTerm::angle) << r.gravity.note;
    EXPECT_NEAR(r.gravity.G, 30.0, 0.3);
    // and its error covers it (the stick and slip at the travel's ends took G 3 errors low)
    EXPECT_LT(std::fabs(r.gravity.G - 30.0), 2.0 * r.gravity.G_se) << r.gravity.G << " +- " << r.gravity.G_se;
    EXPECT_LT(std::fabs(r.gravity.angle0_rad - 0.4), 2.0 * r.gravity.angle0_se_rad)
        << r.gravity.angle0_rad << " +- " << r.gravity.angle0_se_rad;
    EXPECT_NEAR(r.gravity.angle0_rad, 0.4, 0.01);
    EXPECT_NEAR(r.estimate.pos.coulomb_N, ref.estimate.pos.coulomb_N, 0.15);
    EXPECT_NEAR(r.estimate.neg.coulomb_N, ref.estimate.neg.coulomb_N, 0.15);
    EXPECT_NEAR(r.estimate.mass_kg, ref.estimate.mass_kg, 0.002 * ref.estimate.mass_kg);
  }
}

TEST(Gravity, ARotaryAxisGetsTheArmsWeightByDefaultALinearOneNothing) {
  // GIVEN the loaded arm, identified with nothing said of gravity
  IdentifyOptions o;
  o.units = units_for(Axis::rotary);
  const IdentifyResult r = identify(arm(30.0, 0.4), o);
  // THEN the weight is found, as asked for with auto
  ASSERT_EQ(r.gravity.form, GravityTerm::angle) << r.gravity.note;
  EXPECT_NEAR(r.gravity.G, 30.0, 0.3);
  // AND a linear axis, where a constant load looks like asymmetric Coulomb
  // friction, keeps its friction as it was and says nothing of gravity
  const IdentifyResult linear = identify(simulate(SimSpec{}), IdentifyOptions{});
  EXPECT_EQ(linear.gravity.form, GravityTerm::none);
  EXPECT_TRUE(linear.gravity.note.empty()) << linear.gravity.note;
  EXPECT_FALSE(to_json(linear).contains("gravity"));
}

TEST(Gravity, AutomaticKeepsNoTermWhereThereIsNoLoad) {
  const IdentifyResult r = identify(arm(0.0, 0.0), rotary(GravityTerm::automatic));
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.gravity.form, GravityTerm::none);
  EXPECT_NE(r.gravity.note.find("none"), std::string::npos) << r.gravity.note;
}

TEST(Gravity, AConstantLoadIsHalfTheCoulombDifference) {
  // GIVEN a vertical linear axis carrying 40 N
  SimSpec spec;
  Trace tr = simulate(spec);
  for (TraceSample& s : tr.samples) s.u_N += 40.0;
  IdentifyOptions o;
  o.gravity = GravityTerm::constant;
  const IdentifyResult r = identify(tr, o);
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.gravity.form, GravityTerm::constant);
  // THEN G is 40 N plus half the drive's own Coulomb asymmetry (25 / 26 N:
  // -0.5 N), which the data cannot tell from a load, and Coulomb is the same both ways
  EXPECT_NEAR(r.gravity.G, 39.5, 0.2);
  EXPECT_NEAR(r.estimate.pos.coulomb_N, r.estimate.neg.coulomb_N, 0.2);
}

TEST(Gravity, TheAngleFormNeedsARotaryAxis) {
  IdentifyOptions o;
  o.gravity = GravityTerm::angle;
  const IdentifyResult r = identify(simulate(SimSpec{}), o);
  EXPECT_NE(r.error.find("--axis rotary"), std::string::npos) << r.error;
}

}  // namespace
}  // namespace feedid::host
