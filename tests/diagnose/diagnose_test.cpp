// The diagnosis on traces whose truth the test knows. GIVEN a simulated
// drive logged under one of the force conventions and velocity filters,
// WHEN diagnose runs on the trace alone, THEN an effect-free trace is called
// `none` (a logging convention is not a physical effect), and a trace with
// one catalogued effect is called by that effect, which closes most of the
// held-out gap.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/blind_bench.hpp"
#include "diagnose/diagnose.hpp"
#include "io/csv_trace.hpp"
#include "test_support.hpp"

namespace feedid::test {
namespace {

using host::ForceLog;
using host::VelocityLog;

struct DiagCase {
  ForceLog force;
  VelocityLog velocity;
  double duration_s;
};

host::SimConfig logged(const DiagCase& c, std::uint64_t seed) {
  SimSpec spec;
  spec.encoder_m = 5e-8;
  spec.seed = seed;
  spec.duration_s = c.duration_s;
  return logged_config(spec, c.force, c.velocity);
}

class NoFalseAlarm : public ::testing::TestWithParam<DiagCase> {};

// 30 s ladders alternate direction about every 0.75 s: fixed 0.75 s folds
// once put each direction in one half of the split and called every one of
// these `unexplained`.
TEST_P(NoFalseAlarm, EffectFreeTraceIsCalledNone) {
  const host::SimConfig cfg = logged(GetParam(), 11);
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.effect, "none") << host::summary(r);
  EXPECT_LT(r.rms_base_N, 1.4 * r.noise_floor_N);
}

std::string diag_name(const DiagCase& c) {
  return std::string(host::force_log_name(c.force)) + "_" + host::velocity_log_name(c.velocity) + "_" +
         std::to_string(static_cast<int>(c.duration_s)) + "s";
}

INSTANTIATE_TEST_SUITE_P(Conventions, NoFalseAlarm,
                         ::testing::Values(DiagCase{ForceLog::held, VelocityLog::backward_difference, 30.0},
                                           DiagCase{ForceLog::instant, VelocityLog::moving_average, 30.0},
                                           DiagCase{ForceLog::averaged, VelocityLog::low_pass, 30.0},
                                           DiagCase{ForceLog::instant, VelocityLog::backward_difference, 60.0}),
                         [](const auto& info) { return diag_name(info.param); });

// A 3 N, 5 mm position ripple under an instantaneous force log is named,
// its period recovered within 2 %, and most of the held-out gap closed.
// The independent open-loop plant, on the motions a drive sees in service.
// Production: the only slow positive jog may fall in a held-out fold, where
// the base fit cannot predict (it was called `unexplained` at 10x the floor).
// Instant log: the force is point-sampled and the trapezoid reference steps
// its acceleration between ticks (it was `unexplained` at 1.8-3x).
host::SimConfig open_loop(host::Program program, ForceLog force, std::uint64_t seed) {
  host::SimConfig c = logged(DiagCase{force, VelocityLog::low_pass, 60.0}, seed);
  c.plant = host::PlantKind::open_loop;
  c.motion.program = program;
  c.controller.servo_rate_hz = 4000.0;
  return c;
}

// GIVEN short ladders of an effect-free drive (8 to 12 s: the speeds logged
// end inside the Stribeck fall, so the base's friction law is not settled)
// WHEN diagnosed
// THEN the unsettled base is said, and no change of friction with speed or
// time is named in its place (8 s named a thermal drift of +2700 N s/m
// viscous change, 12 s a quadratic damping that "closed" 97 % of the gap)
TEST(DiagnoseBase, AnUnsettledFrictionLawIsSaidAndNothingStandsInForIt) {
  for (const double seconds : {8.0, 10.0, 12.0}) {
    SimSpec spec;
    spec.duration_s = seconds;
    const host::DiagnoseResult r = host::diagnose(host::simulate(sim_config(spec)), host::DiagnoseOptions{});
    ASSERT_TRUE(r.error.empty()) << seconds << " s: " << r.error;
    bool said = false;
    for (const auto& a : r.ambiguities) said = said || a["kinds"][0] == "base_friction_unsettled";
    EXPECT_TRUE(said) << seconds << " s\n" << host::summary(r);
    for (const auto& e : r.effects)
      EXPECT_TRUE(e.kind != "thermal_drift" && e.kind != "quadratic_viscous") << seconds << " s\n" << host::summary(r);
  }
  // A strong quadratic damping beside a ripple (blind pair case 27 of seed
  // 31) leaves the base's Coulomb force slightly negative in one
  // direction: that base is not physical, but its friction does not fall
  // with speed, and the damping is still named.
  host::BlindOptions o;
  o.cases = 30;
  o.seed = 31;
  o.labels = "pair";
  o.write_case = 27;
  o.quiet = true;
  o.case_path = ::testing::TempDir() + "blind_pair_27.csv";
  ASSERT_EQ(host::run_blind_bench(o).bad_input, "");
  const host::CsvResult pair = host::read_trace_csv(o.case_path, host::CsvColumns{});
  ASSERT_TRUE(pair.error.empty()) << pair.error;
  const host::DiagnoseResult q = host::diagnose(pair.trace, host::DiagnoseOptions{});
  ASSERT_TRUE(q.error.empty()) << q.error;
  EXPECT_TRUE(std::any_of(q.effects.begin(), q.effects.end(), [](const auto& e) { return e.kind == "quadratic_viscous"; }))
      << host::summary(q);
  // A constant load larger than the Coulomb force (an inclined axis) leaves
  // one direction's Coulomb force negative; friction does not fall with
  // speed there, and a quadratic damping beside it is named.
  SimSpec loaded;
  host::SimConfig lc = sim_config(loaded);
  lc.effects.quadratic_c2_Ns2_m2 = 3000.0;
  lc.effects.load.offset_N = 300.0;
  const host::DiagnoseResult l = host::diagnose(host::simulate(lc), host::DiagnoseOptions{});
  ASSERT_TRUE(l.error.empty()) << l.error;
  EXPECT_EQ(l.effect, "quadratic_viscous") << host::summary(l);
  for (const auto& a : l.ambiguities) EXPECT_NE(a["kinds"][0], "base_friction_unsettled") << host::summary(l);
  // A ladder long enough to settle it says nothing of the kind.
  SimSpec settled;
  settled.duration_s = 30.0;
  const host::DiagnoseResult r = host::diagnose(host::simulate(sim_config(settled)), host::DiagnoseOptions{});
  for (const auto& a : r.ambiguities) EXPECT_NE(a["kinds"][0], "base_friction_unsettled") << host::summary(r);
}

// GIVEN a trace that moves one way only (the ladder's negative strokes
// folded onto the positive: position unwound, force negated there)
// WHEN diagnosed
// THEN the base's negative direction has no data, and no offset or Coulomb
// asymmetry is claimed against it (its zero made a "25 N difference, an
// offset of 12.5 N"); the one-way motion is said instead.
TEST(DiagnoseBase, AOneWayTraceClaimsNoOffsetAgainstTheDirectionItNeverSaw) {
  SimSpec spec;
  spec.duration_s = 30.0;
  host::Trace tr = host::simulate(sim_config(spec));
  double unwound = tr.samples.front().x_m;
  for (std::size_t k = 1; k < tr.samples.size(); ++k) {
    const double step = tr.samples[k].x_m - tr.samples[k - 1].x_m;
    tr.samples[k - 1].x_m = unwound;
    unwound += std::fabs(step);
  }
  tr.samples.back().x_m = unwound;
  for (auto& smp : tr.samples)
    if (smp.v_m_s < 0) smp.v_m_s = -smp.v_m_s, smp.u_N = -smp.u_N;
  const host::DiagnoseResult r = host::diagnose(tr, host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_FALSE(r.base.estimate.neg.friction_identified()) << host::summary(r);
  bool said = false;
  for (const auto& a : r.ambiguities) {
    EXPECT_FALSE(a.contains("offset_N")) << a.dump();
    said = said || a.value("note", "").find("positive direction only") != std::string::npos;
  }
  EXPECT_TRUE(said) << host::summary(r);
}

/// The kinds of r's ambiguity that names `kind` beside another, or empty.
std::vector<std::string> rival_of(const host::DiagnoseResult& r, const std::string& kind) {
  for (const auto& a : r.ambiguities)
    if (a.contains("z") && a["kinds"][0] == kind) return a["kinds"].get<std::vector<std::string>>();
  return {};
}

// GIVEN a load smooth in position over 30 s (a sine 1.33 travels long:
// per-direction friction profiles draw it as well as a long ripple does)
// WHEN diagnosed on several seeds
// THEN whichever is named, the other is reported beside it as a rival the
// run does not tell apart; a short ripple, which nothing else draws, has none
TEST(DiagnoseAmbiguity, TwoFamiliesThatFitAlikeAreReportedAsRivals) {
  for (const std::uint64_t seed : {1, 3}) {
    SimSpec spec;
    spec.duration_s = 30.0;
    spec.seed = seed;
    host::SimConfig cfg = sim_config(spec);
    cfg.effects.ripple_amplitude_N = 4.0;
    cfg.effects.ripple_period_m = 0.15;
    const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
    ASSERT_TRUE(r.error.empty()) << r.error;
    ASSERT_TRUE(r.effect == "position_friction" || r.effect == "position_ripple") << host::summary(r);
    const std::vector<std::string> kinds = rival_of(r, r.effect);
    ASSERT_EQ(kinds.size(), 2u) << host::summary(r);
    EXPECT_EQ(kinds[1], r.effect == "position_ripple" ? "position_friction" : "position_ripple") << host::summary(r);
  }
  SimSpec spec;
  spec.duration_s = 30.0;
  host::SimConfig cfg = sim_config(spec);
  cfg.effects.ripple_amplitude_N = 4.0;
  cfg.effects.ripple_period_m = 0.01;
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_EQ(r.effect, "position_ripple") << host::summary(r);
  EXPECT_TRUE(rival_of(r, r.effect).empty()) << host::summary(r);
  // Two effects that are both there each close part of the first step's
  // gap, so the first step's runner-up can look like a rival: once named
  // at the next step it is the other half of the answer, not a rival.
  SimSpec both_spec;
  host::SimConfig both = sim_config(both_spec);
  both.effects.ripple_amplitude_N = 4.0;
  both.effects.ripple_period_m = 0.01;
  both.effects.drift_fraction = 0.3;
  const host::DiagnoseResult b = host::diagnose(host::simulate(both), host::DiagnoseOptions{});
  ASSERT_TRUE(b.error.empty()) << b.error;
  ASSERT_GE(b.effects.size(), 2u) << host::summary(b);
  for (const auto& a : b.ambiguities) EXPECT_FALSE(a.contains("z")) << a.dump() << "\n" << host::summary(b);
}

// GIVEN a block length that is no length (0, negative, NaN, infinite),
// THEN the diagnosis refuses it by name instead of answering 'none' or
// 'too little motion'.
TEST(DiagnoseOptionsCheck, ABlockThatIsNoLengthIsRefused) {
  const host::Trace t = host::simulate(test::sim_config(test::SimSpec{}));
  for (double block : {0.0, -0.01, std::nan(""), HUGE_VAL}) {
    host::DiagnoseOptions o;
    o.block_s = block;
    const std::string why = host::diagnose(t, o).error;
    EXPECT_NE(why.find("--block"), std::string::npos) << block << ": " << why;
    EXPECT_NE(why.find("positive, finite"), std::string::npos) << block << ": " << why;
  }
}

TEST(DiagnoseOpenLoopPlant, EffectFreeProgramsAreCalledNone) {
  for (const host::Program p : {host::Program::ladder, host::Program::sine, host::Program::production}) {
    const host::DiagnoseResult r = host::diagnose(host::simulate(open_loop(p, ForceLog::instant, 5)), host::DiagnoseOptions{});
    ASSERT_TRUE(r.error.empty()) << r.error;
    EXPECT_EQ(r.effect, "none") << host::program_name(p) << "\n" << host::summary(r);
  }
}

TEST(DiagnoseOpenLoopPlant, QuadraticDampingOnSineMotionIsNamed) {
  // On sine motion v|v| is 99.8 % collinear with v and the Stribeck terms;
  // the held-out test, not the collinearity, must decide.
  host::SimConfig c = open_loop(host::Program::sine, ForceLog::averaged, 6);
  c.effects.quadratic_c2_Ns2_m2 = 800.0;  // 18 N at 0.15 m/s
  const host::DiagnoseResult r = host::diagnose(host::simulate(c), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "quadratic_viscous") << host::summary(r);
  EXPECT_NEAR(r.effect_parameters.value("c2", 0.0), 800.0, 80.0);
  EXPECT_GT(r.closed_fraction, 0.8);
}

TEST(DiagnoseEffect, PositionRippleUnderAnotherForceConvention) {
  host::SimConfig cfg = logged({ForceLog::instant, VelocityLog::backward_difference, 40.0}, 3);
  cfg.effects.ripple_amplitude_N = 3.0;
  cfg.effects.ripple_period_m = 5e-3;
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "position_ripple") << host::summary(r);
  ASSERT_TRUE(r.effect_parameters.contains("period_m")) << r.effect_parameters.dump();
  EXPECT_NEAR(r.effect_parameters["period_m"].get<double>(), 5e-3, 1e-4);
  EXPECT_GT(r.closed_fraction, 0.8);
}

// The summary's parameters name the log's units as the JSON does: a review
// saw {"delta_N": ..., "x_max_m": ...} printed for a log in rad and V.
TEST(DiagnoseEffect, TheSummaryNamesTheParametersInTheLogsUnits) {
  host::SimConfig cfg = logged({ForceLog::instant, VelocityLog::backward_difference, 40.0}, 3);
  cfg.effects.ripple_amplitude_N = 3.0;
  cfg.effects.ripple_period_m = 5e-3;
  host::DiagnoseOptions opt;
  opt.identify.units = host::units_for(host::Axis::rotary, "V");
  opt.identify.gravity = host::GravityTerm::none;
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), opt);
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "position_ripple") << host::summary(r);
  const std::string text = host::summary(r);
  EXPECT_NE(text.find("\"amplitude_V\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"period_rad\""), std::string::npos) << text;
  EXPECT_EQ(text.find("\"amplitude_N\""), std::string::npos) << text;
}

