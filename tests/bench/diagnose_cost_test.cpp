// `feedid bench --diagnose-cost --cost-in`: GIVEN a recorded trace, WHEN its
// JSON is asked for at the trace's own path, THEN the trace is left as it
// was and the write is refused; WHEN a command refuses the trace, THEN
// no ratio is reported as if it had been measured.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "bench/bench.hpp"
#include "io/csv_trace.hpp"
#include "test_support.hpp"

namespace feedid::test {
namespace {

namespace fs = std::filesystem;

std::string read_all(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

fs::path write_trace(const std::string& name, double duration_s) {
  SimSpec spec;
  spec.duration_s = duration_s;
  const fs::path p = fs::temp_directory_path() / ("feedid_cost_" + name + "_" + std::to_string(::getpid()) + ".csv");
  std::string error;
  EXPECT_TRUE(host::write_trace_csv(p.string(), simulate(spec), error)) << error;
  return p;
}

TEST(DiagnoseCost, TheJsonIsNotWrittenOverTheTraceItMeasures) {
  const fs::path csv = write_trace("over", 20.0);
  const std::string before = read_all(csv);
  host::BenchOptions o;
  o.diagnose_cost = true;
  o.cost_csv = csv.string();
  o.json_path = csv.string();
  o.repeats = 1;
  const host::RunEnd end = host::run_bench(o);
  EXPECT_TRUE(end.bad_input.empty()) << end.bad_input;
  ASSERT_EQ(end.not_written.size(), 1u);
  EXPECT_NE(end.not_written[0].find("input"), std::string::npos) << end.not_written[0];
  EXPECT_EQ(read_all(csv), before);
  fs::remove(csv);
}

TEST(DiagnoseCost, ATraceACommandRefusesIsRefusedNotTimed) {
  const fs::path csv = write_trace("short", 0.3);  // 600 samples: too short to diagnose
  host::BenchOptions o;
  o.diagnose_cost = true;
  o.cost_csv = csv.string();
  o.repeats = 1;
  const host::RunEnd end = host::run_bench(o);
  EXPECT_NE(end.bad_input.find("too short"), std::string::npos) << end.bad_input;
  fs::remove(csv);
}

}  // namespace
}  // namespace feedid::test
