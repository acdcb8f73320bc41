// Real data: WPILib SysId recordings of two drivetrains and a roller
// (../shared/data/sysid_team581; README there). Four files per mechanism,
// one direction and one test each (slow ramp, fast step), uneven sampling
// around 200 Hz, a velocity filtered inside the motor controller, volts for
// force. SysId's own gains from the same recordings are the reference:
// kS (Coulomb), kV (viscous), kA (mass). Skipped without the shared folder.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "io/trace_files.hpp"
#include "identify/identify.hpp"
#include "diagnose/diagnose.hpp"

namespace {

using namespace feedid::host;

const std::string sysid_dir = std::string(FEEDID_SHARED_DIR) + "/data/sysid_team581";

struct Mechanism {
  const char* prefix;
  double ks_V, kv_Vs_rad, ka_Vs2_rad;
  /// The roller's friction falls with speed and our Coulomb + viscous line
  /// sits 2.2 standard errors above kS: a known miss (docs/sysid.md), where
  /// only the flag is claimed.
  bool coulomb_within_2se = true;
};

class SysId : public ::testing::TestWithParam<Mechanism> {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(sysid_dir + "/compbot_drive_left_slow_fwd.csv"))
      GTEST_SKIP() << "SysId data not found at " << sysid_dir << " (the shared/ folder is absent)";
  }
};

// GIVEN a mechanism's four recordings pooled (each its own run), WHEN
// identify runs with nothing told, THEN the Stribeck law is not kept (its
// fit came out with a negative Coulomb term), both directions fall back to
// Coulomb + viscous and agree, the viscous term is within 3 % of SysId's kV,
// the Coulomb term is positive and (but on the roller) within 2 standard
// errors of kS, the mass is within 30 % of kA, and a Coulomb term more than
// 30 % from kS is flagged.
TEST_P(SysId, PooledRecordingsGiveSysIdsFrictionWithoutAStribeckTerm) {
  const Mechanism m = GetParam();
  std::vector<std::string> files;
  for (const char* test : {"slow_fwd", "slow_bwd", "fast_fwd", "fast_bwd"})
    files.push_back(sysid_dir + "/" + m.prefix + "_" + test + ".csv");
  const CsvResult in = read_trace_files(files, CsvColumns{});
  ASSERT_TRUE(in.ok) << in.error;
  const IdentifyResult r = identify(in.trace, IdentifyOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  for (int d = 0; d < 2; ++d) {
    SCOPED_TRACE(d == 0 ? "forward" : "backward");
    EXPECT_FALSE(r.friction_model[static_cast<std::size_t>(d)].stribeck) << r.friction_model[static_cast<std::size_t>(d)].reason;
    const auto& de = d == 0 ? r.estimate.pos : r.estimate.neg;
    EXPECT_FALSE(de.stribeck_identified());
  }
  const SymmetricFriction sym = symmetric_friction(r);
  ASSERT_TRUE(sym.agree) << summary(r);
  EXPECT_NEAR(sym.viscous_Ns_m, m.kv_Vs_rad, 0.03 * m.kv_Vs_rad) << summary(r);
  EXPECT_GT(sym.coulomb_N, 0.0) << summary(r);
  if (m.coulomb_within_2se) EXPECT_NEAR(sym.coulomb_N, m.ks_V, 2.0 * sym.coulomb_se) << summary(r);
  // The mass (kA) comes from the fast steps: 8-sample blocks at 200 Hz.
  // Within 30 % of kA on all five since no block spans the gap between two
  // recordings (a 10 s block had set the lag search and the mass).
  EXPECT_NEAR(r.estimate.mass_kg, m.ka_Vs2_rad, 0.3 * m.ka_Vs2_rad) << summary(r);
  // The bar: kS within 30 %, or flagged (never a confident number that misses).
  if (std::fabs(sym.coulomb_N / m.ks_V - 1.0) > 0.3) EXPECT_FALSE(sym.coulomb_identified()) << summary(r);
}

// GIVEN the test robot's left drivetrain, whose loop logged every 5 ms the
// position its motor controller sent every 20 ms, WHEN identify and
// diagnose read it, THEN both name the hold (4 rows), and the diagnosis,
// which spreads the held values between their updates, runs (its backward
// differences of the held position put the lowest band at 25 rad/s, and
// nothing could be identified), with held-out observations to judge by.
TEST(SysIdLogs, HeldPositionIsFoundAndTheDiagnosisRuns) {
  if (!std::filesystem::exists(sysid_dir + "/test2020bot_drive_left_slow_fwd.csv"))
    GTEST_SKIP() << "SysId data not found at " << sysid_dir;
  std::vector<std::string> files;
  for (const char* test : {"slow_fwd", "slow_bwd", "fast_fwd", "fast_bwd"})
    files.push_back(sysid_dir + "/test2020bot_drive_left_" + test + ".csv");
  const CsvResult in = read_trace_files(files, CsvColumns{});
  ASSERT_TRUE(in.ok) << in.error;
  const IdentifyResult r = identify(in.trace, IdentifyOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.signals.position_hold_rows, 4);
  EXPECT_FALSE(r.signals.held_values_spread);
  const DiagnoseResult dg = diagnose(in.trace, DiagnoseOptions{});
  ASSERT_TRUE(dg.error.empty()) << dg.error;
  EXPECT_NE(dg.position_origin.find("held for 4 rows"), std::string::npos) << dg.position_origin;
  EXPECT_GT(dg.blocks_heldout, 50u);
}

INSTANTIATE_TEST_SUITE_P(Team581, SysId,
                         ::testing::Values(Mechanism{"compbot_drive_left", 0.060039, 0.22421, 0.011814},
                                           Mechanism{"compbot_drive_right", 0.060039, 0.22421, 0.011814},
                                           Mechanism{"test2020bot_drive_left", 0.088986, 0.18647, 0.0076096},
                                           Mechanism{"test2020bot_drive_right", 0.088986, 0.18647, 0.0076096},
                                           Mechanism{"compbot_spu", 0.019184, 0.17836, 0.002161, false}),
                         [](const auto& info) { return std::string(info.param.prefix); });

}  // namespace
