// A position logged modulo a period, found and run on (host_sim/signals/position_wrap.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "signals/position_wrap.hpp"

namespace feedid::host {
namespace {

struct Log {
  std::vector<double> t, x;
};

/// 1 kHz samples of a position x(t).
template <class F>
Log sampled(double seconds, F position) {
  Log l;
  for (int k = 0; k <= static_cast<int>(seconds * 1000.0); ++k) {
    l.t.push_back(1e-3 * k);
    l.x.push_back(position(1e-3 * k));
  }
  return l;
}

/// x modulo the period, into [lo, lo + period).
Log wrapped(Log l, double period, double lo) {
  for (double& x : l.x) x = lo + (x - lo) - period * std::floor((x - lo) / period);
  return l;
}

std::size_t crossings(const Log& l, double period, double lo) {
  std::size_t n = 0;
  for (std::size_t k = 1; k < l.x.size(); ++k)
    n += std::floor((l.x[k] - lo) / period) != std::floor((l.x[k - 1] - lo) / period);
  return n;
}

/// Unwrapped, the log equals the original up to a whole number of periods,
/// within `tolerance` of the period (an estimated period errs at each wrap
/// by what the neighbouring steps mispredict).
void expect_runs_on(const Log& original, Log logged, double period, double tolerance) {
  const PositionWrap w = unwrap_position(logged.t, logged.x, 0.01);
  const double shift = logged.x.front() - original.x.front();
  EXPECT_NEAR(shift / period, std::round(shift / period), 1e-9);
  double worst = 0.0;
  for (std::size_t k = 0; k < logged.x.size(); ++k)
    worst = std::max(worst, std::fabs(logged.x[k] - shift - original.x[k]));
  EXPECT_LT(worst, tolerance * period) << w.describe();
}

// GIVEN a rotary axis turning 20 times at a varying speed, logged as a
// single-turn angle in [-pi, pi), THEN every wrap is found, the period is
// 2 pi exactly, and the angle runs on as it turned.
TEST(PositionWrap, SingleTurnAngleRunsOn) {
  const Log turning = sampled(10.0, [](double t) { return 4.0 * M_PI * t + 0.5 * std::sin(3.0 * t); });
  const Log logged = wrapped(turning, 2.0 * M_PI, -M_PI);
  const PositionWrap w = find_position_wrap(logged.t, logged.x, 0.01);
  EXPECT_EQ(w.wraps, crossings(turning, 2.0 * M_PI, -M_PI));
  EXPECT_GE(w.wraps, 19u);
  EXPECT_EQ(w.period, 2.0 * M_PI);
  expect_runs_on(turning, logged, 2.0 * M_PI, 1e-12);
}

// GIVEN a 12-bit counter (times 1e-4 m per count) that overflows while the
// axis reciprocates across it, THEN the period is found from the jumps and
// the position runs on both ways.
TEST(PositionWrap, CounterOverflowBothWays) {
  const double period = 4096e-4;
  const Log moving = sampled(8.0, [&](double t) { return period + 0.3 * std::sin(2.0 * M_PI * 0.5 * t); });
  const Log logged = wrapped(moving, period, 0.0);
  const PositionWrap w = find_position_wrap(logged.t, logged.x, 0.01);
  EXPECT_EQ(w.wraps, crossings(moving, period, 0.0));
  EXPECT_NEAR(w.period / period, 1.0, 1e-3);
  expect_runs_on(moving, logged, period, 1e-6);
}

// GIVEN motion that does not wrap (a slow sine, a fast one sampled ten
// times a cycle, and two recordings at different places across a gap),
// THEN nothing is taken out.
TEST(PositionWrap, OrdinaryMotionIsLeftAlone) {
  const Log slow = sampled(5.0, [](double t) { return 0.1 * std::sin(t); });
  EXPECT_FALSE(find_position_wrap(slow.t, slow.x, 0.01).found());
  const Log coarse = sampled(2.0, [](double t) { return std::sin(2.0 * M_PI * 100.0 * t + 0.3); });
  EXPECT_FALSE(find_position_wrap(coarse.t, coarse.x, 0.01).found());
  Log two_runs = sampled(2.0, [](double t) { return 0.01 * t; });
  const Log second = sampled(2.0, [](double t) { return 5.0 + 0.01 * t; });
  for (std::size_t k = 0; k < second.t.size(); ++k) {
    two_runs.t.push_back(12.0 + second.t[k]);
    two_runs.x.push_back(second.x[k]);
  }
  Log unchanged = two_runs;
  EXPECT_FALSE(unwrap_position(unchanged.t, unchanged.x, 0.01).found());
  EXPECT_EQ(unchanged.x, two_runs.x);
}

// GIVEN two jumps of more than half the span that disagree (+3 and -1.8
// on a slow ramp), THEN none is taken out: the log is not a wrapped
// position, and a guess would bend the motion.
TEST(PositionWrap, JumpsThatDisagreeAreNotAWrap) {
  const Log l = sampled(3.0, [](double t) { return 0.1 * t + (t >= 1.0 && t < 2.0 ? 3.0 : 0.0) + (t >= 2.0 ? 1.2 : 0.0); });
  EXPECT_FALSE(find_position_wrap(l.t, l.x, 0.01).found());
}

}  // namespace
}  // namespace feedid::host
