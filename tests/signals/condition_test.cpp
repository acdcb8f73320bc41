// The conditioning every command starts from (host/signals/condition.hpp):
// the time base of a log whose stamps are uneven.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include "signals/condition.hpp"

namespace feedid::host {
namespace {

/// A reciprocating axis x = A sin(2 pi 0.5 t), u = m a, sampled at the
/// times `sampled` and stamped at `stamped`.
Trace reciprocating_at(const std::vector<double>& sampled, const std::vector<double>& stamped) {
  Trace tr;
  tr.source = "reciprocating";
  tr.has_velocity = false;
  const double A = 0.05, w = 2.0 * M_PI * 0.5, mass = 20.0;
  for (std::size_t k = 0; k < sampled.size(); ++k) {
    const double t = sampled[k];
    tr.samples.push_back({stamped[k], A * std::sin(w * t), 0.0, -mass * A * w * w * std::sin(w * t)});
  }
  return tr;
}

TEST(Condition, ALogInMsReadAsSecondsIsRefusedUnlessItsUnitIsStated) {
  // GIVEN a 1 kHz log stamped in ms, read as s (1 Hz) for want of a unit
  std::vector<double> clock, stamps;
  for (int k = 0; k < 4000; ++k) {
    clock.push_back(1e-3 * k);
    stamps.push_back(static_cast<double>(k));
  }
  Trace tr = reciprocating_at(clock, stamps);
  // WHEN conditioned  THEN it is refused, naming the step and the option that fixes it
  const std::string e = condition(tr, ConditionOptions{}).error;
  EXPECT_FALSE(e.empty()) << "a 1 Hz log with an unstated time unit was taken";
  EXPECT_NE(e.find("--time-scale 0.001"), std::string::npos) << e;
  EXPECT_NE(e.find("reciprocating"), std::string::npos) << e;
  // AND with the unit stated (the user says 1 s steps are meant) it is taken
  tr.time_unit_stated = true;
  EXPECT_EQ(condition(tr, ConditionOptions{}).error, "");
  // AND a 200 Hz log (the slowest drive logs seen) is taken without a stated unit
  std::vector<double> slow;
  for (int k = 0; k < 4000; ++k) slow.push_back(5e-3 * k);
  EXPECT_EQ(condition(reciprocating_at(slow, slow), ConditionOptions{}).error, "");
}

TEST(Condition, JitteredStampsOfAClockedLogAreTakenToTheClock) {
  // GIVEN a 1 kHz log whose stamps were written up to 0.2 ms late or early
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-2e-4, 2e-4);
  std::vector<double> clock, stamps;
  for (int k = 0; k < 4000; ++k) {
    clock.push_back(1e-3 * k);
    stamps.push_back(clock.back() + jitter(rng));
  }
  // WHEN conditioned
  const Signals s = condition(reciprocating_at(clock, stamps), ConditionOptions{});
  // THEN its times are the clock's, to a tenth of the jitter (the clock's
  // phase and period fitted to 4000 stamps of 0.12 ms standard deviation
  // are good to a few microseconds at the ends)
  EXPECT_EQ(s.stretches_on_clock_slots, 1u);
  double worst = 0.0;
  for (std::size_t k = 0; k < clock.size(); ++k) worst = std::max(worst, std::fabs(s.t[k] - clock[k]));
  EXPECT_LT(worst, 2e-5);
}

TEST(Condition, UnevenStampsOfALogSampledWhenReadAreKept) {
  // GIVEN a log sampled at uneven times (0.6-1.4 ms steps) and stamped right
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> step(6e-4, 1.4e-3);
  std::vector<double> times{0.0};
  while (times.size() < 4000) times.push_back(times.back() + step(rng));
  // WHEN conditioned
  const Signals s = condition(reciprocating_at(times, times), ConditionOptions{});
  // THEN the stamps stay: on them the motion is smoother than on any clock's slots
  EXPECT_EQ(s.stretches_on_clock_slots, 0u);
  for (std::size_t k = 0; k < times.size(); ++k) ASSERT_EQ(s.t[k], times[k]);
}

// GIVEN a 1 kHz log from a 50 nm encoder far from its origin (0.25 m), its
// positions moved by 1e-13 relative as a parser that does not round
// correctly leaves them, THEN the encoder quantum is still found, and
// where it was (the smallest step moved by 5e-7, a 2000-count step missed
// the lattice, and the quantum was lost: EMPS's band edge fell sixfold).
TEST(Condition, TheEncoderQuantumSurvivesTheLastDigitsOfThePositions) {
  const double q = 5e-8;
  Trace tr;
  tr.source = "quantised";
  tr.time_unit_stated = true;
  for (int k = 0; k < 20000; ++k) {
    // a creep at 0.4 counts per sample (steps of one count), then strokes of up to 2500
    const double t = 1e-3 * k, x = k < 5000 ? 0.25 + 2e-5 * t : 0.2501 + 0.1 * std::sin(2.0 * M_PI * 0.2 * (t - 5.0));
    const double moved = std::round(x / q) * q * (1.0 + 1e-13 * static_cast<double>(k % 3 - 1));
    tr.samples.push_back({t, moved, 0.0, 10.0 * std::cos(2.0 * M_PI * 0.2 * t)});
  }
  const Signals s = condition(tr, ConditionOptions{});
  EXPECT_NEAR(s.position_quantum_m, q, 1e-5 * q);  // the smallest step, with its last digits
}

}  // namespace
}  // namespace feedid::host
