// `feedid replay` on the command line: exit codes and what it prints for
// bad controller and model files and a missing reference column.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "cli_run.hpp"

using feedid::test::CliRun;
using feedid::test::run_feedid;

namespace {

const std::string dir = ::testing::TempDir();


/// A file name of this test's own (ctest runs the tests in parallel).
std::string own(const std::string& name) {
  return dir + "replay_cli_" + ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_" + name;
}


void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

/// A logged run: the axis at rest where the reference holds it.
std::string write_run() {
  const std::string path = own("run.csv");
  std::ofstream f(path);
  f << "t,x,u,r\n";
  for (int k = 0; k < 500; ++k) f << k * 1e-3 << "," << 0.01 + 1e-6 * k << ",1," << 0.01 + 1e-6 * k << "\n";
  return path;
}

const char* kController = R"({"kp": 50, "kv": 100, "drive_gain": 10, "saturation": 10, "position_fir": [1],
                              "delay_samples": 1, "reference": "r"})";
const char* kModel = R"({"m": 20, "pos": {"sigma": 50, "fc": 2}, "neg": {"sigma": 50, "fc": 2}})";

/// replay of `run` in the loop of `controller` (its text), with kModel and `more` options.
CliRun replay_in_loop(const std::string& run, const std::string& controller, const std::string& more = "") {
  const std::string c = own("c.json"), m = own("m.json");
  write(c, controller);
  write(m, kModel);
  return run_feedid("replay --model " + m + " --controller " + c + " --in " + run + more);
}

TEST(ReplayCli, RunsAndWarnsOfAnUnknownModelKey) {
  const std::string run = write_run(), c = own("c.json"), m = own("m.json");
  write(c, kController);
  write(m, R"({"m": 20, "pos": {"sigma": 50, "fc": 2}, "neg": {"sigma": 50, "fc": 2}, "ofset_N": 1})");
  const CliRun o = run_feedid("replay --model " + m + " --controller " + c + " --in " + run);
  EXPECT_EQ(o.exit_code, 0) << o.err;
  EXPECT_NE(o.err.find("warning: " + m + ": unknown key 'ofset_N'"), std::string::npos) << o.err;
  EXPECT_NE(o.out.find("relative error"), std::string::npos) << o.out;
}

// A review found the report's "made by" without the column options it was
// run with (and without --json): rerun as shown, it failed. It is now the
// command line as typed, each word quoted where a shell needs it.
TEST(ReplayCli, TheReportSaysTheCommandAsTyped) {
  const std::string run = write_run(), c = own("c.json"), m = own("m.json"), json = own("r.json");
  const std::string report = own("the report");  // a space: quoted on the page
  write(c, kController);
  write(m, kModel);
  const std::string args = "replay --model " + m + " --controller " + c + " --in " + run +
                           " --time t --position x --force u --json " + json + " --report '" + report + "'";
  const CliRun o = run_feedid(args);
  ASSERT_EQ(o.exit_code, 0) << o.err;
  const std::string page = feedid::test::read_text(report + "/report.html");
  const std::string words = "replay --model " + m + " --controller " + c + " --in " + run +
                            " --time t --position x --force u --json " + json + " --report '" + report + "'";
  EXPECT_NE(page.find("/feedid " + words + "</code>"), std::string::npos) << page.substr(0, 600);
}

TEST(ReplayCli, AModelInOtherUnitsThanTheLogIsRefused) {
  // GIVEN a rotary model (rad, N m), as identify --axis rotary writes its units
  const std::string run = write_run(), c = own("c.json"), m = own("m.json");
  write(c, kController);
  write(m, R"({"m": 20, "pos": {"sigma": 50, "fc": 2}, "neg": {"sigma": 50, "fc": 2},
              "units": {"position": "rad", "force": "N m"}})");
  // THEN replaying it on a log read as linear is exit 2, naming both units; read as rotary it runs
  const CliRun o = run_feedid("replay --model " + m + " --controller " + c + " --in " + run);
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.err.find("rad"), std::string::npos) << o.err;
  EXPECT_EQ(run_feedid("replay --model " + m + " --controller " + c + " --in " + run + " --axis rotary").exit_code, 0);
}

TEST(ReplayCli, MissingControllerKeyIsExitTwoNamingIt) {
  const std::string run = write_run(), c = own("c.json"), m = own("m.json");
  write(c, R"({"kp": 50, "kv": 100, "saturation": 10, "position_fir": [1], "delay_samples": 1, "reference": "r"})");
  write(m, kModel);
  const CliRun o = run_feedid("replay --model " + m + " --controller " + c + " --in " + run);
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.err.find("missing key 'drive_gain'"), std::string::npos) << o.err;
}

TEST(ReplayCli, MissingReferenceColumnIsNamed) {
  std::string text = kController;
  text.replace(text.find("\"r\""), 3, "\"qg_m\"");
  const CliRun o = replay_in_loop(write_run(), text);
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.err.find("reference column 'qg_m'"), std::string::npos) << o.err;
}

// --drop-first that leaves fewer than 20 samples was refused as "too short
// to replay: 500 samples", as if the file were at fault.
TEST(ReplayCli, DropFirstThatLeavesTooFewSamplesSaysSo) {
  const CliRun o = replay_in_loop(write_run(), kController, " --drop-first 490");
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.err.find("500 samples, of which --drop-first leaves out 490; at least 20 must be left"), std::string::npos)
      << o.err;
}

// A typo in the controller's extra command column replays without it (the
// EMPS controller names pulses that DATA_EMPS lacks: a note, not an
// error), and the note now lists the header, where the typo shows.
TEST(ReplayCli, AMissingExtraCommandColumnIsNotedBesideTheHeader) {
  std::string text = kController;
  text.replace(text.find("\"reference\""), 0, "\"extra_command\": \"pulsesX\", ");
  const CliRun o = replay_in_loop(write_run(), text);
  EXPECT_EQ(o.exit_code, 0) << o.err;
  EXPECT_NE(o.out.find("has no extra command column 'pulsesX' (header has: 't', 'x', 'u', 'r'): none is added"),
            std::string::npos)
      << o.out;
}

// A NaN in the reference column alone was refused as "kept other rows than
// the trace (a bad value in one column only?): first differs at row 301",
// a row count that is not the file's line. The reader's words now say it.
TEST(ReplayCli, ABadValueInTheReferenceAloneIsNamedWithItsLine) {
  const std::string run = own("run.csv");
  {
    std::ofstream f(run);
    f << "t,x,u,r\n";
    for (int k = 0; k < 500; ++k)
      f << k * 1e-3 << "," << 0.01 + 1e-6 * k << ",1," << (k == 300 ? std::string("nan") : std::to_string(0.01 + 1e-6 * k))
        << "\n";
  }
  const CliRun o = replay_in_loop(run, kController);
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.err.find("the reference column 'r' (from the controller file) has a bad row the other columns do not: " +
                       run + ":302: column 'r'"),
            std::string::npos)
      << o.err;
}

}  // namespace
