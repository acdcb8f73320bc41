// Parameter recovery of the core on the simulator's closed-loop drives
// (the core's own ladder: tests/core/estimator_recovery_test.cpp): simulated drives streamed through Estimator<double>,
// solved with the bands method (the project's) and the paper method (the
// comparator), plus plants from which some parameters cannot be identified.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace {

using namespace feedid;
using feedid::test::rel_err;

// ---------------------------------------------------------------------------
// Recovery across drives (TEST_P)
// ---------------------------------------------------------------------------

struct DriveCase {
  double mass_kg;
  double rate_hz;
  std::uint64_t seed;
  bool other_friction;  ///< sigma 300/350, Fc 12/15, Fs 4/5, vs 5e-3/4e-3, encoder 1e-7
};

std::string case_name(const DriveCase& c) {
  return std::string(c.other_friction ? "OtherFriction_" : "") + "m" + std::to_string(int(c.mass_kg)) + "_" +
         std::to_string(int(c.rate_hz)) + "Hz_seed" + std::to_string(c.seed);
}

void PrintTo(const DriveCase& c, std::ostream* os) { *os << case_name(c); }

host::SimConfig sim_config(const DriveCase& c) {
  test::SimSpec s;
  s.mass_kg = c.mass_kg;
  s.rate_hz = c.rate_hz;
  s.seed = c.seed;
  s.duration_s = 60.0;
  if (c.other_friction) s.encoder_m = 1e-7;  // 1e-4 m/s velocity quantum at 1 kHz
  host::SimConfig sc = test::sim_config(s);
  if (c.other_friction) {
    sc.drive.pos = host::DirectionFriction{300.0, 12.0, 4.0, 5e-3};
    sc.drive.neg = host::DirectionFriction{350.0, 15.0, 5.0, 4e-3};
  }
  return sc;
}

/// One simulated stream per case, solved both ways; cached so the bands and
/// paper tests of a case share a simulation when run in one process.
struct Solved {
  host::SimConfig sim;
  Config<double> config;
  Status bands_status = Status::not_initialized, paper_status = Status::not_initialized;
  Estimate<double> bands, paper;
  test::PushCounts pushed;
};

const Solved& solved(const DriveCase& c) {
  static std::map<std::string, std::unique_ptr<Solved>> cache;
  std::unique_ptr<Solved>& slot = cache[case_name(c)];
  if (!slot) {
    auto s = std::make_unique<Solved>();
    s->sim = sim_config(c);
    s->config = test::default_config<double>(s->sim);
    auto est = std::make_unique<Estimator<double>>();
    EXPECT_EQ(est->init(s->config), Status::ok) << est->config_error();
    s->pushed = test::push_trace(*est, host::simulate(s->sim));
    s->bands_status = est->solve(Method::bands);
    s->bands = est->estimate();
    s->paper_status = est->solve(Method::paper);
    s->paper = est->estimate();
    slot = std::move(s);
  }
  return *slot;
}

void print_estimate(const char* tag, const Estimate<double>& e, const host::DriveParams& d) {
  auto dir = [](const char* n, const DirectionEstimate<double>& x, const host::DirectionFriction& t) {
    std::printf("    %s sigma %+.3f%% Fc %+.3f%% Fs %+.3f%% vs %+.3f%% flags 0x%x\n", n,
                100 * (x.viscous_Ns_m / t.viscous_Ns_m - 1), 100 * (x.coulomb_N / t.coulomb_N - 1),
                100 * (x.breakaway_N / t.breakaway_N - 1),
                100 * (x.stribeck_velocity_m_s / t.stribeck_velocity_m_s - 1), x.flags);
  };
  std::printf("  %s: mass %+.3f%% flags 0x%x\n", tag, 100 * (e.mass_kg / d.mass_kg - 1), e.mass_flags);
  dir("pos", e.pos, d.pos);
  dir("neg", e.neg, d.neg);
}

void expect_direction_within(const DirectionEstimate<double>& e, const host::DirectionFriction& t,
                             double tol_sigma_fc, double tol_fs, double tol_vs, const char* dir) {
  EXPECT_LT(rel_err(e.viscous_Ns_m, t.viscous_Ns_m), tol_sigma_fc) << dir << " sigma " << e.viscous_Ns_m;
  EXPECT_LT(rel_err(e.coulomb_N, t.coulomb_N), tol_sigma_fc) << dir << " Fc " << e.coulomb_N;
  EXPECT_LT(rel_err(e.breakaway_N, t.breakaway_N), tol_fs) << dir << " Fs " << e.breakaway_N;
  EXPECT_LT(rel_err(e.stribeck_velocity_m_s, t.stribeck_velocity_m_s), tol_vs)
      << dir << " vs " << e.stribeck_velocity_m_s;
}

