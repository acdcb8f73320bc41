// Force rows beyond a limit read from the data (host/signals/force_outliers.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "signals/filters.hpp"
#include "signals/force_outliers.hpp"

namespace feedid::host {
namespace {

/// 1 kHz reciprocation x = A sin(2 pi 0.5 t) under u = m a + Fc sign(v),
/// with rests of `rest_s` (force 0.3 N) between the seconds of motion.
Trace reciprocating(double seconds, double rest_s = 0.0) {
  Trace tr;
  tr.source = "recip.csv";
  tr.has_velocity = false;
  const double A = 0.05, w = 2.0 * M_PI * 0.5, mass = 20.0;
  double t = 0.0;
  for (int k = 0; k <= static_cast<int>(seconds * 1000.0); ++k) {
    const double tm = 1e-3 * k, v = A * w * std::cos(w * tm), a = -A * w * w * std::sin(w * tm);
    tr.samples.push_back({t, A * std::sin(w * tm), 0.0, mass * a + 10.0 * (v > 0 ? 1.0 : -1.0)});
    t += 1e-3;
    if (rest_s > 0.0 && k % 1000 == 999)
      for (int j = 0; j < static_cast<int>(rest_s * 1000.0); ++j, t += 1e-3)
        tr.samples.push_back({t, tr.samples.back().x_m, 0.0, 0.3});
  }
  return tr;
}

std::vector<double> column(const Trace& tr, double TraceSample::*field) {
  std::vector<double> out;
  for (const auto& s : tr.samples) out.push_back(s.*field);
  return out;
}

// GIVEN a log in another force unit (3e7 and 1e8 per N), THEN the limit is
// the same multiple of its forces: nothing is cut that the log in N keeps,
// as the fixed limit of 1e9 cut 40 % of a log at 3e7.
TEST(ForceOutliers, TheLimitScalesWithTheForceUnit) {
  const Trace tr = reciprocating(10.0);
  const double limit = force_outlier_limit(column(tr, &TraceSample::x_m), column(tr, &TraceSample::u_N));
  for (const double unit : {3e7, 1e8, 1e-6}) {
    Trace scaled = tr;
    for (auto& s : scaled.samples) s.u_N *= unit;
    ForceOutliers found;
    const Trace kept = bridge_force_outliers(scaled, "unit", found);
    EXPECT_NEAR(found.limit / (limit * unit), 1.0, 1e-12) << unit;
    EXPECT_EQ(found.rows, 0u) << unit;
    EXPECT_EQ(kept.samples.size(), tr.samples.size()) << unit;
  }
}

// GIVEN one row of 1e12 and one of -1e4 in a log peaking near 20 N, THEN
// both forces are counted, named with their file, time and value, and
// replaced by the straight line between their neighbours; every other
// sample, the acceleration peaks among them, stays as logged.
TEST(ForceOutliers, IsolatedRowsAreBridgedCountedAndNamed) {
  const Trace clean = reciprocating(10.0);
  Trace tr = clean;
  tr.samples[1234].u_N = 1e12;
  tr.samples[5678].u_N = -1e4;
  ForceOutliers found;
  const Trace kept = bridge_force_outliers(tr, "N", found);
  EXPECT_EQ(found.rows, 2u);
  EXPECT_EQ(found.unbridged, 0u);
  ASSERT_EQ(kept.samples.size(), tr.samples.size());
  ASSERT_EQ(found.first.size(), 2u);
  EXPECT_NE(found.first[0].find("recip.csv: t = 1.234 s: force 1e+12 N"), std::string::npos) << found.first[0];
  EXPECT_NE(found.first[1].find("t = 5.678 s: force -10000 N"), std::string::npos) << found.first[1];
  for (const std::size_t k : {std::size_t{1234}, std::size_t{5678}})
    EXPECT_DOUBLE_EQ(kept.samples[k].u_N, 0.5 * (clean.samples[k - 1].u_N + clean.samples[k + 1].u_N)) << k;
  for (std::size_t k = 0; k < kept.samples.size(); ++k)
    if (k != 1234 && k != 5678) ASSERT_EQ(kept.samples[k].u_N, clean.samples[k].u_N) << k;
  EXPECT_LT(found.limit, 1e4);
  EXPECT_GT(found.limit, 19.5);  // m A w^2 + Fc = 9.87 + 10 N: the peaks are no outliers
  EXPECT_NE(found.describe("N").find("2 force rows beyond"), std::string::npos) << found.describe("N");
}

// GIVEN a log that rests nine tenths of its time at a holding force of
// 0.3 N, THEN its limit is read from the motion: the acceleration peaks,
// a hundred times the force at rest, are no outliers.
TEST(ForceOutliers, LongRestsDoNotLowerTheLimit) {
  const Trace tr = reciprocating(10.0, 9.0);
  ForceOutliers found;
  const Trace kept = bridge_force_outliers(tr, "N", found);
  EXPECT_EQ(found.rows, 0u);
  EXPECT_GT(found.limit, 10.0 * 19.5);
  EXPECT_EQ(kept.samples.size(), tr.samples.size());
}

// GIVEN two pooled runs with outliers at the first sample of the second
// and a hundred samples into it, THEN no bridge spans the gap between the
// runs (the first sample takes its successor's force) and the message
// names the second file and its own time.
TEST(ForceOutliers, BridgesStayWithinTheirRun) {
  const Trace one = reciprocating(4.0);
  Trace tr = one;
  tr.runs.push_back({"a.csv", 0, one.samples.size(), 0.0, 0, 0});
  const double shift = one.samples.back().t_s + Trace::kRunGap_s;
  for (auto s : one.samples) {
    s.t_s += shift;
    tr.samples.push_back(s);
  }
  tr.runs.push_back({"b.csv", one.samples.size(), one.samples.size(), shift, 0, 0});
  const std::size_t first = one.samples.size();
  tr.samples[first].u_N = 5e6;
  tr.samples[first + 100].u_N = 5e6;
  ForceOutliers found;
  const Trace kept = bridge_force_outliers(tr, "N", found);
  ASSERT_EQ(found.rows, 2u);
  EXPECT_NE(found.first[0].find("b.csv: t = 0 s"), std::string::npos) << found.first[0];
  EXPECT_NE(found.first[1].find("b.csv: t = 0.1 s"), std::string::npos) << found.first[1];
  EXPECT_EQ(kept.samples[first].u_N, one.samples[1].u_N);
}

// GIVEN a stretch of a single sample whose force is an outlier, THEN there
// is nothing to bridge it by: counted as unbridged and left for the core.
TEST(ForceOutliers, AnOutlierAloneInItsStretchIsLeftForTheCore) {
  Trace tr = reciprocating(4.0);
  tr.samples.push_back({tr.samples.back().t_s + 5.0, 0.0, 0.0, 1e9});
  ForceOutliers found;
  const Trace kept = bridge_force_outliers(tr, "N", found);
  EXPECT_EQ(found.rows, 1u);
  EXPECT_EQ(found.unbridged, 1u);
  EXPECT_EQ(kept.samples.back().u_N, 1e9);
}

// GIVEN a force of zeros, THEN there is no scale to call a row an outlier
// by: the limit is the largest finite number (a valid core max_force_N).
TEST(ForceOutliers, AForceOfZerosHasNoLimit) {
  Trace tr = reciprocating(2.0);
  for (auto& s : tr.samples) s.u_N = 0.0;
  ForceOutliers found;
  EXPECT_EQ(bridge_force_outliers(tr, "N", found).samples.size(), tr.samples.size());
  EXPECT_EQ(found.limit, std::numeric_limits<double>::max());
}

TEST(ForceSaturation, ClippedRowsAreLeftOutAsGapsAndAPeakIsNot) {
  // GIVEN a reciprocation whose force (peak 19.9 N) is clipped at +-15 N
  Trace tr = reciprocating(10.0);
  const Trace unclipped = tr;
  for (auto& smp : tr.samples) smp.u_N = std::clamp(smp.u_N, -15.0, 15.0);
  // WHEN screened
  ForceSaturation found;
  const Trace kept = leave_out_force_saturation(tr, found);
  // THEN both levels are found, every clipped row is gone, and the kept
  // rows either side of each hole are more than a gap apart
  ASSERT_TRUE(found.found_hi && found.found_lo);
  EXPECT_EQ(found.level_hi, 15.0);
  EXPECT_EQ(found.level_lo, -15.0);
  EXPECT_EQ(found.rows_left_out, tr.samples.size() - kept.samples.size());
  EXPECT_GE(found.rows_left_out, found.rows);
  for (const auto& smp : kept.samples) EXPECT_LT(std::fabs(smp.u_N), 15.0);
  for (std::size_t k = 1; k < kept.samples.size(); ++k) {
    const double step = kept.samples[k].t_s - kept.samples[k - 1].t_s;
    EXPECT_TRUE(step < 1.5e-3 || step > max_step_s(1e-3)) << "a hole of " << step << " s is neither a row nor a gap";
  }
  // AND the unclipped force, whose peaks pass in a row or two, is left whole
  ForceSaturation none;
  EXPECT_EQ(leave_out_force_saturation(unclipped, none).samples.size(), unclipped.samples.size());
  EXPECT_FALSE(none.found());
}

TEST(ForceSaturation, AFewSpikesBeyondAClipDoNotHideIt) {
  // GIVEN the reciprocation clipped at +-15 N, with spikes beyond the upper level
  Trace tr = reciprocating(10.0);
  for (auto& smp : tr.samples) smp.u_N = std::clamp(smp.u_N, -15.0, 15.0);
  tr.samples[1000].u_N = 1e5;
  tr.samples[3000].u_N = 40.0;
  tr.samples[5000].u_N = 40.0;
  // WHEN screened THEN both levels are still found (the spikes are the outlier bridge's)
  ForceSaturation found;
  (void)leave_out_force_saturation(tr, found);
  ASSERT_TRUE(found.found_hi && found.found_lo);
  EXPECT_EQ(found.level_hi, 15.0);
  // AND more rows beyond the level than a few spikes are a force, not spikes: no clip there
  for (std::size_t k = 0; k < 10; ++k) tr.samples[6000 + 50 * k].u_N = 20.0 + k;
  (void)leave_out_force_saturation(tr, found);
  EXPECT_FALSE(found.found_hi);
  EXPECT_TRUE(found.found_lo);
}

TEST(ForceSaturation, ACoarselyQuantisedForceIsNotCalledClipped) {
  // GIVEN the reciprocation's force (peak 19.9 N) in steps of 5 N, unclipped
  Trace tr = reciprocating(10.0);
  for (auto& smp : tr.samples) smp.u_N = 5.0 * std::round(smp.u_N / 5.0);
  // WHEN screened  THEN no level is a clip: the top step holds no more rows than those below it
  ForceSaturation found;
  (void)leave_out_force_saturation(tr, found);
  EXPECT_FALSE(found.found()) << found.describe("N");
  // AND neither is a constant force, which has no other value to be clipped from
  for (auto& smp : tr.samples) smp.u_N = 1.0;
  (void)leave_out_force_saturation(tr, found);
  EXPECT_FALSE(found.found()) << found.describe("N");
}

TEST(ForceSaturation, APartThatHoldsOneForceAtRestIsNotClippedBelowTheLogsLevel) {
  // GIVEN a stretch that dwells, holding 3 N (its largest force) but for a few smaller rows
  Trace tr = reciprocating(2.0);
  for (std::size_t k = 0; k < tr.samples.size(); ++k) tr.samples[k].u_N = k % 50 == 0 ? 2.0 : 3.0;
  // WHEN screened alone THEN the held force looks like a clip ...
  ForceSaturation found;
  (void)leave_out_force_saturation(tr, found);
  EXPECT_TRUE(found.found_hi);
  // ... AND is none where the log's force has been ten times that (a stream's chunk)
  (void)leave_out_force_saturation(tr, found, ForceSaturation{}, 0.5 * 30.0);
  EXPECT_FALSE(found.found()) << found.describe("N");
  // AND a level known from earlier in the log is left out here too
  ForceSaturation known;
  known.found_hi = true;
  known.level_hi = 3.0;
  const Trace kept = leave_out_force_saturation(tr, found, known, 0.5 * 30.0);
  EXPECT_TRUE(found.found_hi);
  EXPECT_LT(kept.samples.size(), tr.samples.size());
}

TEST(PositionSpikes, AOneRowJumpIsBridgedAndAFastMoveIsNot) {
  // GIVEN a reciprocation (peak step 0.16 mm per 1 ms row) with one row 1 m off
  Trace tr = reciprocating(10.0);
  const Trace clean = tr;
  tr.samples[5000].x_m += 1.0;
  // WHEN bridged  THEN that row, and only it, is back between its neighbours and named
  PositionSpikes found;
  const Trace out = bridge_position_spikes(tr, found);
  EXPECT_EQ(found.rows, 1u);
  ASSERT_EQ(found.first.size(), 1u);
  EXPECT_NE(found.first.front().find("recip.csv: t = 5 s"), std::string::npos) << found.first.front();
  EXPECT_NEAR(out.samples[5000].x_m, clean.samples[5000].x_m, 1e-6);
  for (std::size_t k = 0; k < out.samples.size(); ++k)
    if (k != 5000) EXPECT_EQ(out.samples[k].x_m, clean.samples[k].x_m) << k;
  // AND the clean motion, fast strokes included, is left whole
  PositionSpikes none;
  (void)bridge_position_spikes(clean, none);
  EXPECT_EQ(none.rows, 0u);
}

}  // namespace
}  // namespace feedid::host