TEST(DiagnoseEffect, AnArmsWeightIsTheBasesNotAnEffect) {
  // GIVEN an arm whose weight is 30 N m at 0.4 rad (its friction 25 N m)
  host::DiagnoseOptions opt;
  opt.identify.units = host::units_for(host::Axis::rotary);
  const host::DiagnoseResult r = host::diagnose(arm_trace(30.0, 0.4), opt);
  ASSERT_TRUE(r.error.empty()) << r.error;
  // THEN the base's identification fits the weight (gravity auto on a
  // rotary axis), and no effect takes it up again: the gap is the noise
  EXPECT_EQ(r.base.gravity.form, host::GravityTerm::angle) << r.base.gravity.note;
  EXPECT_NEAR(r.base.gravity.G, 30.0, 0.5);
  EXPECT_EQ(r.effect, "none") << host::summary(r);
  EXPECT_LT(r.rms_base_N, 1.5 * r.noise_floor_N) << host::summary(r);
}

// A physical delay of 2.5 periods under an instantaneous force log: the
// conventions explain a force delay of up to 0.6 period, so `delay` is named
// and its size is the part beyond that (docs/diagnosis.md, "Timing").
TEST(DiagnoseEffect, DelayBeyondTheConventionsIsNamedAndSizedBeyondThem) {
  host::SimConfig cfg = logged({ForceLog::instant, VelocityLog::backward_difference, 40.0}, 5);
  const double period = 1.0 / cfg.controller.servo_rate_hz;
  cfg.effects.delay_s = 2.5 * period;
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "delay") << host::summary(r);
  EXPECT_NEAR(r.lag_beyond_conventions_s / period, 2.5 - 0.6, 0.2);
  EXPECT_NEAR(r.effect_parameters["delay_s"].get<double>() / period, 2.5 - 0.6, 0.3) << r.effect_parameters.dump();
}

