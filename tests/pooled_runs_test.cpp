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

#include "trace_files.hpp"
#include "diagnose.hpp"
#include "identify.hpp"
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
  EXPECT_EQ(host::to_json(two)["input"]["runs"].size(), 2u);

  const host::DiagnoseResult d = host::diagnose(pooled.trace, host::DiagnoseOptions{});
  ASSERT_TRUE(d.error.empty()) << d.error;
  EXPECT_EQ(d.effect, "none") << host::summary(d);  // the 1 m jump is no position effect
}

}  // namespace
}  // namespace feedid::test
