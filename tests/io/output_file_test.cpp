// Outputs are written whole or not at all, and never over an input
// (host_sim/io/output_file.hpp; the CLI's check in main.cpp).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cli_run.hpp"
#include "io/output_file.hpp"

namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::ostringstream o;
  o << f.rdbuf();
  return o.str();
}

/// A fresh folder per test, so that a left-over temporary would show.
fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("feedid_output_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::size_t entries(const fs::path& d) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(d)) ++n;
  return n;
}

TEST(OutputFile, CommitReplacesTheFileWholeAndLeavesNoTemporary) {
  const fs::path d = fresh_dir("commit");
  const std::string p = (d / "a.json").string();
  ASSERT_EQ(feedid::host::write_whole_file(p, "old\n"), "");
  ASSERT_EQ(feedid::host::write_whole_file(p, "new\n"), "");
  EXPECT_EQ(slurp(p), "new\n");
  EXPECT_EQ(entries(d), 1u);
  fs::remove_all(d);
}

// A link is written through: its target gets the new file and the link
// stays (renaming over the link replaced it, as root even /dev/stdout).
// A redirected /dev/stdout is written in place, not renamed over.
TEST(OutputFile, ALinkIsWrittenThroughAndStaysALink) {
  const fs::path d = fresh_dir("link");
  const fs::path target = d / "model.json", link = d / "latest.json";
  ASSERT_EQ(feedid::host::write_whole_file(target.string(), "old\n"), "");
  fs::create_symlink(target.filename(), link);
  ASSERT_EQ(feedid::host::write_whole_file(link.string(), "new\n"), "");
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(link)));
  EXPECT_EQ(slurp(target), "new\n");
  EXPECT_EQ(entries(d), 2u) << "no temporary left";
  const feedid::test::CliRun to_stdout = feedid::test::run_feedid("simulate --duration 1 --out /dev/stdout");
  EXPECT_EQ(to_stdout.exit_code, 0);
  EXPECT_EQ(to_stdout.out.rfind("t,x,v,u\n", 0), 0u) << "the trace reached the redirected stdout";
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status("/dev/stdout")) || !fs::is_regular_file(fs::symlink_status("/dev/stdout")));
  fs::remove_all(d);
}

TEST(OutputFile, AnOutputNeverCommittedLeavesThePreviousFileAsItWas) {
  const fs::path d = fresh_dir("abandon");
  const std::string p = (d / "trace.csv").string();
  ASSERT_EQ(feedid::host::write_whole_file(p, "t,x,v,u\n0,0,0,0\n"), "");
  {
    feedid::host::OutputFile f(p);
    ASSERT_TRUE(f.ok()) << f.error();
    f.write("t,x,v,u\n0,0");  // interrupted before commit()
  }
  EXPECT_EQ(slurp(p), "t,x,v,u\n0,0,0,0\n");
  EXPECT_EQ(entries(d), 1u) << "the temporary must be gone";
  fs::remove_all(d);
}

TEST(OutputFile, AFullDeviceIsAnErrorThatSaysWhy) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full here";
  const std::string err = feedid::host::write_whole_file("/dev/full", std::string(1 << 16, 'x'));
  ASSERT_FALSE(err.empty());
  EXPECT_NE(err.find("/dev/full: cannot write"), std::string::npos) << err;
}

TEST(OutputFile, AMissingFolderIsAnErrorThatNamesThePath) {
  const std::string err = feedid::host::write_whole_file("/nonexistent-folder-feedid/x.json", "{}");
  EXPECT_NE(err.find("/nonexistent-folder-feedid/x.json: cannot write"), std::string::npos) << err;
}

TEST(OutputFile, AnOutputOverAnInputIsRefusedAndTheInputKept) {
  const fs::path d = fresh_dir("input");
  const std::string in = (d / "run.csv").string();
  ASSERT_EQ(feedid::host::write_whole_file(in, "t,x,v,u\n"), "");
  const std::string err = feedid::host::write_whole_file((d / "." / "run.csv").string(), "{}", {in});
  EXPECT_NE(err.find("refusing to write an output over the input"), std::string::npos) << err;
  EXPECT_EQ(slurp(in), "t,x,v,u\n");
  fs::remove_all(d);
}

TEST(OutputFile, TheCliRefusesAJsonOverItsInputWithExit2) {
  const fs::path d = fresh_dir("cli");
  const std::string trace = (d / "t.csv").string();
  ASSERT_EQ(feedid::test::run_feedid("simulate --duration 5 --out " + trace).exit_code, 0);
  const std::string before = slurp(trace);
  EXPECT_EQ(feedid::test::run_feedid("identify --in " + trace + " --json " + trace).exit_code, 2);
  EXPECT_EQ(slurp(trace), before);
  EXPECT_EQ(feedid::test::run_feedid("simulate --duration 1 --out /dev/full").exit_code, 1) << "a write that fails is exit 1";
  fs::remove_all(d);
}

TEST(OutputFile, UsageErrorsExit2AndVersionExits0) {
  EXPECT_EQ(feedid::test::run_feedid("identify --no-such-option").exit_code, 2);
  EXPECT_EQ(feedid::test::run_feedid("--version").exit_code, 0);
}

}  // namespace
