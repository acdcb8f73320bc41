// Several recordings, one model (issue 11). GIVEN one trace written as two
// files, the second with its clock restarted at 0 and its position offset by
// 1 m, WHEN both are read with read_trace_files (what `--in a --in b` does),
// THEN the runs are listed, no stage joins the two files (position and time
// jumps do not leak into velocity or sections), and the pooled model equals
// the one from the single file.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "io/trace_files.hpp"
#include "diagnose/diagnose.hpp"
#include "identify/identify.hpp"
#include "test_support.hpp"

namespace feedid::test {
namespace {

TEST(PooledRuns, TwoFilesOfOneTraceGiveItsModel) {
  SimSpec spec;
  spec.duration_s = 40.0;
  const host::Trace whole = host::simulate(sim_config(spec));
  const std::size_t half = whole.samples.size() / 2;
  host::Trace a, b;
  a.samples.assign(whole.samples.begin(), whole.samples.begin() + static_cast<std::ptrdiff_t>(half));
  const double t0 = whole.samples[half].t_s;
  for (std::size_t k = half; k < whole.samples.size(); ++k) {
    host::TraceSample s = whole.samples[k];
    s.t_s -= t0;
    s.x_m += 1.0;
    b.samples.push_back(s);
  }
  const std::string pa = ::testing::TempDir() + "run_a.csv", pb = ::testing::TempDir() + "run_b.csv";
  std::string error;
  ASSERT_TRUE(host::write_trace_csv(pa, a, error)) << error;
  ASSERT_TRUE(host::write_trace_csv(pb, b, error)) << error;

  const host::CsvResult pooled = host::read_trace_files({pa, pb}, host::CsvColumns{});
  ASSERT_TRUE(pooled.ok) << pooled.error;
  ASSERT_EQ(pooled.trace.runs.size(), 2u);
  EXPECT_EQ(pooled.trace.runs[1].first, half);
  EXPECT_EQ(pooled.trace.samples.size(), whole.samples.size());

  const host::IdentifyResult one = host::identify(whole, host::IdentifyOptions{});
  const host::IdentifyResult two = host::identify(pooled.trace, host::IdentifyOptions{});
  ASSERT_TRUE(two.error.empty()) << two.error;
  EXPECT_NEAR(two.estimate.mass_kg, one.estimate.mass_kg, 1e-3 * one.estimate.mass_kg);
  EXPECT_NEAR(two.estimate.pos.coulomb_N, one.estimate.pos.coulomb_N, 1e-3 * one.estimate.pos.coulomb_N);
  EXPECT_NEAR(two.estimate.neg.viscous_Ns_m, one.estimate.neg.viscous_Ns_m, 1e-3 * one.estimate.neg.viscous_Ns_m);
  const auto runs = host::to_json(two)["input"]["runs"];
  ASSERT_EQ(runs.size(), 2u);
  // Each run's core counters: its own samples, and together the totals.
  std::uint64_t accepted = 0;
  unsigned sections = 0, split = 0, windows = 0;
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& c = runs[i]["core"];
    EXPECT_EQ(c["samples_accepted"].get<std::uint64_t>(), pooled.trace.runs[i].samples);
    EXPECT_GT(c["sections_complete"]["pos"].get<unsigned>(), 5u) << "run " << i;
    EXPECT_GT(c["sections_complete"]["neg"].get<unsigned>(), 5u) << "run " << i;
    accepted += c["samples_accepted"].get<std::uint64_t>();
    sections += c["sections_complete"]["pos"].get<unsigned>() + c["sections_complete"]["neg"].get<unsigned>();
    split += c["sections_split"].get<unsigned>();
    windows += c["mass_windows"].get<unsigned>();
  }
  EXPECT_EQ(accepted, two.diagnostics.samples_accepted);
  EXPECT_EQ(sections, two.diagnostics.sections_complete[0] + two.diagnostics.sections_complete[1]);
  EXPECT_EQ(split, two.diagnostics.sections_split);
  EXPECT_EQ(windows, two.diagnostics.mass_windows);

  const host::DiagnoseResult d = host::diagnose(pooled.trace, host::DiagnoseOptions{});
  ASSERT_TRUE(d.error.empty()) << d.error;
  EXPECT_EQ(d.effect, "none") << host::summary(d);  // the 1 m jump is no position effect
}

}  // namespace
}  // namespace feedid::test

namespace feedid::host {
namespace {

std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

// --in-list: each recording with its own columns and scales, pooled as runs.
TEST(InputList, EachFileKeepsItsOwnColumnsAndScales) {
  write_file("feedid_list_a.csv", "t,x,v,u\n0,0,0,1\n0.001,1e-6,1e-3,2\n");
  write_file("feedid_list_b.csv", "time,pos_um,force_A\n0,0,1\n0.001,1,2\n");  // um and A
  const std::string list = write_file("feedid_runs.txt",
                                      "# two recordings of one axis\n"
                                      "feedid_list_a.csv\n"
                                      "\n"
                                      "feedid_list_b.csv time=time position=pos_um force=force_A position-scale=1e-6 "
                                      "force-scale=2.5\n");
  CsvColumns defaults;
  std::vector<TraceInput> inputs;
  std::string error;
  ASSERT_TRUE(read_input_list(list, defaults, inputs, error)) << error;
  ASSERT_EQ(inputs.size(), 2u);
  const CsvResult r = read_trace_files(inputs);
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.trace.runs.size(), 2u);
  const TraceSample& b1 = r.trace.samples[r.trace.runs[1].first + 1];
  EXPECT_DOUBLE_EQ(b1.x_m, 1e-6);  // 1 um
  EXPECT_DOUBLE_EQ(b1.u_N, 5.0);   // 2 A at 2.5 N/A
  EXPECT_FALSE(r.trace.has_velocity) << "the second file has no velocity column";
}

TEST(InputList, ErrorsNameTheLine) {
  std::vector<TraceInput> inputs;
  std::string error;
  const std::string bad_key = write_file("feedid_runs_bad.txt", "a.csv\nb.csv gain=3\n");
  EXPECT_FALSE(read_input_list(bad_key, CsvColumns{}, inputs, error));
  EXPECT_NE(error.find(":2: unknown key 'gain'"), std::string::npos) << error;
  const std::string bad_number = write_file("feedid_runs_num.txt", "a.csv force-scale=two\n");
  EXPECT_FALSE(read_input_list(bad_number, CsvColumns{}, inputs, error));
  EXPECT_NE(error.find(":1: force-scale 'two' is not a number"), std::string::npos) << error;
  // A scale is checked as the options' are (finite, non-zero; time not
  // negative), at its line: a zero force scale was taken, and its error
  // blamed --force-scale, an option nobody gave.
  for (const char* bad : {"force-scale=0", "position-scale=nan", "force-scale=1e999", "time-scale=-1e-3"}) {
    inputs.clear();
    error.clear();
    const std::string list = write_file("feedid_runs_scale.txt", std::string("a.csv\nb.csv ") + bad + "\n");
    EXPECT_FALSE(read_input_list(list, CsvColumns{}, inputs, error)) << bad;
    const std::string key = std::string(bad).substr(0, std::string(bad).find('='));
    EXPECT_NE(error.find(":2: " + key + " "), std::string::npos) << bad << ": " << error;
    EXPECT_EQ(error.find("--"), std::string::npos) << error;
  }
  inputs.clear();
  EXPECT_FALSE(read_input_list(write_file("feedid_runs_empty.txt", "# nothing\n"), CsvColumns{}, inputs, error));
  EXPECT_NE(error.find("no recordings"), std::string::npos) << error;
}

}  // namespace
}  // namespace feedid::host
