// The estimator as a stream, on the core's own traces (core_trace.hpp):
// rejection of bad samples (a rejected sample never changes the state),
// configuration checks, the memory budget and the from_position velocity
// source. Float against double over an hour and section detection on the
// simulator's drives are in tests/sim/core_stream_on_sim_test.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "core/core_trace.hpp"
#include "feedid/footprint_budget.hpp"

namespace {

using namespace feedid;
using core_test::rel_err;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------
// (3) bad samples
// ---------------------------------------------------------------------------

using Est = Estimator<double>;
using Stats = Est::Stats;

std::vector<unsigned char> bytes_of(const Stats& s) {
  std::vector<unsigned char> b(sizeof s);
  std::memcpy(b.data(), &s, sizeof s);
  return b;
}

/// Diagnostics counter that a rejection status increments.
std::uint64_t counter_for(const Diagnostics& g, Status s) {
  switch (s) {
    case Status::rejected_not_finite: return g.rejected_not_finite;
    case Status::rejected_time_not_increasing: return g.rejected_time_not_increasing;
    case Status::rejected_out_of_range: return g.rejected_out_of_range;
    case Status::rejected_velocity_jump: return g.rejected_velocity_jump;
    default: return ~0ull;
  }
}

struct BadSample {
  const char* name;
  Status expected;
  // Corrupts the sample (dt_s already set from the trace).
  void (*corrupt)(Sample<double>& s, double v_prev);
};

const BadSample kBadSamples[] = {
    {"nan_velocity", Status::rejected_not_finite, [](Sample<double>& s, double) { s.velocity_m_s = kNaN; }},
    {"inf_velocity", Status::rejected_not_finite, [](Sample<double>& s, double) { s.velocity_m_s = -kInf; }},
    {"nan_force", Status::rejected_not_finite, [](Sample<double>& s, double) { s.force_N = kNaN; }},
    {"inf_force", Status::rejected_not_finite, [](Sample<double>& s, double) { s.force_N = kInf; }},
    {"nan_dt", Status::rejected_not_finite, [](Sample<double>& s, double) { s.dt_s = kNaN; }},
    {"inf_dt", Status::rejected_not_finite, [](Sample<double>& s, double) { s.dt_s = kInf; }},
    {"zero_dt", Status::rejected_time_not_increasing, [](Sample<double>& s, double) { s.dt_s = 0.0; }},
    {"negative_dt", Status::rejected_time_not_increasing, [](Sample<double>& s, double) { s.dt_s = -1e-3; }},
    // The fast path tests dt by its bits (Estimator::set_fast_path): the
    // signed zero, a negative NaN and the most negative dt must not pass.
    {"negative_zero_dt", Status::rejected_time_not_increasing, [](Sample<double>& s, double) { s.dt_s = -0.0; }},
    {"negative_nan_dt", Status::rejected_not_finite, [](Sample<double>& s, double) { s.dt_s = -kNaN; }},
    {"lowest_dt", Status::rejected_time_not_increasing,
     [](Sample<double>& s, double) { s.dt_s = -std::numeric_limits<double>::max(); }},
    {"speed_above_max", Status::rejected_out_of_range, [](Sample<double>& s, double) { s.velocity_m_s = -25.0; }},
    {"force_above_max", Status::rejected_out_of_range, [](Sample<double>& s, double) { s.force_N = 2e6; }},
    {"velocity_jump", Status::rejected_velocity_jump,
     [](Sample<double>& s, double v_prev) { s.velocity_m_s = v_prev + 1.0; }},
};

void PrintTo(const BadSample& b, std::ostream* os) { *os << b.name; }

class BadSamples : public ::testing::TestWithParam<BadSample> {
 protected:
  static const core_test::StrokeSpec& spec() {
    static const core_test::StrokeSpec s;
    return s;
  }
  static const std::vector<Sample<double>>& trace() {
    static const std::vector<Sample<double>> tr = core_test::stroke_ladder(core_test::default_drive(), spec());
    return tr;
  }
  static std::size_t moving_index() {  // first sample after 5 s with |v| > 1 mm/s
    const auto& tr = trace();
    for (std::size_t k = 0; k < tr.size(); ++k)
      if (static_cast<double>(k) > 5.0 * spec().rate_hz && std::fabs(tr[k].velocity_m_s) > 1e-3) return k;
    return 0;
  }
  static Sample<double> sample(std::size_t k) { return trace()[k]; }
  static Config<double> config() { return core_test::default_config<double>(spec().encoder_m, spec().rate_hz); }
};

TEST_P(BadSamples, RejectedWithItsStatusAndChangesNothing) {
  const BadSample& bad = GetParam();
  const auto& tr = trace();
  const std::size_t k0 = moving_index();
  ASSERT_GT(k0, 0u);
  // GIVEN an estimator that has taken the stream up to a sample in motion
  auto a = std::make_unique<Est>();
  ASSERT_EQ(a->init(config()), Status::ok);
  for (std::size_t k = 0; k < k0; ++k) ASSERT_EQ(a->push(sample(k)), Status::ok);
  const std::vector<unsigned char> stats_before = bytes_of(a->statistics());
  const Diagnostics diag_before = a->diagnostics();
  // WHEN sample k0 arrives corrupted
  Sample<double> s = sample(k0);
  bad.corrupt(s, tr[k0 - 1].velocity_m_s);
  const Status st = a->push(s);
  // THEN it is rejected with its own status
  EXPECT_EQ(st, bad.expected) << status_name(st);
  // AND exactly its counter and the rejection total went up by one
  const Diagnostics& g = a->diagnostics();
  EXPECT_EQ(g.samples_rejected, diag_before.samples_rejected + 1);
  EXPECT_EQ(g.samples_accepted, diag_before.samples_accepted);
  for (Status c : {Status::rejected_not_finite, Status::rejected_time_not_increasing, Status::rejected_out_of_range,
                   Status::rejected_velocity_jump})
    EXPECT_EQ(counter_for(g, c), counter_for(diag_before, c) + (c == bad.expected ? 1 : 0)) << status_name(c);
  // AND the statistics are byte for byte what they were
  EXPECT_EQ(bytes_of(a->statistics()), stats_before);

  // AND the rest of the stream ends exactly as if sample k0 had never been
  // sent, its time (when it had a valid one) added to the next step, else
  // the chain restarted there
  auto b = std::make_unique<Est>();
  ASSERT_EQ(b->init(config()), Status::ok);
  for (std::size_t k = 0; k < k0; ++k) ASSERT_EQ(b->push(sample(k)), Status::ok);
  const bool time_kept = std::isfinite(s.dt_s) && s.dt_s > 0.0;
  for (std::size_t k = k0 + 1; k < tr.size(); ++k) {
    ASSERT_EQ(a->push(sample(k)), Status::ok) << k;
    Sample<double> sb = sample(k);
    // The same sum the estimator forms; with the rejected sample's time
    // unknown (NaN/Inf dt) no integral may span it: a restart, as after a gap.
    if (k == k0 + 1 && time_kept) sb.dt_s += s.dt_s;
    if (k == k0 + 1 && !std::isfinite(s.dt_s)) sb.dt_s = 1e3;
    ASSERT_EQ(b->push(sb), Status::ok) << k;
  }
  ASSERT_EQ(a->solve(), Status::ok);
  ASSERT_EQ(b->solve(), Status::ok);
  EXPECT_EQ(bytes_of(a->statistics()), bytes_of(b->statistics()));
  EXPECT_EQ(a->estimate().mass_kg, b->estimate().mass_kg);
  EXPECT_EQ(a->estimate().pos.coulomb_N, b->estimate().pos.coulomb_N);
  EXPECT_EQ(a->estimate().neg.stribeck_velocity_m_s, b->estimate().neg.stribeck_velocity_m_s);
}

INSTANTIATE_TEST_SUITE_P(Kinds, BadSamples, ::testing::ValuesIn(kBadSamples),
                         [](const ::testing::TestParamInfo<BadSample>& i) { return std::string(i.param.name); });

/// Streams the 56 s ladder twice: as is, and with 1 % of the samples
/// (chosen at random, never the first) corrupted by `corrupt`. Returns the
/// number of corrupted samples; checks each was rejected as not finite.
template <typename Corrupt>
std::size_t stream_clean_and_corrupted(Est& clean, Est& dirty, Corrupt corrupt) {
  const core_test::StrokeSpec spec;
  const std::vector<Sample<double>> tr = core_test::stroke_ladder(core_test::default_drive(), spec);
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const Config<double> cfg = core_test::default_config<double>(spec.encoder_m, spec.rate_hz);
  EXPECT_EQ(clean.init(cfg), Status::ok);
  EXPECT_EQ(dirty.init(cfg), Status::ok);
  std::size_t corrupted = 0, rejected = 0;
  for (std::size_t k = 0; k < tr.size(); ++k) {
    const Sample<double>& s = tr[k];
    EXPECT_EQ(clean.push(s), Status::ok);
    Sample<double> d = s;
    if (k > 0 && u01(rng) < 0.01) {
      ++corrupted;
      corrupt(d, rng);
    }
    if (dirty.push(d) != Status::ok) ++rejected;
  }
  EXPECT_EQ(rejected, corrupted);
  EXPECT_EQ(dirty.diagnostics().rejected_not_finite, corrupted);
  EXPECT_GT(corrupted, tr.size() / 200);  // about 1 %, at least 0.5 %
  EXPECT_LT(corrupted, tr.size() / 50);
  EXPECT_EQ(clean.solve(), Status::ok);
  EXPECT_EQ(dirty.solve(), Status::ok);
  return corrupted;
}

void expect_estimates_close(const Estimate<double>& d, const Estimate<double>& c, double tol) {
  std::printf("  mass %+.4f%%\n", 100 * (d.mass_kg / c.mass_kg - 1));
  EXPECT_LT(rel_err(d.mass_kg, c.mass_kg), tol) << "mass " << d.mass_kg << " vs " << c.mass_kg;
  EXPECT_EQ(d.mass_flags, c.mass_flags);
  for (int k = 0; k < 2; ++k) {
    const DirectionEstimate<double>& ec = k == 0 ? c.pos : c.neg;
    const DirectionEstimate<double>& ed = k == 0 ? d.pos : d.neg;
    const char* dir = k == 0 ? "pos" : "neg";
    std::printf("  %s: sigma %+.4f%% Fc %+.4f%% Fs %+.4f%% vs %+.4f%%\n", dir,
                100 * (ed.viscous_Ns_m / ec.viscous_Ns_m - 1), 100 * (ed.coulomb_N / ec.coulomb_N - 1),
                100 * (ed.breakaway_N / ec.breakaway_N - 1),
                100 * (ed.stribeck_velocity_m_s / ec.stribeck_velocity_m_s - 1));
    EXPECT_LT(rel_err(ed.viscous_Ns_m, ec.viscous_Ns_m), tol) << dir;
    EXPECT_LT(rel_err(ed.coulomb_N, ec.coulomb_N), tol) << dir;
    EXPECT_LT(rel_err(ed.breakaway_N, ec.breakaway_N), tol) << dir;
    EXPECT_LT(rel_err(ed.stribeck_velocity_m_s, ec.stribeck_velocity_m_s), tol) << dir;
    EXPECT_EQ(ed.flags, ec.flags) << dir;
  }
}

TEST(Stream, OnePercentNaNReadingsBarelyMoveTheEstimate) {
  // GIVEN a 60 s stream, and a copy in which 1 % of the samples have a NaN
  // velocity or force reading (the servo clock, hence dt, stays valid)
  auto clean = std::make_unique<Est>();
  auto dirty = std::make_unique<Est>();
  // WHEN both are streamed and solved
  stream_clean_and_corrupted(*clean, *dirty, [](Sample<double>& d, std::mt19937_64& rng) {
    if (std::uniform_int_distribution<int>(0, 1)(rng) == 0) d.velocity_m_s = kNaN;
    else d.force_N = kNaN;
  });
  // THEN every parameter is within 0.5 % of the clean stream's
  expect_estimates_close(dirty->estimate(), clean->estimate(), 0.005);
}

// Core issue (reported): when a rejected sample's dt is not finite, its time
// is dropped, and the next good sample's interval (dt of one period) is used
// for a velocity change and a force that span two periods. With 1 % of
// samples wholly NaN (dt included) the mass comes out 1.4 % low (0.9-1.4 %
// over three seeds when only dt is NaN), against 0.1 % when only velocity or
// force is NaN. Bridging a sample of unknown duration would need a
// continuity break instead.
TEST(StreamBadSamples, OnePercentWhollyNaNSamplesBarelyMoveTheEstimate) {
  auto clean = std::make_unique<Est>();
  auto dirty = std::make_unique<Est>();
  stream_clean_and_corrupted(*clean, *dirty, [](Sample<double>& d, std::mt19937_64&) {
    d.dt_s = d.velocity_m_s = d.position_m = d.force_N = kNaN;
  });
  expect_estimates_close(dirty->estimate(), clean->estimate(), 0.005);
}

// ---------------------------------------------------------------------------
// (4) configuration checks
// ---------------------------------------------------------------------------

struct BadConfig {
  const char* name;
  const char* field;  ///< expected in config_error()
  void (*corrupt)(Config<double>& c);
};

const BadConfig kBadConfigs[] = {
    {"velocity_min_zero", "velocity_min_m_s", [](Config<double>& c) { c.velocity_min_m_s = 0.0; }},
    {"velocity_min_negative", "velocity_min_m_s", [](Config<double>& c) { c.velocity_min_m_s = -1e-4; }},
    {"velocity_min_nan", "velocity_min_m_s", [](Config<double>& c) { c.velocity_min_m_s = kNaN; }},
    {"velocity_min_inf", "velocity_min_m_s", [](Config<double>& c) { c.velocity_min_m_s = kInf; }},
    {"velocity_max_nan", "velocity_max_m_s", [](Config<double>& c) { c.velocity_max_m_s = kNaN; }},
    {"velocity_max_below_4_min", "velocity_max_m_s",
     [](Config<double>& c) { c.velocity_max_m_s = 3.9 * c.velocity_min_m_s; }},
    {"velocity_max_equal_4_min", "velocity_max_m_s",
     [](Config<double>& c) { c.velocity_max_m_s = 4.0 * c.velocity_min_m_s; }},
    {"resolution_negative", "velocity_resolution_m_s", [](Config<double>& c) { c.velocity_resolution_m_s = -1e-5; }},
    {"resolution_nan", "velocity_resolution_m_s", [](Config<double>& c) { c.velocity_resolution_m_s = kNaN; }},
    {"section_enter_nan", "section_enter_m_s", [](Config<double>& c) { c.section_enter_m_s = kNaN; }},
    {"rest_samples_zero", "rest_samples", [](Config<double>& c) { c.rest_samples = 0; }},
    {"min_section_negative", "min_section_s", [](Config<double>& c) { c.min_section_s = -0.01; }},
    {"max_fold_zero", "max_fold_s", [](Config<double>& c) { c.max_fold_s = 0.0; }},
    {"mass_window_nan", "mass_window_s", [](Config<double>& c) { c.mass_window_s = kNaN; }},
    {"max_acceleration_negative", "max_acceleration_m_s2", [](Config<double>& c) { c.max_acceleration_m_s2 = -1.0; }},
    {"max_speed_zero", "max_speed_m_s", [](Config<double>& c) { c.max_speed_m_s = 0.0; }},
    {"max_force_inf", "max_force_N", [](Config<double>& c) { c.max_force_N = kInf; }},
    {"max_gap_zero", "max_gap_s", [](Config<double>& c) { c.max_gap_s = 0.0; }},
    {"max_step_ratio_zero", "max_step_speed_ratio", [](Config<double>& c) { c.max_step_speed_ratio = 0.0; }},
    {"stribeck_min_negative", "stribeck_min", [](Config<double>& c) { c.stribeck_min_m_s = -1e-3; }},
    {"stribeck_range_inverted", "stribeck_max_m_s",
     [](Config<double>& c) {
       c.stribeck_min_m_s = 1e-2;
       c.stribeck_max_m_s = 1e-3;
     }},
    {"stribeck_range_too_narrow", "stribeck_max_m_s",
     [](Config<double>& c) {
       c.stribeck_min_m_s = 1e-3;
       c.stribeck_max_m_s = 1.5e-3;
     }},
    {"stribeck_min_above_default_max", "stribeck_max_m_s",
     [](Config<double>& c) { c.stribeck_min_m_s = 0.5 * c.velocity_max_m_s; }},
    {"vs_iterations_zero", "max_vs_iterations", [](Config<double>& c) { c.max_vs_iterations = 0; }},
    {"vs_iterations_too_many", "max_vs_iterations", [](Config<double>& c) { c.max_vs_iterations = 201; }},
    {"velocity_source_unknown", "velocity_source",
     [](Config<double>& c) { c.velocity_source = static_cast<VelocitySource>(7); }},
    {"force_lag_positive", "force_lag_samples",
     [](Config<double>& c) { c.force_lag_samples = 0.5; }},
    {"force_lag_beyond_history", "force_lag_samples",
     [](Config<double>& c) { c.force_lag_samples = -5.5; }},
    {"force_lag_nan", "force_lag_samples",
     [](Config<double>& c) { c.force_lag_samples = std::numeric_limits<double>::quiet_NaN(); }},
};

void PrintTo(const BadConfig& b, std::ostream* os) { *os << b.name; }

class InitRejects : public ::testing::TestWithParam<BadConfig> {};

TEST_P(InitRejects, InvalidConfigNamesTheFieldAndLeavesEstimatorUnusable) {
  const BadConfig& bad = GetParam();
  // GIVEN an estimator that was working with a valid config
  auto est = std::make_unique<Est>();
  Config<double> cfg = core_test::default_config<double>(1e-8, 1000.0);
  ASSERT_EQ(est->init(cfg), Status::ok);
  EXPECT_EQ(est->config_error(), nullptr);
  ASSERT_EQ(est->push(Sample<double>{}), Status::ok);
  // WHEN it is re-initialised with one bad field
  bad.corrupt(cfg);
  // THEN init says invalid_config and names the field
  EXPECT_EQ(est->init(cfg), Status::invalid_config);
  ASSERT_NE(est->config_error(), nullptr);
  EXPECT_NE(std::string(est->config_error()).find(bad.field), std::string::npos) << est->config_error();
  // AND push and solve refuse to work
  Sample<double> s;
  s.dt_s = 1e-3;
  EXPECT_EQ(est->push(s), Status::not_initialized);
  EXPECT_EQ(est->solve(), Status::not_initialized);
  EXPECT_EQ(est->diagnostics().samples_accepted, 0u);
}

INSTANTIATE_TEST_SUITE_P(Fields, InitRejects, ::testing::ValuesIn(kBadConfigs),
                         [](const ::testing::TestParamInfo<BadConfig>& i) { return std::string(i.param.name); });

TEST(Init, FloatConfigWithNaNIsRejected) {
  auto est = std::make_unique<Estimator<float>>();
  Config<float> cfg = core_test::default_config<float>(1e-8, 1000.0);
  cfg.velocity_min_m_s = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(est->init(cfg), Status::invalid_config);
  EXPECT_NE(est->config_error(), nullptr);
}

TEST(Init, DefaultAndTestConfigsAreValid) {
  auto est = std::make_unique<Est>();
  EXPECT_EQ(est->init(Config<double>{}), Status::ok) << est->config_error();
  EXPECT_EQ(est->init(core_test::default_config<double>(1e-7, 1000.0)), Status::ok) << est->config_error();
  Config<double> edge = core_test::default_config<double>(1e-8, 1000.0);
  edge.velocity_max_m_s = 4.001 * edge.velocity_min_m_s;  // just above the limit
  EXPECT_EQ(est->init(edge), Status::ok) << est->config_error();
  EXPECT_EQ(est->config_error(), nullptr);
}

TEST(Init, PushAndSolveBeforeInitAreNotInitialized) {
  // GIVEN a fresh estimator, never initialised
  auto est = std::make_unique<Est>();
  Sample<double> s;
  s.dt_s = 1e-3;
  s.velocity_m_s = 0.01;
  // WHEN used  THEN every call says so, and nothing is counted
  EXPECT_EQ(est->push(s), Status::not_initialized);
  EXPECT_EQ(est->solve(), Status::not_initialized);
  EXPECT_EQ(est->solve(Method::paper), Status::not_initialized);
  EXPECT_EQ(est->diagnostics().samples_accepted, 0u);
  EXPECT_EQ(est->diagnostics().samples_rejected, 0u);
  // AND after a good init the same sample is taken
  ASSERT_EQ(est->init(core_test::default_config<double>(1e-8, 1000.0)), Status::ok);
  EXPECT_EQ(est->push(s), Status::ok);
}

// ---------------------------------------------------------------------------
// (5) memory budget
// ---------------------------------------------------------------------------

constexpr std::size_t kFirmwareRamBudget = feedid::fw::estimator_float_ram_budget;
static_assert(sizeof(feedid::Estimator<float>) <= kFirmwareRamBudget,
              "Estimator<float> exceeds the 8 KiB firmware RAM budget");

TEST(Memory, FloatEstimatorFitsFirmwareBudget) {
  std::printf("  sizeof(Estimator<float>) = %zu bytes, sizeof(Estimator<double>) = %zu bytes\n",
              sizeof(Estimator<float>), sizeof(Estimator<double>));
  RecordProperty("sizeof_estimator_float", static_cast<int>(sizeof(Estimator<float>)));
  RecordProperty("sizeof_estimator_double", static_cast<int>(sizeof(Estimator<double>)));
  EXPECT_LE(sizeof(Estimator<float>), kFirmwareRamBudget);
}

// ---------------------------------------------------------------------------
// (6) velocity from position
// ---------------------------------------------------------------------------

TEST(Stream, VelocityFromPositionMatchesReportedVelocity) {
  // GIVEN a ladder of strokes, whose reported velocity is the backward
  // difference of the quantised position over the servo period 1/rate.
  // dt is that period (what a fixed-rate servo reports), so both velocity
  // paths are the same division. (With dt from differences of t, the two
  // velocities differ by ~1e-12 relative; with velocity_min = 2 quanta, a
  // speed of exactly 2 quanta then falls on either side of the rest
  // threshold, which moves Fs and vs by up to 5e-5 relative: a threshold
  // tie, not a from_position error.)
  const core_test::StrokeSpec spec;
  const Estimate<double> truth = core_test::default_drive();
  const std::vector<Sample<double>> tr = core_test::stroke_ladder(truth, spec);
  Config<double> measured = core_test::default_config<double>(spec.encoder_m, spec.rate_hz);
  Config<double> from_x = measured;
  from_x.velocity_source = VelocitySource::from_position;
  auto a = std::make_unique<Est>();
  auto b = std::make_unique<Est>();
  ASSERT_EQ(a->init(measured), Status::ok);
  ASSERT_EQ(b->init(from_x), Status::ok);
  // WHEN one estimator takes the velocity and the other only the position,
  // with garbage in its velocity field
  for (std::size_t k = 0; k < tr.size(); ++k) {
    const Sample<double>& s = tr[k];
    Sample<double> g = s;
    g.velocity_m_s = k % 2 ? kNaN : 1e30;
    ASSERT_EQ(a->push(s), Status::ok) << k;
    ASSERT_EQ(b->push(g), Status::ok) << k;
  }
  // THEN both give the same estimate within 1e-6 relative, by either method
  EXPECT_EQ(a->diagnostics().sections_complete[0], b->diagnostics().sections_complete[0]);
  EXPECT_EQ(a->diagnostics().sections_complete[1], b->diagnostics().sections_complete[1]);
  for (Method m : {Method::bands, Method::paper}) {
    ASSERT_EQ(a->solve(m), Status::ok);
    ASSERT_EQ(b->solve(m), Status::ok);
    const Estimate<double>& ea = a->estimate();
    const Estimate<double>& eb = b->estimate();
    const char* name = m == Method::bands ? "bands" : "paper";
    EXPECT_LT(rel_err(eb.mass_kg, ea.mass_kg), 1e-6) << name;
    EXPECT_EQ(eb.mass_flags, ea.mass_flags) << name;
    for (int k = 0; k < 2; ++k) {
      const DirectionEstimate<double>& pa = k == 0 ? ea.pos : ea.neg;
      const DirectionEstimate<double>& pb = k == 0 ? eb.pos : eb.neg;
      EXPECT_LT(rel_err(pb.viscous_Ns_m, pa.viscous_Ns_m), 1e-6) << name << k;
      EXPECT_LT(rel_err(pb.coulomb_N, pa.coulomb_N), 1e-6) << name << k;
      EXPECT_LT(rel_err(pb.breakaway_N, pa.breakaway_N), 1e-6) << name << k;
      EXPECT_LT(rel_err(pb.stribeck_velocity_m_s, pa.stribeck_velocity_m_s), 1e-6) << name << k;
      EXPECT_EQ(pb.flags, pa.flags) << name << k;
    }
  }
  // AND the estimate is the drive's, not a constant of the garbage
  EXPECT_LT(rel_err(b->estimate().mass_kg, truth.mass_kg), 0.03);
}

TEST(Stream, FromPositionRejectsNonFinitePosition) {
  // GIVEN an estimator that differences position
  auto est = std::make_unique<Est>();
  Config<double> cfg = core_test::default_config<double>(1e-8, 1000.0);
  cfg.velocity_source = VelocitySource::from_position;
  ASSERT_EQ(est->init(cfg), Status::ok);
  Sample<double> s;
  ASSERT_EQ(est->push(s), Status::ok);
  // WHEN a position is NaN  THEN the sample is rejected as not finite
  s.dt_s = 1e-3;
  s.position_m = kNaN;
  EXPECT_EQ(est->push(s), Status::rejected_not_finite);
  EXPECT_EQ(est->diagnostics().rejected_not_finite, 1u);
}

}  // namespace
