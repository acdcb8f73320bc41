// Columns logged faster than they are updated (host_sim/signals/held_values.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "identify/identify.hpp"
#include "identify/timing_search.hpp"
#include "signals/held_values.hpp"

namespace feedid::host {
namespace {

/// 200 Hz rows with jittered steps (4-6 ms) of a motion x(t) = 0.5 t^2 + t,
/// sampled by a status frame every `hold` rows (each row logs the last frame).
struct HeldLog {
  std::vector<double> t, truth, logged;
};
HeldLog held_log(int hold, int rows) {
  HeldLog h;
  double t = 0.0, frame = 0.0;
  for (int k = 0; k < rows; ++k) {
    t += 0.004 + 0.002 * std::fabs(std::sin(1.7 * k));
    const double x = 0.5 * t * t + t;
    if (k % hold == 0) frame = x;
    h.t.push_back(t);
    h.truth.push_back(x);
    h.logged.push_back(frame);
  }
  return h;
}

// GIVEN a position that the log repeats for four rows between updates,
// WHEN its hold is detected and spread, THEN the period is 4, and every
// row between two updates lies on the straight line between them (the
// motion's chord), within the curvature's error over a 20 ms frame.
TEST(HeldValues, AFourRowHoldIsFoundAndSpreadBetweenUpdates) {
  HeldLog h = held_log(4, 400);
  const HoldPattern p = detect_hold(h.logged, 0.0);
  EXPECT_EQ(p.period_rows, 4);
  EXPECT_GE(p.changes, 20u);
  std::vector<double> x = h.logged;
  spread_held_values(x, h.t, p.period_rows + 1, 0.05);
  double worst_held = 0.0, worst_spread = 0.0;
  for (std::size_t k = 4; k + 4 < x.size(); ++k) {
    worst_held = std::max(worst_held, std::fabs(h.logged[k] - h.truth[k]));
    // The value appearing at row k is the motion at row k: spread, the rows
    // lie on chords through the motion, at most (a/8) T^2 off (T <= 24 ms).
    worst_spread = std::max(worst_spread, std::fabs(x[k] - h.truth[k]));
  }
  EXPECT_LT(worst_spread, 1.1 * 0.125 * 1.0 * 0.024 * 0.024);
  EXPECT_GT(worst_held, 50.0 * worst_spread);  // the holds' sawtooth, gone
}

// GIVEN a slow axis whose encoder count stays for a varying number of rows
// (quantisation, no hold in the logger) and a signal that changes every
// row, WHEN holds are looked for with a minimum change of three counts,
// THEN neither is held.
TEST(HeldValues, QuantisationAndEveryRowChangesAreNotHolds) {
  std::vector<double> counts, smooth;
  for (int k = 0; k < 2000; ++k) {
    counts.push_back(1e-6 * std::floor(0.37 * k + 0.2 * std::sin(0.05 * k)));  // 1 um counts, 2-3 rows each
    smooth.push_back(std::sin(0.01 * k));
  }
  EXPECT_EQ(detect_hold(counts, 3e-6).period_rows, 1);
  EXPECT_EQ(detect_hold(smooth, 0.0).period_rows, 1);
}

// GIVEN a held position with a rest of a second and a time gap (another
// recording) in it, WHEN spread, THEN the rest stays flat (no creep is
// invented across it) and nothing is interpolated across the gap.
TEST(HeldValues, RestAndGapsAreNotSpread) {
  std::vector<double> t, x;
  for (int k = 0; k < 40; ++k) { t.push_back(0.005 * k); x.push_back(0.1 * (k / 4)); }    // moving, held 4 rows
  for (int k = 40; k < 240; ++k) { t.push_back(0.005 * k); x.push_back(x.back()); }       // 1 s at rest
  for (int k = 240; k < 280; ++k) { t.push_back(0.005 * k); x.push_back(1.0 + 0.1 * (k / 4)); }
  for (int k = 0; k < 40; ++k) { t.push_back(10.0 + 0.005 * k); x.push_back(5.0 + 0.1 * (k / 4)); }  // after a 8.6 s gap
  std::vector<double> y = x;
  spread_held_values(y, t, 5, 0.025);
  for (int k = 41; k < 240; ++k) EXPECT_EQ(y[static_cast<std::size_t>(k)], x[static_cast<std::size_t>(k)]) << k;
  for (int k = 280; k < 284; ++k)  // after the gap, as at the start: before its first update, as logged
    EXPECT_EQ(y[static_cast<std::size_t>(k)], x[static_cast<std::size_t>(k)]) << k;
  EXPECT_NE(y[285], x[285]);  // and spread after it
  EXPECT_EQ(y[279], x[279]);  // the last rows before it: no update after them to spread toward
  EXPECT_EQ(y[1], x[1]);      // before the first update: nothing to spread from
  EXPECT_NE(y[5], x[5]);      // a held row inside the motion is spread
}

// GIVEN a 200 Hz log whose position is held for four rows (updated at
// 50 Hz), WHEN the velocity cut-offs to try are set, THEN the lowest is 0.1
// of the update rate (5 Hz), not of the row rate (20 Hz): the SysId roller's
// 40 ms steps overshot to 80 rad/s at 20 Hz, above any speed it reached.
// A log updated every row keeps the row rate's floor, and a fast one 100 Hz.
TEST(HeldValues, AHeldPositionLowersTheLowestVelocityCutOff) {
  Signals s;
  s.sample_rate_hz = 200.0;
  EXPECT_DOUBLE_EQ(lowest_velocity_filter_hz(s), 20.0);
  s.position_hold_rows = 4;
  EXPECT_DOUBLE_EQ(s.position_update_rate_hz(), 50.0);
  EXPECT_DOUBLE_EQ(lowest_velocity_filter_hz(s), 5.0);
  s.sample_rate_hz = 4000.0;
  s.position_hold_rows = 1;
  EXPECT_DOUBLE_EQ(lowest_velocity_filter_hz(s), kLowestVelocityFilter_hz);
  s.position_hold_rows = 8;
  EXPECT_DOUBLE_EQ(lowest_velocity_filter_hz(s), 50.0);
}

}  // namespace
}  // namespace feedid::host