// A log without a position column: the diagnosis integrates velocity for
// the position and reversal candidates, and says so. It used zeros, which no
// ripple fits.
TEST(DiagnoseEffect, RippleWithoutAPositionColumnIsFoundOnIntegratedVelocity) {
  host::SimConfig cfg = logged({ForceLog::held, VelocityLog::backward_difference, 40.0}, 3);
  cfg.effects.ripple_amplitude_N = 3.0;
  cfg.effects.ripple_period_m = 5e-3;
  host::Trace trace = host::simulate(cfg);
  trace.has_position = false;
  for (auto& s : trace.samples) s.x_m = 0.0;
  const host::DiagnoseResult r = host::diagnose(trace, host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "position_ripple") << host::summary(r);
  EXPECT_NEAR(r.effect_parameters["period_m"].get<double>(), 5e-3, 2e-4);
  EXPECT_NE(r.position_origin.find("integrated from the velocity"), std::string::npos);
}

// A log without a velocity column: the base model's JSON says the velocity
// was derived, not "measured" (the identification folds reach the core as a
// column, which had made it say measured).
TEST(DiagnoseEffect, DerivedVelocityIsReportedAsDerived) {
  host::Trace trace = host::simulate(logged({ForceLog::held, VelocityLog::backward_difference, 30.0}, 2));
  trace.has_velocity = false;
  const host::DiagnoseResult r = host::diagnose(trace, host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.base.signals.velocity_origin.rfind("derived", 0), 0u) << r.base.signals.velocity_origin;
}

