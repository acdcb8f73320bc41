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
  EXPECT_EQ(feedid::analysis::mass_uncertainty_flags(100.0, 100.0 * feedid::thresholds::kMassRelativeSe * 0.99), 0u);
  EXPECT_NE(feedid::analysis::mass_uncertainty_flags(100.0, 100.0 * feedid::thresholds::kMassRelativeSe * 1.01), 0u);
  feedid::Config<double> c;
  c.velocity_min_m_s = 1e-4;
  c.velocity_max_m_s = 0.2;
  EXPECT_DOUBLE_EQ(feedid::analysis::stribeck_lo(c), feedid::thresholds::kStribeckLowOfVelocityMin * 1e-4);
  EXPECT_DOUBLE_EQ(feedid::analysis::stribeck_hi(c), feedid::thresholds::kStribeckHighOfVelocityMax * 0.2);
}

}  // namespace