/// Fs and vs of both directions flagged (never a confident number), while
/// sigma and Fc stay identified within 1 % of the truth.
void expect_stribeck_flagged_friction_kept(const Estimate<double>& e, const host::DriveParams& d) {
  EXPECT_NE(e.pos.flags & stribeck_flags, 0u);
  EXPECT_NE(e.neg.flags & stribeck_flags, 0u);
  EXPECT_FALSE(e.pos.stribeck_identified());
  EXPECT_FALSE(e.neg.stribeck_identified());
  for (const auto* p : {&e.pos, &e.neg}) {
    const host::DirectionFriction& t = p == &e.pos ? d.pos : d.neg;
    EXPECT_TRUE(p->friction_identified());
    EXPECT_LT(rel_err(p->viscous_Ns_m, t.viscous_Ns_m), 0.01) << p->viscous_Ns_m;
    EXPECT_LT(rel_err(p->coulomb_N, t.coulomb_N), 0.01) << p->coulomb_N;
  }
}

class Recovery : public ::testing::TestWithParam<DriveCase> {};

TEST_P(Recovery, BandsMethodRecoversAllNineParameters) {
  // GIVEN 60 s of a simulated reciprocating drive, streamed sample by sample
  const Solved& s = solved(GetParam());
  ASSERT_EQ(s.pushed.rejected, 0u);
  // WHEN solved with the bands method
  ASSERT_EQ(s.bands_status, Status::ok);
  const Estimate<double>& e = s.bands;
  const host::DriveParams& d = s.sim.drive;
  print_estimate("bands", e, d);
  // THEN mass, sigma and Fc are within 1 %, Fs and vs within 3 % of the truth
  EXPECT_LT(rel_err(e.mass_kg, d.mass_kg), 0.01) << "mass " << e.mass_kg;
  expect_direction_within(e.pos, d.pos, 0.01, 0.03, 0.03, "pos");
  expect_direction_within(e.neg, d.neg, 0.01, 0.03, 0.03, "neg");
  // AND nothing is flagged as unidentifiable
  EXPECT_EQ(e.mass_flags, 0u);
  EXPECT_EQ(e.pos.flags, 0u);
  EXPECT_EQ(e.neg.flags, 0u);
  EXPECT_TRUE(e.pos.stribeck_identified());
  EXPECT_TRUE(e.neg.stribeck_identified());
  // AND the reported uncertainty covers the actual error (no confident wrong value)
  EXPECT_LE(std::fabs(e.mass_kg - d.mass_kg), 4 * e.mass_se_kg + 1e-3 * d.mass_kg);
}

// The literal paper method is the comparator. Measured on these cases (core
// as of this writing): sigma within 0.32 %, Fc within 0.17 %, Fs within
// 3.8 % (400 kg at 1 kHz), vs within 1.7 %; hence 5 % for Fs and vs. Mass
// from integral(u a) = m integral(a^2) uses a^2 of the differenced,
// quantised velocity, whose quantisation noise inflates integral(a^2): with
// a velocity quantum q*rate of 1e-5 m/s (1e-8 m at 1 kHz) the mass is within
// 2 %, but at 4e-5 m/s (4 kHz) it comes out 6.5 % low and at 1e-4 m/s (1e-7 m
// at 1 kHz) 2.9 % low, for every mass and seed. For those the test asserts
// the bias honestly: low, by less than 8 %, and worse than the bands method.
TEST_P(Recovery, PaperMethodOnSameStreamIsTheComparator) {
  // GIVEN the same stream as the bands test
  const Solved& s = solved(GetParam());
  // WHEN solved with the paper method
  ASSERT_EQ(s.paper_status, Status::ok);
  const Estimate<double>& e = s.paper;
  const host::DriveParams& d = s.sim.drive;
  print_estimate("paper", e, d);
  // THEN sigma and Fc are within 3 %, Fs and vs within 5 % of the truth.
  // (The literal method integrates every interval of a section, including
  // the hard accelerations, so the discrete inertia terms do not cancel
  // exactly: at 400 kg and 1 kHz this biases Fs by about 3.8 %. The bands
  // method leaves those intervals out of its friction sums; see method.md.)
  expect_direction_within(e.pos, d.pos, 0.03, 0.05, 0.05, "pos");
  expect_direction_within(e.neg, d.neg, 0.03, 0.05, 0.05, "neg");
  // AND the mass is within 2 % where the velocity quantum is fine enough,
  //     else biased low by less than 8 % and worse than the bands method
  const double quantum = s.config.velocity_resolution_m_s;
  if (quantum <= 1e-5) {
    EXPECT_LT(rel_err(e.mass_kg, d.mass_kg), 0.02) << "mass " << e.mass_kg;
  } else {
    EXPECT_LT(e.mass_kg, d.mass_kg);
    EXPECT_GT(e.mass_kg, 0.92 * d.mass_kg);
    EXPECT_GT(rel_err(e.mass_kg, d.mass_kg), rel_err(s.bands.mass_kg, d.mass_kg));
  }
  EXPECT_EQ(e.mass_flags, 0u);
  EXPECT_EQ(e.pos.flags, 0u);
  EXPECT_EQ(e.neg.flags, 0u);
}

