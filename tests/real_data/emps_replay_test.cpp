// Real data: the EMPS drive replayed in its own loop (docs/examples/
// emps_controller.json) against the published closed-loop simulation
// figures (EMPS_Description.pdf §3.5; ../shared/data/emps/README.md).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <utility>

#include "gap/model_gap.hpp"
#include "identify/identify.hpp"
#include "io/trace_files.hpp"
#include "model/model_file.hpp"
#include "replay/replay.hpp"
#include "real_data/emps_data.hpp"

namespace {

using namespace feedid::host;
using feedid::test::emps_columns;
using feedid::test::emps_dir;
const std::string examples = std::string(FEEDID_SOURCE_DIR) + "/docs/examples";

/// Published figures (%): velocity, acceleration, force.
struct Published {
  const char* file;
  double velocity, acceleration, force;
};
const Published kPublished[] = {{"DATA_EMPS.csv", 0.22911, 8.6036, 5.848}, {"DATA_EMPS_PULSES.csv", 0.47888, 19.8152, 8.9409}};

class EmpsReplay : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(emps_dir + "/DATA_EMPS_PULSES.csv"))
      GTEST_SKIP() << "EMPS data not found at " << emps_dir << " (the shared/ folder is absent); skipping real-data test";
  }
  ReplayResult replay_on(const ModelFile& m, const std::string& file, const ReplayOptions& opt = {}) {
    const Controller c = read_controller_file(examples + "/emps_controller.json");
    return replay(m, c, read_logged_run(emps_dir + "/" + file, emps_columns(), c), opt);
  }
};

TEST_F(EmpsReplay, PublishedModelReplaysWithinTwentyPercentOfThePublishedFigures) {
  const ModelFile ref = read_model_file(examples + "/emps_reference_model.json");
  for (const Published& p : kPublished) {
    const ReplayResult r = replay_on(ref, p.file);
    EXPECT_NEAR(r.error_pct.velocity, p.velocity, 0.2 * p.velocity) << p.file;
    EXPECT_NEAR(r.error_pct.acceleration, p.acceleration, 0.2 * p.acceleration) << p.file;
    EXPECT_NEAR(r.error_pct.force, p.force, 0.2 * p.force) << p.file;
  }
}

/// How far each figure of the published model moves when its parameters
/// move by their published standard errors (§3.4: M 0.1085 kg, Fv 1.1460
/// N s/m, Fc 0.1012 N, offset 0.0444 N), one at a time, added in
/// quadrature: the resolution at which "no worse" can be told.
ReplayFigures figure_se(const ModelFile& ref, const ReplayFigures& at_ref,
                        const std::function<ReplayFigures(const ModelFile&)>& figures_of) {
  const std::function<void(ModelFile&)> moves[] = {
      [](ModelFile& m) { m.drive.mass_kg += 0.1085; },
      [](ModelFile& m) { m.drive.pos.viscous_Ns_m += 1.1460, m.drive.neg.viscous_Ns_m += 1.1460; },
      [](ModelFile& m) { m.drive.pos.coulomb_N += 0.1012, m.drive.neg.coulomb_N += 0.1012; },
      [](ModelFile& m) { m.load.offset_N += 0.0444; }};
  ReplayFigures se;
  for (const auto& move : moves) {
    ModelFile m = ref;
    move(m);
    const ReplayFigures f = figures_of(m);
    se.velocity = std::hypot(se.velocity, f.velocity - at_ref.velocity);
    se.acceleration = std::hypot(se.acceleration, f.acceleration - at_ref.acceleration);
    se.force = std::hypot(se.force, f.force - at_ref.force);
  }
  return se;
}

TEST_F(EmpsReplay, HalvingTheStepChangesNoFigureByMoreThanOnePercent) {
  // On the run whose pulses step the force (the hardest for the integrator)
  const ModelFile ref = read_model_file(examples + "/emps_reference_model.json");
  const ReplayResult coarse = replay_on(ref, "DATA_EMPS_PULSES.csv");
  ReplayOptions fine;
  fine.substeps = 2 * coarse.substeps;
  const ReplayFigures a = coarse.error_pct;
  const ReplayFigures b = replay_on(ref, "DATA_EMPS_PULSES.csv", fine).error_pct;
  for (const auto& [x, y] : {std::pair{a.position, b.position}, std::pair{a.velocity, b.velocity},
                             std::pair{a.acceleration, b.acceleration}, std::pair{a.force, b.force}})
    EXPECT_NEAR(x, y, 0.01 * y);
}

TEST_F(EmpsReplay, IdentifiedModelReplaysNoWorseThanThePublishedOne) {
  // GIVEN feedid's model identified on DATA_EMPS, through the model file as the CLI reads it
  const CsvResult id_in = read_trace_file(emps_dir + "/DATA_EMPS.csv", emps_columns());
  ASSERT_TRUE(id_in.ok) << id_in.error;
  const IdentifyResult id = identify(id_in.trace, IdentifyOptions{});
  ASSERT_EQ(id.status, feedid::Status::ok) << id.error;
  const ModelFile mine = model_file_from_json(to_json(id), "identify");
  const ModelFile ref = read_model_file(examples + "/emps_reference_model.json");
  for (const Published& p : kPublished) {
    auto figures_of = [&](const ModelFile& m) { return replay_on(m, p.file).error_pct; };
    const ReplayFigures a = figures_of(mine), b = figures_of(ref);
    const ReplayFigures se = figure_se(ref, b, figures_of);
    // THEN no figure is worse than the published model's by more than the
    // published parameters' own standard errors make it uncertain
    EXPECT_LE(a.velocity, b.velocity + se.velocity) << p.file;
    EXPECT_LE(a.acceleration, b.acceleration + se.acceleration) << p.file;
    EXPECT_LE(a.force, b.force + se.force) << p.file;
    // AND the force, which the identification fits, is better outright
    EXPECT_LT(a.force, b.force) << p.file;
  }
}

