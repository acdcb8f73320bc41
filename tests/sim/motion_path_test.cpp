// Reference paths of the simulators (host_sim/sim/motion_path.hpp). GIVEN each
// motion program, WHEN the path is read forward in time, THEN it stays in
// the travel, its velocity is the derivative of its position, and its
// acceleration stays within the bound, so the open-loop plant's inverse
// dynamics see what a drive's trajectory generator would give it.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "sim/motion_path.hpp"

namespace feedid::test {
namespace {

using host::MotionParams;
using host::MotionPath;
using host::PathPoint;
using host::Program;

class EveryProgram : public ::testing::TestWithParam<Program> {};

TEST_P(EveryProgram, StaysInTravelWithConsistentDerivativesAndBoundedAcceleration) {
  MotionParams m;
  m.program = GetParam();
  m.duration_s = 60.0;
  MotionPath path(m, 3);
  const double h = 1e-4;
  PathPoint prev = path.at(0.0);
  int reversals = 0;
  double last_sign = 0.0;
  for (double t = h; t < m.duration_s; t += h) {
    const PathPoint p = path.at(t);
    ASSERT_GE(p.x_m, -1e-12) << t;
    ASSERT_LE(p.x_m, m.max_travel_m + 1e-12) << t;
    ASSERT_LE(std::fabs(p.a_m_s2), m.acceleration_m_s2 * (1 + 1e-9)) << t;
    // Position difference against the mean velocity over the step.
    ASSERT_NEAR((p.x_m - prev.x_m) / h, 0.5 * (p.v_m_s + prev.v_m_s), m.acceleration_m_s2 * h) << t;
    ASSERT_LE(std::fabs(p.v_m_s - prev.v_m_s), m.acceleration_m_s2 * h * (1 + 1e-9)) << t;
    const double sign = p.v_m_s > 0 ? 1.0 : (p.v_m_s < 0 ? -1.0 : 0.0);
    if (sign != 0.0 && last_sign != 0.0 && sign != last_sign) ++reversals;
    if (sign != 0.0) last_sign = sign;
    prev = p;
  }
  EXPECT_GE(reversals, 10) << host::program_name(GetParam());
}

INSTANTIATE_TEST_SUITE_P(Programs, EveryProgram, ::testing::Values(Program::ladder, Program::sine, Program::production),
                         [](const auto& info) { return std::string(host::program_name(info.param)); });

TEST(ProductionProgram, HasRapidsAtTopSpeedThreeFeedRatesAndDwells) {
  MotionParams m;
  m.program = Program::production;
  m.duration_s = 120.0;
  MotionPath path(m, 4);
  std::set<long> cruise_speeds_um_s;
  double longest_rest_s = 0.0;
  for (const host::PathPiece& p : path.pieces()) {
    if (p.shape != host::PathPiece::Shape::polynomial || p.a_m_s2 != 0.0) continue;
    if (p.v0_m_s == 0.0) longest_rest_s = std::max(longest_rest_s, p.duration_s);
    else if (std::fabs(p.v0_m_s) >= 0.02 * m.fastest_speed_m_s)
      cruise_speeds_um_s.insert(std::lround(std::fabs(p.v0_m_s) * 1e6));
  }
  EXPECT_TRUE(cruise_speeds_um_s.count(std::lround(m.fastest_speed_m_s * 1e6)));
  EXPECT_EQ(cruise_speeds_um_s.size(), 4u);  // the rapid and three feeds (jogs are below 2 %)
  EXPECT_GE(longest_rest_s, 0.2);
}

TEST(MotionProgram, UnknownNameIsRejectedByName) {
  EXPECT_EQ(host::parse_program("sine").value, Program::sine);
  EXPECT_TRUE(host::parse_program("sine").ok());
  const host::Outcome<Program> circle = host::parse_program("circle");
  EXPECT_FALSE(circle.ok()) << "accepted an unknown program";
  EXPECT_NE(circle.error.find("--program"), std::string::npos) << circle.error;
}

}  // namespace
}  // namespace feedid::test