std::vector<DriveCase> drive_cases() {
  std::vector<DriveCase> v;
  for (double m : {20.0, 100.0, 400.0})
    for (double r : {1000.0, 4000.0})
      for (std::uint64_t seed : {1u, 2u}) v.push_back(DriveCase{m, r, seed, false});
  for (std::uint64_t seed : {1u, 2u}) v.push_back(DriveCase{100.0, 1000.0, seed, true});
  return v;
}

INSTANTIATE_TEST_SUITE_P(Drives, Recovery, ::testing::ValuesIn(drive_cases()),
                         [](const ::testing::TestParamInfo<DriveCase>& i) { return case_name(i.param); });

// ---------------------------------------------------------------------------
// Degenerate plants
// ---------------------------------------------------------------------------

/// Streams a trace into a fresh estimator and solves it.
struct Streamed {
  std::unique_ptr<Estimator<double>> est = std::make_unique<Estimator<double>>();
  Status status = Status::not_initialized;
  const Estimate<double>& e() const { return est->estimate(); }
};

Streamed run_stream(const host::Trace& tr, const Config<double>& cfg, Method method = Method::bands) {
  Streamed r;
  EXPECT_EQ(r.est->init(cfg), Status::ok) << r.est->config_error();
  const test::PushCounts n = test::push_trace(*r.est, tr);
  EXPECT_EQ(n.rejected, 0u);
  r.status = r.est->solve(method);
  return r;
}

/// Samples of the model itself with an analytic velocity: strokes in the
/// positive direction only, v = V sin^2(pi tau / T) (smooth acceleration),
/// peak speeds V log-spaced over [2e-4, 0.15] m/s, rest between strokes.
/// Force and velocity are instantaneous at t_k (pair with trapezoid).
host::Trace positive_only_trace(const host::DriveParams& d, double rate_hz, double seconds,
                                double force_noise_N, std::uint64_t seed) {
  constexpr double kPi = 3.14159265358979323846;
  const int levels = 14;
  const double stroke_s = 1.0, dwell_s = 0.2, period_s = stroke_s + dwell_s;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, force_noise_N);
  host::Trace tr;
  tr.source = "positive only";
  const double dt = 1.0 / rate_hz;
  const auto n = static_cast<std::size_t>(seconds * rate_hz) + 1;
  auto peak = [&](long stroke) { return 2e-4 * std::pow(0.15 / 2e-4, double(stroke % levels) / (levels - 1)); };
  double x_start = 0.0;  // position at the start of the current stroke
  long current = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    const auto stroke = static_cast<long>(std::floor(t / period_s));
    for (; current < stroke; ++current) x_start += peak(current) * stroke_s / 2.0;  // full stroke: V T / 2
    const double V = peak(stroke);
    const double tau = t - static_cast<double>(stroke) * period_s;
    double v = 0.0, a = 0.0, x_in = V * stroke_s / 2.0;
    if (tau < stroke_s) {
      const double s = std::sin(kPi * tau / stroke_s);
      v = V * s * s;
      a = V * kPi / stroke_s * std::sin(2.0 * kPi * tau / stroke_s);
      x_in = V * (tau / 2.0 - stroke_s / (4.0 * kPi) * std::sin(2.0 * kPi * tau / stroke_s));
    }
    const double u = d.mass_kg * a + host::stribeck_friction(d, v) + noise(rng);
    tr.samples.push_back(host::TraceSample{t, x_start + x_in, v, u});
  }
  return tr;
}

