// What the command line says about its input (issue 30): every reader,
// whole-file or streamed, names the rows it skipped; messages are printable
// and bounded whatever the input holds. The formats users have (issue 31):
// a `;` log with decimal commas and a preamble gives the plain log's model
// and says what it left out, in every reader; a headerless log is refused
// with exit 2 naming file:line and --columns, and read with --columns.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_run.hpp"

using feedid::test::CliRun;
using feedid::test::run_feedid;

namespace {


/// A simulated 30 s log with lines 501 and 901 (1-based, the header is 1) made unreadable.
std::string log_with_two_bad_rows() {
  const std::string clean = ::testing::TempDir() + "feedid_messages_clean.csv";
  const std::string bad = ::testing::TempDir() + "feedid_messages_bad.csv";
  EXPECT_EQ(run_feedid("simulate --duration 30 --out " + clean).exit_code, 0);
  std::ifstream in(clean);
  std::ofstream out(bad);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) out << (n == 501 || n == 901 ? "0.25,abc,0,1" : line) << "\n";
  return bad;
}

// GIVEN a log with two unreadable rows, THEN identify (whole and streamed)
// and monitor each count them and name them by line.
TEST(Messages, EveryReaderNamesTheRowsItSkipped) {
  const std::string in = log_with_two_bad_rows();
  for (const std::string cmd : {"identify --in ", "identify --stream --in ", "monitor --in "}) {
    const CliRun r = run_feedid(cmd + in);
    EXPECT_NE(r.err.find("skipped 2 bad rows"), std::string::npos) << cmd << r.err;
    EXPECT_NE(r.err.find("feedid_messages_bad.csv:501: "), std::string::npos) << cmd << r.err;
    EXPECT_NE(r.err.find("feedid_messages_bad.csv:901: "), std::string::npos) << cmd << r.err;
  }
}

double mass_of(const std::string& json_path) {
  std::ifstream f(json_path);
  return nlohmann::json::parse(f).at("m").get<double>();
}

/// The lines of `from` after its header, each through `convert`, after `head`.
template <typename F> std::string rewrite(const std::string& from, const std::string& name, const std::string& head, F convert) {
  const std::string path = ::testing::TempDir() + name;
  std::ifstream in(from);
  std::ofstream out(path);
  out << head;
  std::string line;
  std::getline(in, line);  // the header t,x,v,u
  while (std::getline(in, line)) out << convert(line) << "\n";
  return path;
}

TEST(Formats, GermanLogWithPreambleAndHeaderlessLogFromTheCommandLine) {
  const std::string dir = ::testing::TempDir();
  const std::string clean = dir + "feedid_formats_clean.csv";
  ASSERT_EQ(run_feedid("simulate --duration 30 --out " + clean).exit_code, 0);
  const std::string german = rewrite(clean, "feedid_formats_de.csv", "# DriveLog 2.1\nAchse: X\nt;x;v;u\n", [](std::string l) {
    for (char& c : l) c = c == ',' ? ';' : c == '.' ? ',' : c;
    return l;
  });
  ASSERT_EQ(run_feedid("identify --in " + clean + " --json " + dir + "feedid_formats_clean.json").exit_code, 0);
  const CliRun de = run_feedid("identify --in " + german + " --json " + dir + "feedid_formats_de.json");
  ASSERT_EQ(de.exit_code, 0) << de.err;
  EXPECT_EQ(mass_of(dir + "feedid_formats_de.json"), mass_of(dir + "feedid_formats_clean.json"));
  for (const std::string cmd : {"identify --in ", "identify --stream --in ", "monitor --in "})
    EXPECT_NE(run_feedid(cmd + german).err.find("feedid_formats_de.csv: 2 lines before the header (line 3) left out"),
              std::string::npos)
        << cmd;

  const std::string bare = rewrite(clean, "feedid_formats_bare.csv", "", [](std::string l) { return l; });
  const CliRun refused = run_feedid("identify --in " + bare);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("feedid_formats_bare.csv:1: no header row names the columns"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("--columns"), std::string::npos) << refused.err;
  const CliRun named = run_feedid("identify --columns t,x,v,u --in " + bare + " --json " + dir + "feedid_formats_bare.json");
  ASSERT_EQ(named.exit_code, 0) << named.err;
  EXPECT_EQ(mass_of(dir + "feedid_formats_bare.json"), mass_of(dir + "feedid_formats_clean.json"));
}

}  // namespace