// Issue 28's bar for `diagnose --model M --controller C` on PULSES, M
// identified on DATA_EMPS: a cause named, the held-out acceleration error
// at most 12 % with it (published 19.8 %), the force error not grown.
TEST_F(EmpsReplay, DiagnoseOfTheIdentifiedModelOnPulsesNamesACauseAndClosesTheAccelerationGap) {
  const CsvResult id_in = read_trace_file(emps_dir + "/DATA_EMPS.csv", emps_columns());
  ASSERT_TRUE(id_in.ok) << id_in.error;
  const IdentifyResult id = identify(id_in.trace, IdentifyOptions{});
  ASSERT_EQ(id.status, feedid::Status::ok) << id.error;
  DiagnoseOptions opt;
  opt.model = model_file_from_json(to_json(id), "identify");
  opt.threads = 3;
  const Controller c = read_controller_file(examples + "/emps_controller.json");
  const CsvResult pulses = read_trace_file(emps_dir + "/DATA_EMPS_PULSES.csv", emps_columns());
  ASSERT_TRUE(pulses.ok) << pulses.error;
  const LoggedRun run = read_logged_run(emps_dir + "/DATA_EMPS_PULSES.csv", emps_columns(), c);
  const ModelGap g = model_gap(pulses.trace, opt, &c, &run, ReplayOptions{});
  ASSERT_TRUE(g.diagnosis.error.empty()) << g.diagnosis.error;
  ASSERT_TRUE(g.replayed);
  EXPECT_TRUE(g.comparison_named || !g.diagnosis.effects.empty()) << summary(g);
  EXPECT_LE(g.after_pct.acceleration, 12.0) << summary(g);
  EXPECT_LE(g.after_pct.force, g.before_pct.force) << summary(g);
  // The effects in the plant alone do not grow the force error either.
  EXPECT_LE(g.after_effects_pct.force, g.before_pct.force) << summary(g);
  // The families, and here the pairs of them, were searched on three
  // threads, the replay before the causes beside them: on one the
  // diagnosis and both replays are the same to the bit.
  ASSERT_GE(g.diagnosis.effects.size(), 2u) << summary(g);
  // AND the two are named as a pair, each naming the other, and the summary
  // says so (neither passes alone: the first step's table shows z 2.3 and
  // 2.7, which a review read as the verdict contradicting its table)
  EXPECT_EQ(g.diagnosis.effects[0].named_with, g.diagnosis.effects[1].kind) << summary(g);
  EXPECT_EQ(g.diagnosis.effects[1].named_with, g.diagnosis.effects[0].kind) << summary(g);
  EXPECT_NE(summary(g.diagnosis).find("close the gap only together"), std::string::npos) << summary(g.diagnosis);
  DiagnoseOptions one = opt;
  one.threads = 1;
  EXPECT_EQ(to_json(model_gap(pulses.trace, one, &c, &run, ReplayOptions{})).dump(), to_json(g).dump());
}

TEST_F(EmpsReplay, LoggedCommandRevealsTheDocumentedGains) {
  // GIVEN the controller file without kp and kv, on the run without pulses
  nlohmann::json j = read_json_file(examples + "/emps_controller.json").value;
  j.erase("kp");
  j.erase("kv");
  const Controller c = controller_from_json(j, "emps_controller.json without gains");
  const ReplayResult r = replay(read_model_file(examples + "/emps_reference_model.json"), c,
                                read_logged_run(emps_dir + "/DATA_EMPS.csv", emps_columns(), c), ReplayOptions{});
  ASSERT_EQ(r.error, "");
  // THEN the fit finds the documented kp 160.18 and kv 243.45 within 1 %
  ASSERT_TRUE(r.gain_fit.done);
  EXPECT_NEAR(r.gain_fit.value.kp, 160.18, 0.01 * 160.18);
  EXPECT_NEAR(r.gain_fit.value.kv, 243.45, 0.01 * 243.45);
}

TEST_F(EmpsReplay, PulsesEnterTheLoggedCommandAsTheReadmeFound) {
  // GIVEN the PULSES run, whose vir holds the control law plus about 1.014 pulses (README, doubtful point 1)
  const Controller c = read_controller_file(examples + "/emps_controller.json");
  const ReplayResult r = replay(read_model_file(examples + "/emps_reference_model.json"), c,
                                read_logged_run(emps_dir + "/DATA_EMPS_PULSES.csv", emps_columns(), c), ReplayOptions{},
                                true);
  ASSERT_EQ(r.error, "");
  // THEN the fit finds that gain, and with it the documented kv within 0.1 %
  EXPECT_NEAR(r.gain_fit.extra_gain, 1.014, 0.002);
  EXPECT_NEAR(r.gain_fit.value.kv, 243.45, 0.001 * 243.45);
}

}  // namespace
