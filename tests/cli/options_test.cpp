// Numbers in options are checked as they are parsed: a value that is not
// a finite number, a negative cut-off or a zero scale is a usage error
// (exit 2) naming the option, never taken as "from the data".
#include <gtest/gtest.h>

#include <string>

#include "cli_run.hpp"

namespace {

/// feedid's exit code.
int exit_code(const std::string& args) { return feedid::test::run_feedid(args).exit_code; }

TEST(Options, InvalidNumbersAreUsageErrors) {
  // GIVEN a trace that identifies (exit 0) with plain values of the same options
  const std::string in = ::testing::TempDir() + "feedid_options_30s.csv";
  ASSERT_EQ(exit_code("simulate --duration 30 --out " + in), 0);
  ASSERT_EQ(exit_code("identify --in " + in + " --velocity-filter 300 --force-lag-s 0 --velocity-min 0.0002 --force-scale 2"), 0);
  // THEN each invalid number is a usage error
  for (const char* bad : {"--velocity-filter -5", "--force-lag-s nan", "--velocity-lag-s inf", "--velocity-min -1",
                          "--force-scale 0", "--position-scale nan", "--time-scale -0.001", "--velocity-filter 3x"})
    EXPECT_EQ(exit_code("identify --in " + in + " " + bad), 2) << bad;
}

TEST(Options, TheDefaultsStillParse) {
  // The --help of each command lists the defaults, which must pass their own checks.
  EXPECT_EQ(exit_code("identify --help"), 0);
  EXPECT_EQ(exit_code("validate --help"), 0);
  EXPECT_EQ(exit_code("diagnose --help"), 0);
}

TEST(Options, AFileGivenTwiceIsPooledWithAWarning) {
  const std::string in = ::testing::TempDir() + "feedid_options_twice.csv";
  ASSERT_EQ(exit_code("simulate --duration 30 --out " + in), 0);
  const feedid::test::CliRun twice = feedid::test::run_feedid("identify --in " + in + " --in " + in);
  EXPECT_EQ(twice.exit_code, 0);
  EXPECT_NE(twice.err.find("is given twice"), std::string::npos) << twice.err;
}

TEST(Options, ARotaryModelIsNotValidatedOnALinearLog) {
  // GIVEN a model identified as a rotary axis
  const std::string in = ::testing::TempDir() + "feedid_options_units.csv";
  const std::string model = ::testing::TempDir() + "feedid_options_units.json";
  ASSERT_EQ(exit_code("simulate --duration 30 --out " + in), 0);
  ASSERT_EQ(exit_code("identify --in " + in + " --axis rotary --json " + model), 0);
  // THEN validating it on the log read as linear is refused, and read as rotary it runs
  EXPECT_EQ(exit_code("validate --model " + model + " --in " + in), 2);
  EXPECT_EQ(exit_code("validate --model " + model + " --in " + in + " --axis rotary"), 0);
}

}  // namespace
