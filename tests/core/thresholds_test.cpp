// docs/reference.md's "Thresholds" table states the values of
// core/feedid/thresholds.hpp: the docs are checked against the one header
// the core's rules read, so that neither drifts from the other.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "feedid/analysis.hpp"
#include "feedid/thresholds.hpp"

namespace {

/// Rows `| `name` | value | ... |` of the section that starts at `heading`.
std::map<std::string, double> doc_table(const std::string& path, const std::string& heading) {
  std::ifstream in(path);
  std::map<std::string, double> rows;
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (line.rfind("## ", 0) == 0) inside = line == heading;
    if (!inside || line.rfind("| `", 0) != 0) continue;
    const std::size_t a = 3, b = line.find('`', a);
    const std::size_t c = line.find('|', b);
    const std::size_t d = line.find('|', c + 1);
    rows[line.substr(a, b - a)] = std::stod(line.substr(c + 1, d - c - 1));
  }
  return rows;
}

TEST(Thresholds, ReferenceDocStatesTheCoreHeadersValues) {
  namespace th = feedid::thresholds;
  const std::map<std::string, double> header = {
      {"kFrictionRelativeSe", th::kFrictionRelativeSe},
      {"kMassRelativeSe", th::kMassRelativeSe},
      {"kMinBandTime_s", th::kMinBandTime_s},
      {"kStribeckGridPoints", th::kStribeckGridPoints},
      {"kStribeckLowOfVelocityMin", th::kStribeckLowOfVelocityMin},
      {"kStribeckHighOfVelocityMax", th::kStribeckHighOfVelocityMax},
      {"kStribeckFloorResolutions", th::kStribeckFloorResolutions},
      {"kStribeckFloorOfVelocityMin", th::kStribeckFloorOfVelocityMin},
      {"kStribeckSlowTime_s", th::kStribeckSlowTime_s},
      {"kStribeckSlowBands", th::kStribeckSlowBands},
  };
  const auto doc = doc_table(std::string(FEEDID_SOURCE_DIR) + "/docs/reference.md", "## Thresholds");
  ASSERT_EQ(doc.size(), header.size()) << "docs/reference.md, Thresholds: one row per constant of thresholds.hpp";
  for (const auto& [name, value] : header) {
    const auto it = doc.find(name);
    ASSERT_NE(it, doc.end()) << name << " is missing from docs/reference.md, Thresholds";
    EXPECT_DOUBLE_EQ(it->second, value) << name;
  }
}

TEST(Thresholds, TheCoresRulesUseThem) {
  feedid::DirectionEstimate<double> e{};
  e.coulomb_N = 20.0;
  e.coulomb_se = 20.0 * feedid::thresholds::kFrictionRelativeSe * 0.99;
  EXPECT_EQ(feedid::analysis::coulomb_uncertainty_flags(e), 0u);
  e.coulomb_se = 20.0 * feedid::thresholds::kFrictionRelativeSe * 1.01;
  EXPECT_NE(feedid::analysis::coulomb_uncertainty_flags(e), 0u);
  e.viscous_Ns_m = -700.0;  // the rule reads the size, whatever the sign
  e.viscous_se = 700.0 * feedid::thresholds::kFrictionRelativeSe * 0.99;
  EXPECT_EQ(feedid::analysis::viscous_uncertainty_flags(e), 0u);
  e.viscous_se = 700.0 * feedid::thresholds::kFrictionRelativeSe * 1.01;
  EXPECT_EQ(feedid::analysis::viscous_uncertainty_flags(e), static_cast<uint32_t>(feedid::flag_viscous_uncertain));
  e.viscous_se = std::nan("");
  EXPECT_NE(feedid::analysis::viscous_uncertainty_flags(e), 0u);
  EXPECT_EQ(feedid::analysis::mass_uncertainty_flags(100.0, 100.0 * feedid::thresholds::kMassRelativeSe * 0.99), 0u);
  EXPECT_NE(feedid::analysis::mass_uncertainty_flags(100.0, 100.0 * feedid::thresholds::kMassRelativeSe * 1.01), 0u);
  feedid::Config<double> c;
  c.velocity_min_m_s = 1e-4;
  c.velocity_max_m_s = 0.2;
  EXPECT_DOUBLE_EQ(feedid::analysis::stribeck_lo(c), feedid::thresholds::kStribeckLowOfVelocityMin * 1e-4);
  EXPECT_DOUBLE_EQ(feedid::analysis::stribeck_hi(c), feedid::thresholds::kStribeckHighOfVelocityMax * 0.2);
}

// GIVEN band points of a friction curve that falls across every speed
// (30 N at rest to 27 N), THEN the Coulomb + viscous slope is held at 0
// with Fc the time-weighted mean and the direction flagged; a rising
// curve, and one of negative level (a reversed force), are left as fitted.
TEST(Thresholds, AFallingCurvesSlopeIsHeldAtItsBound) {
  auto points = [](double level, double slope) {
    feedid::analysis::FrictionPoints<double, 8> p;
    for (int k = 0; k < 6; ++k) {
      const double t = 0.1 * (k + 1), v = 1e-3 * (k + 1);
      (void)feedid::analysis::add_friction_point(p, t, v * t, v * v * t, (level + slope * v) * t);
    }
    return p;
  };
  auto held = [&](double level, double slope, feedid::Vector<double, 3>& th) {
    const auto p = points(level, slope);
    double ssr = 0.0;
    EXPECT_TRUE(feedid::analysis::fit_coulomb_viscous_at(p, th, ssr));
    return feedid::analysis::hold_falling_friction(p, th, ssr);
  };
  feedid::Vector<double, 3> th;
  EXPECT_EQ(held(30.0, -500.0, th), static_cast<uint32_t>(feedid::flag_friction_still_falling));
  EXPECT_EQ(th.v[1], 0.0);
  const auto p = points(30.0, -500.0);
  double mean = 0.0;
  for (int k = 0; k < p.count; ++k) mean += p.target[k];
  EXPECT_NEAR(th.v[0], mean / p.total_time, 1e-9);
  EXPECT_EQ(held(30.0, 500.0, th), 0u);
  EXPECT_NEAR(th.v[1], 500.0, 1e-6);
  EXPECT_EQ(held(-30.0, -500.0, th), 0u);
  EXPECT_NEAR(th.v[1], -500.0, 1e-6);
}

}  // namespace