// Per candidate term: a trace with exactly that effect gives back its
// parameters. Tolerances are about three times the blind benchmark's median
// errors (docs/blind_bench_seed11.md): position range edges 5 % of its width
// and its force 10 %; presliding work 2 Fp d 10 %; compliance frequency 6 %
// and load mass 30 %.
TEST(DiagnoseParameters, PositionFrictionRangeAndForce) {
  host::SimConfig cfg = logged({ForceLog::held, VelocityLog::moving_average, 40.0}, 7);
  cfg.effects.position_friction_N = 10.0;
  cfg.effects.position_friction_x_min_m = 0.03;  // inside the ladder's 0.11 m of travel
  cfg.effects.position_friction_x_max_m = 0.08;
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "position_friction") << host::summary(r);
  const nlohmann::json& p = r.effect_parameters;
  EXPECT_NEAR(p.value("x_min_m", 0.0), 0.03, 0.05 * 0.05) << p.dump();
  EXPECT_NEAR(p.value("x_max_m", 0.0), 0.08, 0.05 * 0.05) << p.dump();
  EXPECT_NEAR(p.value("delta_N", 0.0), 10.0, 1.0) << p.dump();
}

// 60 s: over 40 s of the default ladder the same presliding closed 43 % of
// the gap at z = 2.3 (too few reversals in the held-out folds) and was
// called `unexplained` (docs/diagnosis.md, Limits).
TEST(DiagnoseParameters, PreslidingDistanceAndForce) {
  host::SimConfig cfg = logged({ForceLog::averaged, VelocityLog::backward_difference, 60.0}, 8);
  cfg.effects.presliding_force_N = 12.0;
  cfg.effects.presliding_distance_m = 30e-6;
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "presliding_hysteresis") << host::summary(r);
  // What a reversal's few blocks carry is the friction work the bristles
  // take, 2 Fp d; force and distance trade against each other along it
  // (here 6.4 N over 54 um for 12 N over 30 um), so each alone is only
  // checked to a factor of two.
  const nlohmann::json& p = r.effect_parameters;
  const double d = p.value("distance_m", 0.0), f = p.value("force_N", 0.0);
  EXPECT_NEAR(f * d, 12.0 * 30e-6, 0.1 * 12.0 * 30e-6) << p.dump();
  EXPECT_GT(d, 15e-6) << p.dump();
  EXPECT_LT(d, 60e-6) << p.dump();
  EXPECT_GT(f, 6.0) << p.dump();
  EXPECT_LT(f, 24.0) << p.dump();
}