namespace {
// GIVEN the truth simulate --truth writes, with and without an effect,
// THEN every command that reads a model takes it (its simulated effects,
// recorded by name, are said to be left out).
TEST(Messages, SimulatesTruthFileIsAModelFile) {
  const std::string dir = ::testing::TempDir();
  for (const std::string fx : {"", " --ripple-amplitude 3"}) {
    const std::string trace = dir + "feedid_truth_trace.csv", truth = dir + "feedid_truth.json";
    ASSERT_EQ(run_feedid("simulate --duration 20" + fx + " --out " + trace + " --truth " + truth).exit_code, 0) << fx;
    const CliRun v = run_feedid("validate --model " + truth + " --in " + trace);
    EXPECT_EQ(v.exit_code, 0) << fx << v.err;
    EXPECT_EQ(run_feedid("compensate --max-speed 0.15 --model " + truth).exit_code, 0) << fx;  // a truth has no speed range
    EXPECT_EQ(v.err.find("simulated_effects") != std::string::npos, !fx.empty()) << fx << v.err;
  }
}

// GIVEN a run with a step change and a warm-up, THEN the truth file states
// both (it held the drive before them only), and validate, which models
// neither, says so by the key's name.
TEST(Messages, SimulatesTruthFileStatesTheChangeAndTheWarmUp) {
  const std::string dir = ::testing::TempDir();
  const std::string trace = dir + "feedid_truth_change.csv", truth = dir + "feedid_truth_change.json";
  ASSERT_EQ(run_feedid("simulate --duration 10 --change-time 6 --change-coulomb-fraction 0.2 --change-direction neg "
                       "--warmup-drop 0.1 --warmup-minutes 0.1 --out " + trace + " --truth " + truth).exit_code, 0);
  std::ifstream f(truth);
  const nlohmann::json j = nlohmann::json::parse(f);
  ASSERT_TRUE(j.contains("simulated_change")) << j.dump();
  EXPECT_DOUBLE_EQ(j["simulated_change"]["step"]["time_s"].get<double>(), 6.0);
  EXPECT_DOUBLE_EQ(j["simulated_change"]["step"]["coulomb_fraction"].get<double>(), 0.2);
  EXPECT_EQ(j["simulated_change"]["step"]["direction"], "negative");
  EXPECT_DOUBLE_EQ(j["simulated_change"]["warmup"]["ramp_s"].get<double>(), 6.0);
  EXPECT_DOUBLE_EQ(j["simulated_change"]["warmup"]["friction_drop_at_ramp_end"].get<double>(), 0.1);
  const CliRun v = run_feedid("validate --model " + truth + " --in " + trace);
  EXPECT_EQ(v.exit_code, 0) << v.err;
  EXPECT_NE(v.err.find("simulated_change"), std::string::npos) << v.err;
  ASSERT_EQ(run_feedid("simulate --duration 5 --out " + trace + " --truth " + truth).exit_code, 0);
  std::ifstream g(truth);
  EXPECT_FALSE(nlohmann::json::parse(g).contains("simulated_change"));
}

// GIVEN --stream asked for on pooled inputs, THEN the run says it reads
// them whole instead (a .mat run did so without a word) and still succeeds
TEST(Messages, AStreamThatCannotBeHadIsSaid) {
  const std::string trace = ::testing::TempDir() + "feedid_stream_pooled.csv";
  ASSERT_EQ(run_feedid("simulate --duration 10 --out " + trace).exit_code, 0);
  const CliRun r = run_feedid("identify --stream --in " + trace + " --in " + trace);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("--stream is not used: it reads one CSV file row by row, and this run pools several inputs"),
            std::string::npos) << r.err;
  EXPECT_EQ(run_feedid("identify --in " + trace + " --in " + trace).err.find("--stream"), std::string::npos);
}

