// The sign of a logged force from how it meets the motion (host_sim/signals/force_sign.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "signals/force_sign.hpp"

namespace feedid::host {
namespace {

/// 1 kHz samples of x = A sin(2 pi 0.5 t) + drift t under
/// u = m a + Fc sign(v) + offset, optionally negated.
struct Motion {
  std::vector<double> t, x, u;
};
Motion reciprocating_with_force(double seconds, double coulomb_N, double offset_N, double drift_m_s = 0.0) {
  Motion m;
  const double A = 0.05, w = 2.0 * M_PI * 0.5, mass = 20.0;
  for (int k = 0; k <= static_cast<int>(seconds * 1000.0); ++k) {
    const double t = 1e-3 * k;
    const double v = A * w * std::cos(w * t) + drift_m_s, a = -A * w * w * std::sin(w * t);
    m.t.push_back(t);
    m.x.push_back(A * std::sin(w * t) + drift_m_s * t);
    m.u.push_back(mass * a + coulomb_N * (v > 0 ? 1.0 : -1.0) + offset_N);
  }
  return m;
}
Motion negated(Motion m) {
  for (double& u : m.u) u = -u;
  return m;
}

// GIVEN reciprocating motion against Coulomb friction, THEN the force as
// logged pushes with the motion both ways (ratio 1) and is kept; negated,
// it is found reversed.
TEST(ForceSign, FrictionBothWaysGivesTheSign) {
  const Motion m = reciprocating_with_force(10.0, 10.0, 0.0);
  const ForceSign kept = find_force_sign(m.t, m.x, m.u, 0.01);
  EXPECT_EQ(kept.sign, 1);
  EXPECT_TRUE(kept.both_directions);
  EXPECT_TRUE(kept.conclusive);
  EXPECT_NEAR(kept.ratio, 1.0, 0.02);
  const ForceSign found = find_force_sign(m.t, m.x, negated(m).u, 0.01);
  EXPECT_EQ(found.sign, -1);
  EXPECT_NEAR(found.ratio, -kept.ratio, 1e-12);
  EXPECT_NE(found.describe().find("negated"), std::string::npos);
}

// GIVEN an offset (gravity) three times the friction, THEN the difference
// of the directions' mean forces still gives the sign either way round
// (ratio Fc / offset = 1/3); at ten times it is inside the margin, and the
// force is left as logged with a word that its sign is unconfirmed.
TEST(ForceSign, AnOffsetCancelsBetweenTheDirections) {
  const Motion three = reciprocating_with_force(10.0, 10.0, -30.0);
  const ForceSign kept = find_force_sign(three.t, three.x, three.u, 0.01);
  EXPECT_EQ(kept.sign, 1);
  EXPECT_NEAR(kept.ratio, 1.0 / 3.0, 0.03);
  EXPECT_EQ(find_force_sign(three.t, three.x, negated(three).u, 0.01).sign, -1);
  const Motion ten = reciprocating_with_force(10.0, 10.0, -100.0);
  for (const Motion& m : {ten, negated(ten)}) {
    const ForceSign f = find_force_sign(m.t, m.x, m.u, 0.01);
    EXPECT_FALSE(f.conclusive) << f.ratio;
    EXPECT_EQ(f.sign, 1);
    EXPECT_NE(f.describe().find("unconfirmed"), std::string::npos);
  }
}

// GIVEN travel one way only (a SysId file: from rest, speeding up against
// friction), THEN the net work decides: kept as logged, found negated.
// With no motion at all there is nothing to judge by: as logged, NaN.
TEST(ForceSign, OneWayTravelIsJudgedByItsWork) {
  Motion m;
  for (int k = 0; k <= 2000; ++k) {
    const double t = 1e-3 * k, v = 0.3 * (1.0 - std::exp(-t / 0.2));
    m.t.push_back(t);
    m.x.push_back(0.3 * (t - 0.2 * (1.0 - std::exp(-t / 0.2))));
    m.u.push_back(5.0 * 0.3 / 0.2 * std::exp(-t / 0.2) + 2.0 + 10.0 * v);
  }
  const ForceSign kept = find_force_sign(m.t, m.x, m.u, 0.01);
  EXPECT_FALSE(kept.both_directions);
  EXPECT_EQ(kept.sign, 1);
  EXPECT_NEAR(kept.ratio, 1.0, 1e-12);
  EXPECT_EQ(find_force_sign(m.t, m.x, negated(m).u, 0.01).sign, -1);
  const std::vector<double> t = {0.0, 0.001, 0.002}, x = {1.0, 1.0, 1.0}, u = {5.0, 5.0, 5.0};
  const ForceSign still = find_force_sign(t, x, u, 0.01);
  EXPECT_EQ(still.sign, 1);
  EXPECT_FALSE(still.conclusive);
  EXPECT_TRUE(std::isnan(still.ratio));
}

// GIVEN two recordings pooled with a jump of position across the gap
// between them, THEN the jump is no travel: the steps over max_step_s are
// left out (a huge force on the far side of the gap would otherwise decide).
TEST(ForceSign, AJumpAcrossAGapIsNoMotion) {
  Motion m = reciprocating_with_force(4.0, 10.0, 0.0);
  const std::size_t n = m.t.size();
  for (std::size_t k = 0; k < n; ++k) {  // a second run, 10 s later and 5 m away
    m.t.push_back(m.t[k] + m.t[n - 1] + 10.0);
    m.x.push_back(m.x[k] - 5.0);
    m.u.push_back(k == 0 ? 1e6 : m.u[k]);
  }
  const ForceSign f = find_force_sign(m.t, m.x, m.u, 0.01);
  EXPECT_EQ(f.sign, 1);
  EXPECT_NEAR(f.ratio, 1.0, 0.02);
}

// GIVEN one force row of 1e12 (+ or -) in either direction's travel, THEN
// the sign stands: a plain mean over travel took the one row for all of a
// direction's force and negated the EMPS log (peak 152 N). And a fifth of
// one direction's samples replaced by 1e6 of the wrong sign cannot turn it
// either.
TEST(ForceSign, NoOutlierRowTurnsTheSign) {
  const Motion clean = reciprocating_with_force(10.0, 10.0, 0.0);
  const double ratio = find_force_sign(clean.t, clean.x, clean.u, 0.01).ratio;
  for (const std::size_t k : {std::size_t{400}, std::size_t{1400}})  // moving positive, negative
    for (const double outlier : {1e12, -1e12}) {
      Motion m = clean;
      m.u[k] = outlier;
      const ForceSign f = find_force_sign(m.t, m.x, m.u, 0.01);
      EXPECT_EQ(f.sign, 1) << k << " " << outlier;
      EXPECT_NEAR(f.ratio, ratio, 0.01) << k << " " << outlier;
    }
  Motion fifth = clean;
  std::size_t replaced = 0, negative_travel = 0;
  for (std::size_t k = 1; k < fifth.t.size(); ++k) {
    if (!(fifth.x[k] < fifth.x[k - 1])) continue;
    if (negative_travel++ % 5 == 0) {
      fifth.u[k] = 1e6;  // negative travel pushed positive: evidence of a reversed log
      ++replaced;
    }
  }
  ASSERT_GE(replaced, 1000u);
  const ForceSign f = find_force_sign(fifth.t, fifth.x, fifth.u, 0.01);
  EXPECT_EQ(f.sign, 1) << f.ratio;
  EXPECT_TRUE(f.conclusive) << f.ratio;
}

}  // namespace
}  // namespace feedid::host