TEST(DiagnoseParameters, ComplianceFrequencyAndLoadMass) {
  host::SimConfig cfg = logged({ForceLog::instant, VelocityLog::low_pass, 40.0}, 9);
  cfg.effects.compliance_frequency_hz = 30.0;
  cfg.effects.compliance_mass_fraction = 0.3;
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "compliance") << host::summary(r);
  const nlohmann::json& p = r.effect_parameters;
  EXPECT_NEAR(p.value("frequency_hz", 0.0), 30.0, 0.06 * 30.0) << p.dump();
  EXPECT_NEAR(p.value("load_mass_kg", 0.0), 0.3 * cfg.drive.mass_kg, 0.3 * 0.3 * cfg.drive.mass_kg) << p.dump();
}

// Two effects at once: forward selection names both, each from what the
// other leaves, and together they close most of the held-out gap.
/// A 4 N ripple of 8 mm and a thermal drift of 40 % over 15 s, 60 s held force.
host::SimConfig ripple_and_drift() {
  host::SimConfig cfg = logged({ForceLog::held, VelocityLog::backward_difference, 60.0}, 4);
  cfg.effects.ripple_amplitude_N = 4.0;
  cfg.effects.ripple_period_m = 8e-3;
  cfg.effects.drift_fraction = 0.4;
  cfg.effects.drift_time_constant_s = 15.0;
  return cfg;
}

