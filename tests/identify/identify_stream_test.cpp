// identify in bounded memory (host_sim/identify/identify_stream.cpp): the same drive,
// read row by row in chunks, gives what the whole-trace identification gives.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include "io/csv_trace.hpp"
#include "identify/identify_stream.hpp"
#include "test_support.hpp"

namespace feedid::host {
namespace {

/// The default simulated drive, `duration_s` long, written to a temporary
/// CSV named `name`; its path, or empty if it could not be written.
std::string simulated_csv(double duration_s, const char* name) {
  test::SimSpec spec;
  spec.duration_s = duration_s;
  const std::string path = ::testing::TempDir() + name;
  std::string err;
  return write_trace_csv(path, host::simulate(test::sim_config(spec)), err) ? path : std::string();
}

TEST(IdentifyStream, ChunksGiveTheWholeTracesEstimate) {
  test::SimSpec spec;
  spec.duration_s = 60.0;
  const host::SimConfig cfg = test::sim_config(spec);
  const Trace trace = host::simulate(cfg);
  const std::string path = ::testing::TempDir() + "feedid_stream_identify.csv";
  std::string err;
  ASSERT_TRUE(write_trace_csv(path, trace, err)) << err;

  const IdentifyResult whole = identify(trace, IdentifyOptions{});
  CsvStream in(path, CsvColumns{});
  ASSERT_TRUE(in.ok()) << in.error();
  StreamOptions small;  // many chunks on a short trace: every chunk edge is exercised
  small.head_s = 15.0;
  small.chunk_s = 5.0;
  small.margin_s = 0.5;
  const IdentifyResult r = identify_stream(in, path, IdentifyOptions{}, small);
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_TRUE(whole.error.empty()) << whole.error;
  EXPECT_TRUE(r.streamed);
  EXPECT_EQ(r.diagnostics.samples_accepted + r.diagnostics.samples_rejected, trace.samples.size())
      << "every row pushed once: no chunk edge drops or repeats one";
  EXPECT_GT(r.jackknife_chunks, 0);
  // Against the truth, within the streamed standard errors (3 se), and the
  // standard errors of the same order as the whole-trace ones.
  const auto& t = cfg.drive;
  EXPECT_NEAR(r.estimate.mass_kg, t.mass_kg, 3.0 * r.estimate.mass_se_kg);
  for (int d = 0; d < 2; ++d) {
    const auto& e = d == 0 ? r.estimate.pos : r.estimate.neg;
    const auto& w = d == 0 ? whole.estimate.pos : whole.estimate.neg;
    const auto& tr = d == 0 ? t.pos : t.neg;
    EXPECT_NEAR(e.coulomb_N, tr.coulomb_N, 3.0 * e.coulomb_se) << d;
    EXPECT_NEAR(e.viscous_Ns_m, tr.viscous_Ns_m, 3.0 * e.viscous_se) << d;
    EXPECT_GT(e.coulomb_se, 0.2 * w.coulomb_se) << d;
    EXPECT_LT(e.coulomb_se, 5.0 * w.coulomb_se) << d;
  }
  EXPECT_NE(to_json(r)["input"]["streamed"].get<std::string>().find("row by row"), std::string::npos);
}

TEST(IdentifyStream, AClipThatStartsAfterTheHeadIsLeftOut) {
  // GIVEN the default drive whose force is clipped from 20 s on, after the head
  test::SimSpec spec;
  spec.duration_s = 60.0;
  const host::SimConfig cfg = test::sim_config(spec);
  Trace trace = host::simulate(cfg);
  double peak = 0.0;
  for (const TraceSample& s : trace.samples)
    if (s.t_s > 20.0) peak = std::max(peak, std::fabs(s.u_N));
  const double limit = 0.8 * peak;
  for (TraceSample& s : trace.samples)
    if (s.t_s > 20.0) s.u_N = std::clamp(s.u_N, -limit, limit);
  const std::string path = ::testing::TempDir() + "feedid_stream_late_clip.csv";
  std::string err;
  ASSERT_TRUE(write_trace_csv(path, trace, err)) << err;
  // WHEN streamed with a 15 s head
  CsvStream in(path, CsvColumns{});
  ASSERT_TRUE(in.ok()) << in.error();
  StreamOptions small;
  small.head_s = 15.0;
  small.chunk_s = 5.0;
  small.margin_s = 0.5;
  const IdentifyResult r = identify_stream(in, path, IdentifyOptions{}, small);
  ASSERT_TRUE(r.error.empty()) << r.error;
  // THEN the clip is found and named, and the mass is the drive's
  const ForceSaturation& sat = r.force_outliers.saturation;
  ASSERT_TRUE(sat.found_hi && sat.found_lo);
  EXPECT_DOUBLE_EQ(sat.level_hi, limit);
  EXPECT_GT(sat.rows, 0u);
  EXPECT_GE(sat.rows_left_out, sat.rows);
  EXPECT_NEAR(r.estimate.mass_kg, cfg.drive.mass_kg, 3.0 * r.estimate.mass_se_kg);
  EXPECT_TRUE(to_json(r)["input"]["force_saturation"].is_object());
}

TEST(IdentifyStream, PositionSpikesInEveryChunkAreBridgedAndCounted) {
  // GIVEN the default drive with one position row far off and back, in the head and after it
  test::SimSpec spec;
  spec.duration_s = 40.0;
  const Trace clean = host::simulate(test::sim_config(spec));
  Trace spiky = clean;
  for (double at : {10.0, 30.0}) spiky.samples[static_cast<std::size_t>(at * 2000.0)].x_m += 1.0;
  const std::string path = ::testing::TempDir() + "feedid_stream_spikes.csv", clean_path = path + ".clean.csv";
  std::string err;
  ASSERT_TRUE(write_trace_csv(path, spiky, err)) << err;
  ASSERT_TRUE(write_trace_csv(clean_path, clean, err)) << err;
  StreamOptions small;
  small.head_s = 15.0;
  small.chunk_s = 5.0;
  small.margin_s = 0.5;
  // WHEN both are streamed
  CsvStream in(path, CsvColumns{}), in_clean(clean_path, CsvColumns{});
  const IdentifyResult r = identify_stream(in, path, IdentifyOptions{}, small);
  const IdentifyResult c = identify_stream(in_clean, clean_path, IdentifyOptions{}, small);
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_TRUE(c.error.empty()) << c.error;
  // THEN both spikes are counted once, and the estimate is the clean log's
  EXPECT_EQ(r.force_outliers.position_spikes.rows, 2u);
  EXPECT_EQ(r.diagnostics.samples_rejected, c.diagnostics.samples_rejected);
  EXPECT_NEAR(r.estimate.mass_kg, c.estimate.mass_kg, 0.1 * c.estimate.mass_se_kg);
  EXPECT_NEAR(r.estimate.pos.coulomb_N, c.estimate.pos.coulomb_N, 0.1 * c.estimate.pos.coulomb_se);
}

// Under 50 s of data fewer than five jackknife groups have any: the core's
// own standard errors, never a jackknife over empty groups (which gave 0).
TEST(IdentifyStream, ShortLogKeepsTheCoresStandardErrors) {
  const std::string path = simulated_csv(30.0, "feedid_stream_short.csv");
  ASSERT_FALSE(path.empty());
  CsvStream in(path, CsvColumns{});
  const IdentifyResult r = identify_stream(in, path, IdentifyOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.jackknife_chunks, 0);
  EXPECT_GT(r.estimate.pos.coulomb_se, 0.0);
  EXPECT_GT(r.estimate.mass_se_kg, 0.0);
  // AND what the stream does not compute is null in the JSON, not a 0 that
  // reads as a perfect fit (a review found rms_force_residual_N 0 and a
  // window mass of 0 kg beside m); the windows' mass is the mass it reports
  const nlohmann::json j = to_json(r);
  EXPECT_TRUE(j.at("fit").at("rms_force_residual_N").is_null());
  EXPECT_TRUE(j.at("standard_errors").at("jackknife").is_null());
  EXPECT_TRUE(j.at("standard_errors").at("velocity_cutoff").is_null());
  EXPECT_EQ(j.at("mass_from_windows_kg").get<double>(), r.estimate.mass_kg);
  // AND the timing term it folds into the standard errors is the one reported
  // (the JSON said 0 while m's standard error held it)
  const double core_m = j.at("standard_errors").at("core").at(0).get<double>();
  const double timing_m = j.at("standard_errors").at("timing").at(0).get<double>();
  EXPECT_GT(timing_m, 0.0);
  EXPECT_NEAR(r.estimate.mass_se_kg, std::hypot(core_m, timing_m), 1e-12 * r.estimate.mass_se_kg);
}

// GIVEN band edges the core rejects (lowest above highest), WHEN the
// streamed identification stops at init, THEN its result names the
// configuration it was asked to run, as identify() does (it was empty).
TEST(IdentifyStream, ARejectedConfigurationIsReportedAsAsked) {
  const std::string path = simulated_csv(10.0, "feedid_stream_badconfig.csv");
  ASSERT_FALSE(path.empty());
  IdentifyOptions opt;
  opt.velocity_min_m_s = 0.2;
  opt.velocity_max_m_s = 0.1;
  CsvStream in(path, CsvColumns{});
  const IdentifyResult r = identify_stream(in, path, opt);
  EXPECT_EQ(r.status, feedid::Status::invalid_config);
  EXPECT_FALSE(r.error.empty());
  EXPECT_EQ(r.config.velocity_min_m_s, 0.2);
  EXPECT_EQ(r.config.velocity_max_m_s, 0.1);
  test::SimSpec spec;
  spec.duration_s = 10.0;
  EXPECT_EQ(identify(host::simulate(test::sim_config(spec)), opt).config.velocity_min_m_s, 0.2);
}

TEST(IdentifyStream, AReadErrorIsNotReportedAsOk) {
  std::string text = "t,x,v,u\n";
  for (int k = 0; k < 300; ++k) text += std::to_string(k * 1e-3) + ",0,0,1\n";
  text += "0.1,0,0,1\n";  // time goes back: with --bad-rows error, the error
  const std::string path = ::testing::TempDir() + "feedid_stream_bad.csv";
  std::ofstream(path) << text;
  CsvColumns strict;
  strict.skip_bad_rows = false;
  CsvStream in(path, strict);
  const IdentifyResult r = identify_stream(in, path, IdentifyOptions{});
  EXPECT_FALSE(r.error.empty());
  EXPECT_NE(r.status, feedid::Status::ok);
}

}  // namespace
}  // namespace feedid::host