// GIVEN a top speed of 0 or less, THEN compensate refuses it by name
// (it was read as "not given" and replaced by the model's).
TEST(Messages, CompensateRefusesATopSpeedThatIsNotPositive) {
  const std::string dir = ::testing::TempDir();
  const std::string trace = dir + "feedid_comp_trace.csv", truth = dir + "feedid_comp_truth.json";
  ASSERT_EQ(run_feedid("simulate --duration 5 --out " + trace + " --truth " + truth).exit_code, 0);
  for (const std::string v : {"-1", "0", "nan"}) {
    const CliRun r = run_feedid("compensate --model " + truth + " --max-speed " + v);
    EXPECT_EQ(r.exit_code, 2) << v;
    EXPECT_NE(r.err.find("--max-speed: " + v + " m/s: must be > 0"), std::string::npos) << r.err;
  }
}
}  // namespace

namespace {
// GIVEN an input kept in the report folder under a name the report writes,
// or two outputs named alike, THEN the command refuses before it writes.
TEST(Messages, NoOutputReplacesAnInputOrAnotherOutput) {
  const std::string dir = ::testing::TempDir() + "feedid_report_clash";
  std::filesystem::create_directories(dir);
  const std::string trace = dir + "/report.html", json = dir + "/o.json";
  ASSERT_EQ(run_feedid("simulate --duration 20 --out " + trace).exit_code, 0);
  const CliRun over = run_feedid("diagnose --in " + trace + " --report " + dir);
  EXPECT_EQ(over.exit_code, 2);
  EXPECT_NE(over.err.find("refusing to write the report over the input"), std::string::npos) << over.err;
  std::ifstream kept(trace);
  std::string header;
  std::getline(kept, header);
  EXPECT_EQ(header, "t,x,v,u") << "the input was replaced";
  const CliRun twice = run_feedid("diagnose --in " + trace + " --json " + json + " --model-out " + json);
  EXPECT_EQ(twice.exit_code, 2);
  EXPECT_NE(twice.err.find("another output is written to this file too"), std::string::npos) << twice.err;
}
// GIVEN a result at --json, WHEN a later run fails after reading (too little
// motion) THEN its report with the error is at --json, and the earlier
// result is kept whole beside it, not lost; a second failure keeps it too.
// GIVEN an output named in a folder that does not exist (or a report
// folder that is a file) beside a --json that can be written
// WHEN the command runs
// THEN it stops before running, exit 2, naming the option and the folder,
// and writes nothing: found after the run, the --json was written and the
// run exited 1
TEST(Messages, AnOutputThatCannotBeWrittenStopsTheRunBeforeItStarts) {
  const std::string dir = ::testing::TempDir() + "feedid_unwritable";
  std::filesystem::create_directories(dir);
  const std::string trace = dir + "/t.csv", json = dir + "/x.json";
  std::filesystem::remove(json);
  ASSERT_EQ(run_feedid("simulate --duration 20 --out " + trace).exit_code, 0);
  const CliRun r = run_feedid("identify --in " + trace + " --json " + json + " --friction-plot " + dir + "/nodir/p.svg");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("--friction-plot"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(json)) << "an output of a run that was refused";
  const CliRun folder = run_feedid("identify --in " + trace + " --json " + dir);
  EXPECT_EQ(folder.exit_code, 2) << folder.err;
  EXPECT_NE(folder.err.find("is a folder"), std::string::npos) << folder.err;
  const CliRun report = run_feedid("diagnose --in " + trace + " --report " + trace);
  EXPECT_EQ(report.exit_code, 2) << report.err;
}

TEST(Messages, AFailedRunKeepsTheResultItReplaces) {
  const std::string dir = ::testing::TempDir() + "feedid_failed_run";
  std::filesystem::create_directories(dir);
  const std::string good = dir + "/good.csv", still = dir + "/still.csv", json = dir + "/axis.json";
  std::filesystem::remove(dir + "/axis.prev.json");
  ASSERT_EQ(run_feedid("simulate --duration 20 --out " + good).exit_code, 0);
  {
    std::ofstream out(still);
    out << "t,x,u\n";
    for (int k = 0; k < 500; ++k) out << k * 1e-3 << ",0," << (k % 7) << "\n";
  }
  ASSERT_EQ(run_feedid("identify --in " + good + " --json " + json).exit_code, 0);
  std::ifstream first(json);
  const std::string earlier((std::istreambuf_iterator<char>(first)), std::istreambuf_iterator<char>());
  for (int failure = 0; failure < 2; ++failure) {
    const CliRun failed = run_feedid("identify --in " + still + " --json " + json);
    EXPECT_EQ(failed.exit_code, 2) << failed.err;
    std::ifstream now(json), prev(dir + "/axis.prev.json");
    const nlohmann::json report = nlohmann::json::parse(now, nullptr, false);
    EXPECT_TRUE(report.is_object() && report.contains("error")) << "the failed run's report is not at --json";
    const std::string kept((std::istreambuf_iterator<char>(prev)), std::istreambuf_iterator<char>());
    EXPECT_EQ(kept, earlier) << "the earlier result was lost";
  }
  // A run that fails before it has a result (reading: a column missing)
  // says so at --json too, and keeps the earlier result the same way: it
  // left the last run's "status ok" there with exit 2.
  std::filesystem::remove(dir + "/axis.prev.json");
  ASSERT_EQ(run_feedid("identify --in " + good + " --json " + json).exit_code, 0);
  const CliRun unread = run_feedid("identify --in " + good + " --force no_such_column --json " + json);
  EXPECT_EQ(unread.exit_code, 2) << unread.err;
  {
    std::ifstream now(json), prev(dir + "/axis.prev.json");
    const nlohmann::json report = nlohmann::json::parse(now, nullptr, false);
    EXPECT_TRUE(report.is_object() && report.contains("error") && !report.contains("status")) << report.dump();
    const nlohmann::json kept = nlohmann::json::parse(prev, nullptr, false);
    EXPECT_TRUE(kept.is_object() && kept.value("status", "") == "ok") << "the earlier result was lost";
  }
  // Where the earlier result cannot be kept (a folder in the way), nothing
  // is replaced, and the run still says its own error and exits with it.
  ASSERT_EQ(run_feedid("identify --in " + good + " --json " + json).exit_code, 0);
  std::filesystem::remove(dir + "/axis.prev.json");
  std::filesystem::create_directory(dir + "/axis.prev.json");
  const CliRun blocked = run_feedid("identify --in " + still + " --json " + json);
  EXPECT_EQ(blocked.exit_code, 2) << blocked.err;
  EXPECT_NE(blocked.err.find("not enough motion"), std::string::npos) << blocked.err;
  EXPECT_NE(blocked.err.find("left as it was"), std::string::npos) << blocked.err;
  std::ifstream left(json);
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(left)), std::istreambuf_iterator<char>()), earlier);
  std::filesystem::remove(dir + "/axis.prev.json");
  // An output named where the earlier result would be kept is refused before anything runs.
  const CliRun clash = run_feedid("identify --in " + good + " --json " + json + " --friction-plot " + dir + "/axis.prev.json");
  EXPECT_EQ(clash.exit_code, 2) << clash.err;
}
}  // namespace