TEST(DiagnoseEffects, RippleAndThermalDriftAreBothNamed) {
  const host::DiagnoseResult r = host::diagnose(host::simulate(ripple_and_drift()), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  std::vector<std::string> named;
  for (const auto& e : r.effects) named.push_back(e.kind);
  std::sort(named.begin(), named.end());
  EXPECT_EQ(named, (std::vector<std::string>{"position_ripple", "thermal_drift"})) << host::summary(r);
  EXPECT_GT(r.closed_fraction, 0.8);
}

// The families of a selection step are searched on several threads at
// once; they share the observations, the column bank's products and
// nothing they write. Two effects take two steps (the second beside the
// first's columns, whose products with the others the threads fill in),
// so the JSON must be the same to the bit on one thread and on three.
TEST(DiagnoseEffects, TheDiagnosisIsTheSameOnAnyNumberOfThreads) {
  const host::Trace trace = host::simulate(ripple_and_drift());
  host::DiagnoseOptions one, three;
  one.threads = 1;
  three.threads = 3;
  const host::DiagnoseResult a = host::diagnose(trace, one), b = host::diagnose(trace, three);
  ASSERT_TRUE(a.error.empty()) << a.error;
  ASSERT_GE(a.effects.size(), 2u) << host::summary(a);
  ASSERT_GE(a.steps.size(), 2u) << host::summary(a);
  EXPECT_EQ(host::to_json(a).dump(), host::to_json(b).dump());
}

// A progress callback that throws while the families run on threads: the
// exception reaches the caller (the threads are joined), not
// std::terminate.
TEST(DiagnoseEffects, AThrowingProgressCallbackOnThreadsIsTheCallersException) {
  host::DiagnoseOptions opt;
  opt.threads = 3;
  opt.progress = [](double share) {
    if (share > 0.3) throw std::runtime_error("stop");
  };
  EXPECT_THROW(host::diagnose(host::simulate(ripple_and_drift()), opt), std::runtime_error);
}

// An offset is the same regressor as Coulomb friction that differs by
// direction: the diagnosis reports the ambiguity with the offset's size
// and names no effect from it.
TEST(DiagnoseEffects, OffsetIsReportedAsAmbiguousNotNamed) {
  host::SimConfig cfg = logged({ForceLog::held, VelocityLog::backward_difference, 30.0}, 6);
  cfg.effects.load.offset_N = 8.0;
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.effect, "none") << host::summary(r);
  ASSERT_EQ(r.ambiguities.size(), 1u) << host::summary(r);
  EXPECT_NEAR(r.ambiguities[0]["offset_N"].get<double>(), 8.0, 0.5);
}

}  // namespace
}  // namespace feedid::test