TEST(DegeneratePlant, MotionOnlyInPositiveDirection) {
  // GIVEN model samples of a drive that only ever moves in +x
  const host::DriveParams d{};
  const double rate = 1000.0;
  const host::Trace tr = positive_only_trace(d, rate, 60.0, 0.5, 7);
  Config<double> cfg = test::default_config<double>(1e-8, rate);
  cfg.force_lag_samples = force_lag_of<double>(ForceAlignment::trapezoid);
  // WHEN streamed and solved
  const Streamed r = run_stream(tr, cfg);
  ASSERT_EQ(r.status, Status::ok);
  const Estimate<double>& e = r.e();
  print_estimate("bands", e, d);
  // THEN the negative direction says it has no data
  EXPECT_NE(e.neg.flags & flag_no_data, 0u);
  EXPECT_FALSE(e.neg.friction_identified());
  EXPECT_EQ(e.neg.sections, 0u);
  // AND the positive direction and the mass are still identified
  EXPECT_EQ(e.pos.flags, 0u);
  EXPECT_EQ(e.mass_flags, 0u);
  EXPECT_LT(rel_err(e.mass_kg, d.mass_kg), 0.01) << e.mass_kg;
  expect_direction_within(e.pos, d.pos, 0.01, 0.03, 0.03, "pos");
}

/// GIVEN/WHEN/THEN of case (b): every stroke is fast (slowest peak 0.05 m/s).
/// At 400 kg and 4 kHz the Stribeck region is crossed only on the ramps and
/// the Stribeck terms are flagged on both sides. (At lighter masses or lower
/// rates the servo's settling at the end of each stroke does visit the
/// Stribeck region slowly and Fs, vs are legitimately identified; see the
/// test below: at 1 kHz and 100 kg the data misses the bend around vs, which
/// the coverage rule must flag.)
class FastStrokesOnly : public ::testing::TestWithParam<std::uint64_t> {};

TEST_P(FastStrokesOnly, StribeckFlaggedWhileViscousAndCoulombHold) {
  // GIVEN a drive whose slowest stroke peaks at 0.05 m/s
  test::SimSpec spec;
  spec.mass_kg = 400.0;
  spec.rate_hz = 4000.0;
  spec.seed = GetParam();
  host::SimConfig sc = test::sim_config(spec);
  sc.motion.slowest_speed_m_s = 0.05;
  // WHEN streamed and solved
  const Streamed r = run_stream(host::simulate(sc), test::default_config<double>(sc));
  ASSERT_EQ(r.status, Status::ok);
  const Estimate<double>& e = r.e();
  print_estimate("bands", e, sc.drive);
  // THEN the Stribeck part of both directions is flagged, not reported,
  // AND sigma and Fc are still within 1 %, the mass too
  expect_stribeck_flagged_friction_kept(e, sc.drive);
  EXPECT_LT(rel_err(e.mass_kg, sc.drive.mass_kg), 0.01);
}

INSTANTIATE_TEST_SUITE_P(Seeds, FastStrokesOnly, ::testing::Values(1u, 2u));

// Core issue (reported): with only fast strokes, 100 kg at 1 kHz, the
// negative direction reports vs = 2.64e-3 m/s (truth 1.8e-3, +47 %) with a
// standard error of 1.8e-4 (4.6 se off) and no flag. An honest estimate
// either flags the Stribeck terms or is within a few standard errors.
TEST(FastStrokesOnlyAt1kHz, StribeckFlaggedOrWithinThreeStandardErrors) {
  test::SimSpec spec;
  spec.mass_kg = 100.0;
  spec.rate_hz = 1000.0;
  spec.seed = 1;
  host::SimConfig sc = test::sim_config(spec);
  sc.motion.slowest_speed_m_s = 0.05;
  const Streamed r = run_stream(host::simulate(sc), test::default_config<double>(sc));
  ASSERT_EQ(r.status, Status::ok);
  const Estimate<double>& e = r.e();
  print_estimate("bands", e, sc.drive);
  for (const auto* p : {&e.pos, &e.neg}) {
    const host::DirectionFriction& t = p == &e.pos ? sc.drive.pos : sc.drive.neg;
    if (!p->stribeck_identified()) continue;
    EXPECT_LE(std::fabs(p->stribeck_velocity_m_s - t.stribeck_velocity_m_s), 3 * p->stribeck_velocity_se)
        << (p == &e.pos ? "pos" : "neg") << " vs " << p->stribeck_velocity_m_s << " se "
        << p->stribeck_velocity_se;
  }
}

class StribeckBelowResolution : public ::testing::TestWithParam<double> {};

