// Running the feedid command line from a test: one helper for every CLI test.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

namespace feedid::test {

/// What a run of the feedid command line left: its exit code (-1 where it
/// did not exit), its stdout and its stderr.
struct CliRun {
  int exit_code = -1;
  std::string out, err;
};

inline std::string read_text(const std::string& path) {
  std::ifstream f(path);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

/// feedid with `args`. Its output goes to files of the running test's own
/// (ctest runs the tests in parallel processes).
inline CliRun run_feedid(const std::string& args) {
  const ::testing::TestInfo& test = *::testing::UnitTest::GetInstance()->current_test_info();
  const std::string base = ::testing::TempDir() + "feedid_cli_" + test.test_suite_name() + "_" + test.name();
  const std::string out = base + ".out", err = base + ".err";
  const int rc = std::system((std::string(FEEDID_BIN_DIR) + "/feedid " + args + " >" + out + " 2>" + err).c_str());
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, read_text(out), read_text(err)};
}

}  // namespace feedid::test