namespace feedid::test {
namespace {

// GIVEN an effect-free drive whose velocity column is in another unit or
// of the other sign than its position (the other sign; mm/s beside m; a
// motor-side column through a 1:5 gear), WHEN identify and diagnose run
// with nothing told, THEN the column's gain is measured against the
// position and the column is left out: identify meets the bar on m, sigma
// and Fc, and the diagnosis names no effect. Taken as it was, the reversed
// column put the held-out gap at 26 times the noise floor, `unexplained`.
TEST(VelocityColumn, AColumnInAnotherUnitOrSignIsLeftOut) {
  SimSpec spec;
  spec.duration_s = 30.0;
  spec.seed = 12;
  const host::SimConfig cfg = sim_config(spec);
  const host::Trace logged = host::simulate(cfg);
  for (const double gain : {-1.0, 1000.0, 5.0}) {
    SCOPED_TRACE(gain);
    host::Trace t = logged;
    for (auto& smp : t.samples) smp.v_m_s *= gain;
    const host::IdentifyResult id = host::identify(t, host::IdentifyOptions{});
    ASSERT_TRUE(id.error.empty()) << id.error;
    EXPECT_FALSE(id.signals.has_velocity_column);
    EXPECT_NEAR(id.signals.velocity_column_gain, gain, 0.01 * std::fabs(gain));
    EXPECT_NE(id.signals.velocity_origin.find("left out"), std::string::npos) << id.signals.velocity_origin;
    EXPECT_NEAR(id.estimate.mass_kg, cfg.drive.mass_kg, 0.01 * cfg.drive.mass_kg);
    EXPECT_NEAR(id.estimate.pos.coulomb_N, cfg.drive.pos.coulomb_N, 0.01 * cfg.drive.pos.coulomb_N);
    EXPECT_NEAR(id.estimate.neg.viscous_Ns_m, cfg.drive.neg.viscous_Ns_m, 0.01 * cfg.drive.neg.viscous_Ns_m);
    const host::DiagnoseResult r = host::diagnose(t, host::DiagnoseOptions{});
    ASSERT_TRUE(r.error.empty()) << r.error;
    EXPECT_EQ(r.effect, "none") << host::summary(r);
  }
  // The column as logged is kept (gain 1 within a hundredth).
  const host::IdentifyResult id = host::identify(logged, host::IdentifyOptions{});
  EXPECT_TRUE(id.signals.has_velocity_column);
  EXPECT_NEAR(id.signals.velocity_column_gain, 1.0, 0.01);
}

}  // namespace
}  // namespace feedid::test