TEST_P(StribeckBelowResolution, NeverAConfidentStribeckVelocity) {
  // GIVEN vs = 1e-4 m/s, exactly the velocity quantum of a 1e-7 m encoder at 1 kHz
  test::SimSpec spec;
  spec.mass_kg = GetParam();
  spec.rate_hz = 1000.0;
  spec.encoder_m = 1e-7;
  host::SimConfig sc = test::sim_config(spec);
  sc.drive.pos.stribeck_velocity_m_s = 1e-4;
  sc.drive.neg.stribeck_velocity_m_s = 1e-4;
  // WHEN streamed and solved
  const Streamed r = run_stream(host::simulate(sc), test::default_config<double>(sc));
  ASSERT_EQ(r.status, Status::ok);
  const Estimate<double>& e = r.e();
  print_estimate("bands", e, sc.drive);
  // THEN neither direction reports a usable Fs/vs,
  // AND sigma and Fc are still identified within 1 %
  expect_stribeck_flagged_friction_kept(e, sc.drive);
}

INSTANTIATE_TEST_SUITE_P(Masses, StribeckBelowResolution, ::testing::Values(20.0, 100.0, 400.0),
                         [](const ::testing::TestParamInfo<double>& i) {
                           return "m" + std::to_string(int(i.param));
                         });

/// Constant-speed segments in both directions, separated by time gaps longer
/// than max_gap_s, so no integral ever spans a speed change. The reported
/// velocity jitters by +-1 quantum (quantisation) around the true speed; the
/// force is F(true speed) + noise.
host::Trace constant_velocity_trace(const host::DriveParams& d, double rate_hz, double quantum_m_s,
                                    std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.5);
  std::uniform_int_distribution<int> jitter(-1, 1);
  host::Trace tr;
  tr.source = "constant velocity";
  const double dt = 1.0 / rate_hz, hold_s = 2.0, gap_s = 0.5;
  const int levels = 12;
  double t = 0.0, x = 0.0;
  for (int i = 0; i < 2 * levels; ++i) {
    const double speed = 5e-4 * std::pow(0.15 / 5e-4, double(i / 2) / (levels - 1));
    const double v = (i % 2 == 0 ? 1.0 : -1.0) * speed;
    const auto n = static_cast<int>(hold_s * rate_hz);
    for (int k = 0; k < n; ++k) {
      x += v * dt;
      const double vm = v + jitter(rng) * quantum_m_s;
      tr.samples.push_back(host::TraceSample{t, x, vm, host::stribeck_friction(d, v) + noise(rng)});
      t += dt;
    }
    t += gap_s;
  }
  return tr;
}

TEST(DegeneratePlant, ConstantVelocityOnlyFlagsMass) {
  // GIVEN segments of constant velocity, no acceleration ever observed
  const host::DriveParams d{};
  const double rate = 1000.0, quantum = 1e-5;
  const host::Trace tr = constant_velocity_trace(d, rate, quantum, 3);
  // WHEN streamed and solved
  const Streamed r = run_stream(tr, test::default_config<double>(1e-8, rate));
  const Estimate<double>& e = r.e();
  print_estimate("bands", e, d);
  EXPECT_GT(r.est->diagnostics().continuity_breaks, 0u);
  // THEN the mass is flagged as not identifiable
  EXPECT_NE(e.mass_flags & flag_no_acceleration, 0u);
  EXPECT_FALSE(e.mass_identified());
  // AND the friction of both directions is still identified (sigma, Fc within 1 %)
  ASSERT_EQ(r.status, Status::ok);
  for (const auto* p : {&e.pos, &e.neg}) {
    const host::DirectionFriction& t = p == &e.pos ? d.pos : d.neg;
    EXPECT_TRUE(p->friction_identified());
    EXPECT_LT(rel_err(p->viscous_Ns_m, t.viscous_Ns_m), 0.01) << p->viscous_Ns_m;
    EXPECT_LT(rel_err(p->coulomb_N, t.coulomb_N), 0.01) << p->coulomb_N;
  }
}

TEST(DegeneratePlant, RestJitterOnlyIsInsufficientData) {
  // GIVEN 30 s of an axis at rest: velocity +-1..3 quanta, random force
  const double rate = 1000.0, quantum = 1e-5;
  const host::Trace tr = test::rest_jitter_trace(rate, quantum, 3, 5.0, 30.0, 11);
  const Config<double> cfg = test::default_config<double>(1e-8, rate);
  // WHEN solved with either method
  const Streamed bands = run_stream(tr, cfg, Method::bands);
  const Streamed paper = run_stream(tr, cfg, Method::paper);
  // THEN there is nothing to identify
  EXPECT_EQ(bands.status, Status::insufficient_data);
  EXPECT_EQ(paper.status, Status::insufficient_data);
  EXPECT_NE(bands.e().pos.flags & flag_no_data, 0u);
  EXPECT_NE(bands.e().neg.flags & flag_no_data, 0u);
  EXPECT_FALSE(bands.e().mass_identified());
}

}  // namespace
