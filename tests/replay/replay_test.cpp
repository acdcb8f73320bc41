// Closed-loop replay (host_sim/replay): the controller file, the gains a
// logged command reveals, and the replay itself against a loop simulated
// independently (the simulator's ServoAxis runs its own controller code
// around the same plant class).
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "io/trace_files.hpp"
#include "model/constants.hpp"
#include "replay/replay.hpp"
#include "report/report.hpp"
#include "sim/drive_sim.hpp"
#include "sim/named_effects.hpp"
#include "test_support.hpp"

namespace {

using namespace feedid::host;
using nlohmann::json;

json minimal_controller() {
  return json{{"kp", 60.0},         {"kv", 2.0 * kPi * 40.0 * 100.0}, {"drive_gain", 1.0}, {"saturation", 5000.0},
              {"position_fir", {1.0}}, {"delay_samples", 0},          {"reference", "r"},  {"extra_command", "pulse"}};
}

TEST(ReplayController, EachMissingRequiredKeyIsNamed) {
  for (const char* key : {"drive_gain", "saturation", "position_fir", "delay_samples", "reference"}) {
    json j = minimal_controller();
    j.erase(key);
    const std::string e = controller_from_json(j, "c.json").error;
    EXPECT_NE(e.find(std::string("missing key '") + key + "'"), std::string::npos) << key << ": " << e;
    EXPECT_NE(e.find("c.json"), std::string::npos) << e;
  }
}

TEST(ReplayController, GainsAndExtraCommandAreOptionalUnknownKeysWarned) {
  json j = minimal_controller();
  j.erase("kp");
  j.erase("kv");
  j.erase("extra_command");
  j["kd"] = 3.0;
  const Controller c = controller_from_json(j, "c.json");
  EXPECT_FALSE(c.kp.has_value());
  EXPECT_TRUE(needs_fit(c));
  EXPECT_TRUE(c.extra_command.empty());
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("'kd'"), std::string::npos);
}

TEST(ReplayController, BadValuesAreNamed) {
  json j = minimal_controller();
  j["law"] = "pid";
  EXPECT_NE(controller_from_json(j, "c").error.find("'law'"), std::string::npos);
  j = minimal_controller();
  j["position_fir"] = {0.5, 0.4};
  EXPECT_NE(controller_from_json(j, "c").error.find("sum to 1"), std::string::npos);
  j = minimal_controller();
  j["delay_samples"] = 1.5;
  EXPECT_NE(controller_from_json(j, "c").error.find("'delay_samples'"), std::string::npos);
  j = minimal_controller();
  j["saturation"] = 0;
  EXPECT_NE(controller_from_json(j, "c").error.find("'saturation'"), std::string::npos);
}

// GIVEN a controller file whose kp or kv is 0 (a loop that holds no
// position or commands no force: a replay with it ran and reported
// position errors of thousands of percent as a result)
// THEN the file is refused, naming the gain; a ki of 0 is no integral and
// is kept, and a ki under law "pd", where it plays no part, is warned of
TEST(ReplayController, ZeroLoopGainsAreRefusedAZeroIntegralIsKept) {
  for (const char* key : {"kp", "kv"}) {
    json j = minimal_controller();
    j[key] = 0.0;
    const std::string e = controller_from_json(j, "c.json").error;
    EXPECT_NE(e.find(std::string("'") + key + "' must be > 0"), std::string::npos) << key << ": " << e;
  }
  json pi = minimal_controller();
  pi["law"] = "p_pi";
  pi["ki"] = 0.0;
  const Controller kept = controller_from_json(pi, "c.json");
  EXPECT_EQ(kept.error, "");
  ASSERT_TRUE(kept.ki.has_value());
  EXPECT_EQ(*kept.ki, 0.0);
  EXPECT_TRUE(kept.warnings.empty());
  json pd = minimal_controller();
  pd["ki"] = 3.0;
  const Controller ignored = controller_from_json(pd, "c.json");
  EXPECT_EQ(ignored.error, "");
  ASSERT_EQ(ignored.warnings.size(), 1u);
  EXPECT_NE(ignored.warnings[0].find("'ki' is ignored"), std::string::npos) << ignored.warnings[0];
}

TEST(ReplayController, VelocityEstimateIsTheFirDifference) {
  // qf(k) = 0.5 q(k) + 0.5 q(k-1), dq = (qf(k) - qf(k-1)) / dt, at rest before the first sample
  VelocityEstimate v({0.5, 0.5}, 0.001);
  EXPECT_EQ(v.next(1.0), 0.0);
  EXPECT_NEAR(v.next(1.002), 1.0, 1e-9);  // qf: 1 -> 1.001
  EXPECT_NEAR(v.next(1.004), 2.0, 1e-9);  // qf: 1.001 -> 1.003
}

/// A reference that moves both ways at several speeds and dwells between
/// moves (the axis sticks there): x0 + A sin^2 over moves of T_i, then a hold.
double reference_at(double t) {
  const double moves[][2] = {{1.2, 0.06}, {0.5, -0.01}, {2.0, 0.04}, {0.8, 0.02}};  // duration (s), amplitude (m)
  double t0 = 0.0;
  for (const auto& m : moves) {
    const double T = m[0];
    if (t < t0 + T) return m[1] * std::pow(std::sin(kPi * (t - t0) / T), 2);
    t0 += T;
    if (t < t0 + 0.4) return 0.0;
    t0 += 0.4;
  }
  return 0.0;
}

DriveParams true_drive() {
  DriveParams d;
  d.mass_kg = 100.0;
  d.pos = {200.0, 20.0, 6.0, 2e-3};
  d.neg = {230.0, 22.0, 5.0, 2e-3};
  return d;
}

/// A run logged from the simulator's own loop at 1 kHz: u = kv (kp (r - x) -
/// dx) with dx the backward difference (FIR [1]), no delay, plus a pulse
/// train added to the force; no encoder quantum, no noise. With
/// integral_hz, its PI adds ki = kv 2 pi integral_hz on the velocity error.
LoggedRun simulated_run(const DriveParams& d, double duration_s, double integral_hz = 0.0, const Effects& fx = {},
                        const ExtraForce& extra = {}) {
  SimConfig cfg;
  cfg.drive = d;
  cfg.effects = fx;
  cfg.extra_force = extra;
  cfg.controller.servo_rate_hz = 1000.0;
  cfg.controller.velocity_integral_hz = integral_hz;
  cfg.controller.acceleration_feedforward = false;
  cfg.sensors.encoder_resolution_m = 0.0;
  ServoAxis axis(cfg);
  LoggedRun run;
  run.source = "simulated";
  for (int k = 0; k * 1e-3 <= duration_s; ++k) {
    const double t = k * 1e-3;
    const double pulse = std::fmod(t, 1.0) > 0.5 && std::fmod(t, 1.0) < 0.55 ? 150.0 : 0.0;
    const TraceSample s = axis.step(t, PathPoint{reference_at(t), 0.0, 0.0}, PathPoint{reference_at(t + 1e-3), 0.0, 0.0}, pulse);
    run.t.push_back(t);
    run.x.push_back(s.x_m);
    run.u.push_back(s.u_N);
    run.reference.push_back(reference_at(t));
    run.extra.push_back(pulse);
  }
  return run;
}

ModelFile model_of(const DriveParams& d) {
  ModelFile m;
  m.drive = d;
  return m;
}

// GIVEN a log in mm with its reference and extra command, read in one pass
// THEN the reference is scaled like the position and the extra command is
// as logged; a bad extra value on one row, or no extra column, reads as
// the columns read one by one did: the row named, or none added with a note.
TEST(ReplayRun, ReferenceAndExtraCommandAreReadWithTheTrace) {
  const std::string path = ::testing::TempDir() + "replay_run_columns.csv";
  const auto write = [&path](const std::string& bad_extra, bool with_extra) {
    std::ofstream f(path);
    f << "t,x,u,r" << (with_extra ? ",e" : "") << "\n";
    for (int k = 0; k < 50; ++k) {
      f << k * 1e-3 << "," << 2.0 * k << ",1.5," << 3.0 * k;
      if (with_extra) f << "," << (k == 20 ? bad_extra : std::to_string(0.25 * k));
      f << "\n";
    }
  };
  CsvColumns cols;
  cols.position_scale = 1e-3;
  json j = minimal_controller();
  j["extra_command"] = "e";
  const Controller c = controller_from_json(j, "c");
  write("7.5", true);
  const LoggedRun run = read_logged_run(path, cols, c);
  ASSERT_EQ(run.error, "");
  ASSERT_EQ(run.reference.size(), 50u);
  ASSERT_EQ(run.extra.size(), 50u);
  for (int k = 0; k < 50; ++k) {
    EXPECT_EQ(run.reference[static_cast<std::size_t>(k)], 3.0 * k * 1e-3) << k;
    EXPECT_EQ(run.extra[static_cast<std::size_t>(k)], k == 20 ? 7.5 : 0.25 * k) << k;
  }
  // The one pass is what read them
  LoggedRun one_pass;
  one_pass.t = run.t;
  ASSERT_TRUE(read_reference_and_extra(path, cols, c, one_pass));
  EXPECT_EQ(one_pass.reference, run.reference);
  EXPECT_EQ(one_pass.extra, run.extra);
  // AND that pass started beside the trace's own read is the same pass, on a thread of its own or not
  for (const bool beside : {true, false}) {
    const LoggedRun started =
        read_logged_run(path, cols, c, read_trace_file(path, cols), start_reference_and_extra(path, cols, c, beside).get());
    EXPECT_EQ(started.error, "");
    EXPECT_EQ(started.reference, run.reference) << beside;
    EXPECT_EQ(started.extra, run.extra) << beside;
  }
  write("nan", true);
  EXPECT_NE(read_logged_run(path, cols, c).error.find("extra command column 'e'"), std::string::npos);
  LoggedRun skipped_row;
  skipped_row.t = run.t;
  EXPECT_FALSE(read_reference_and_extra(path, cols, c, skipped_row));
  EXPECT_TRUE(skipped_row.reference.empty());
  write("", false);
  const LoggedRun bare = read_logged_run(path, cols, c);
  EXPECT_EQ(bare.error, "");
  EXPECT_TRUE(bare.extra.empty());
  ASSERT_EQ(bare.notes.size(), 1u);
  EXPECT_NE(bare.notes[0].find("no extra command column 'e'"), std::string::npos);
}

// GIVEN a run whose position is bad on one row (the reference there is fine)
// THEN the replay's refusal names the position's row and why, not the
// reference column (which kept that row and used to take the blame)
TEST(ReplayRun, ARowTheTraceSkipsIsNamedNotBlamedOnTheReference) {
  const std::string path = ::testing::TempDir() + "replay_run_bad_position.csv";
  {
    std::ofstream f(path);
    f << "t,x,u,r\n";
    for (int k = 0; k < 200; ++k) f << k * 1e-3 << "," << (k == 30 ? std::string("abc") : std::to_string(2.0 * k)) << ",1.5," << 3.0 * k << "\n";
  }
  const Controller c = controller_from_json(minimal_controller(), "c");
  const std::string e = read_logged_run(path, CsvColumns{}, c).error;
  EXPECT_NE(e.find(":32: column 'x'"), std::string::npos) << e;
  EXPECT_NE(e.find("needs every row"), std::string::npos) << e;
  EXPECT_EQ(e.find("reference"), std::string::npos) << e;
}

TEST(Replay, TrueModelReproducesAnIndependentlySimulatedLoop) {
  // GIVEN a run logged from the simulator's loop, pulses included
  const LoggedRun run = simulated_run(true_drive(), 7.0);
  const Controller c = controller_from_json(minimal_controller(), "c");
  // WHEN the true model is replayed in that loop
  const ReplayResult r = replay(model_of(true_drive()), c, run, ReplayOptions{});
  ASSERT_EQ(r.error, "");
  // THEN with both sides processed alike every signal agrees to 0.5 %
  EXPECT_LT(r.same_processing_pct.position, 0.5);
  EXPECT_LT(r.same_processing_pct.velocity, 0.5);
  EXPECT_LT(r.same_processing_pct.acceleration, 0.5);
  EXPECT_LT(r.same_processing_pct.force, 0.5);
  EXPECT_LT(r.error_pct.force, 0.5);
  // AND the published comparison differs from it only by the processing
  EXPECT_NEAR(r.error_pct.acceleration, r.processing_pct.acceleration, 0.5);

  // WHEN the mass is 20 % off
  DriveParams heavy = true_drive();
  heavy.mass_kg *= 1.2;
  const ReplayResult w = replay(model_of(heavy), c, run, ReplayOptions{});
  ASSERT_EQ(w.error, "");
  // THEN the force and acceleration errors grow many times over
  EXPECT_GT(w.same_processing_pct.force, 5.0 * std::max(r.same_processing_pct.force, 0.2));
  EXPECT_GT(w.same_processing_pct.acceleration, 5.0 * std::max(r.same_processing_pct.acceleration, 0.2));
}

// GIVEN a run and --filter 1e6 Hz, beyond the log's reach
// THEN the comparison's cut-off is reported as applied (0.4 of the rate)
// and the note says so: 300 Hz to 1e6 Hz gave the same figures while the
// JSON recorded each as asked
TEST(Replay, AFilterBeyondTheRatesReachIsReportedAsApplied) {
  const LoggedRun run = simulated_run(true_drive(), 3.0);
  const Controller c = controller_from_json(minimal_controller(), "c");
  ReplayOptions o;
  o.filter_hz = 1e6;
  const ReplayResult r = replay(model_of(true_drive()), c, run, o);
  ASSERT_EQ(r.error, "");
  const double rate = 1.0 / r.dt_s;
  EXPECT_DOUBLE_EQ(r.filter_applied_hz, 0.4 * rate);
  EXPECT_TRUE(std::any_of(r.notes.begin(), r.notes.end(), [](const std::string& n) { return n.find("--filter 1e+06 Hz") != std::string::npos; }));
  o.filter_hz = 0.4 * rate;
  const ReplayResult at = replay(model_of(true_drive()), c, run, o);
  EXPECT_DOUBLE_EQ(at.error_pct.acceleration, r.error_pct.acceleration);
}

/// 7 s of the true drive in the loop, its plant with a ripple of amplitude
/// (N), period (m) and phase (rad), and any extra force beside it.
LoggedRun rippled_run(double amplitude_N, double period_m, double phase_rad, const ExtraForce& extra = {}) {
  Effects ripple;
  ripple.ripple_amplitude_N = amplitude_N;
  ripple.ripple_period_m = period_m;
  ripple.ripple_phase_rad = phase_rad;
  return simulated_run(true_drive(), 7.0, 0.0, ripple, extra);
}

/// A model file's JSON for drive d with the given effects, as diagnose
/// --model-out writes it.
json model_json(const DriveParams& d, const json& effects) {
  const auto side = [](const DirectionFriction& f) {
    return json{{"sigma", f.viscous_Ns_m}, {"fc", f.coulomb_N}, {"fs", f.breakaway_N}, {"vs", f.stribeck_velocity_m_s}};
  };
  return {{"m", d.mass_kg}, {"pos", side(d.pos)}, {"neg", side(d.neg)}, {"effects", effects}};
}

TEST(Replay, AModelFilesEffectsAreSimulatedInItsPlant) {
  // GIVEN a run whose plant has a position ripple its friction law lacks
  const LoggedRun run = rippled_run(15.0, 0.02, 0.3);
  const Controller c = controller_from_json(minimal_controller(), "c");
  // WHEN replayed with a model file that names the ripple as diagnose writes it, and without it
  const DriveParams d = true_drive();
  const json j = model_json(d, json::array({{{"kind", "position_ripple"},
                                             {"parameters", {{"amplitude_N", 15.0}, {"period_m", 0.02}, {"phase_rad", 0.3}}}}}));
  const ModelFile with = model_file_from_json(j, "m.json");
  ASSERT_TRUE(with.warnings.empty());
  ModelFile bare = with;
  bare.effects = json::array();
  const ReplayResult w = replay(with, c, run, ReplayOptions{}), b = replay(bare, c, run, ReplayOptions{});
  ASSERT_EQ(w.error, "");
  ASSERT_EQ(b.error, "");
  // THEN the effect in the plant closes the gap as the true plant's would, and the replay says so
  EXPECT_LT(w.same_processing_pct.force, 0.5);
  EXPECT_GT(b.same_processing_pct.force, 5.0 * std::max(w.same_processing_pct.force, 0.2));
  bool said = false;
  for (const std::string& n : w.notes) said = said || n.find("position_ripple") != std::string::npos;
  EXPECT_TRUE(said);
  // AND a kind no diagnosis names is an error, not an effect silently left out
  json typo = j;
  typo["effects"][0]["kind"] = "ripple";
  EXPECT_NE(model_file_from_json(typo, "t.json").error.find("\"ripple\""), std::string::npos);
}

// GIVEN a run whose plant has a ripple with a second harmonic (a load not
// one sine: a screw's pitch error, a cogging shape)
// WHEN replayed with the ripple as diagnose writes it, with each harmonic's
// amplitude and phase, and as a file without the phases
// THEN the harmonics are in the plant and close the gap; without the phases
// the fundamental alone is, and the replay says so
TEST(Replay, ARipplesHarmonicsAreSimulatedWithTheirPhases) {
  const ExtraForce second = [](double, double x, double) { return 6.0 * std::sin(2.0 * 2.0 * M_PI * x / 0.05 - 1.1); };
  const LoggedRun run = rippled_run(10.0, 0.05, 0.3, second);
  const Controller c = controller_from_json(minimal_controller(), "c");
  const DriveParams d = true_drive();
  const json ripple = {{"amplitude_N", 10.0}, {"period_m", 0.05}, {"phase_rad", 0.3}, {"harmonics", 2},
                       {"harmonic_amplitudes_N", {10.0, 6.0}}, {"harmonic_phases_rad", {0.3, -1.1}}};
  json j = model_json(d, json::array({{{"kind", "position_ripple"}, {"parameters", ripple}}}));
  const ReplayResult w = replay(model_file_from_json(j, "m.json"), c, run, ReplayOptions{});
  j["effects"][0]["parameters"].erase("harmonic_phases_rad");
  const ReplayResult f = replay(model_file_from_json(j, "m.json"), c, run, ReplayOptions{});
  ASSERT_EQ(w.error, "");
  ASSERT_EQ(f.error, "");
  EXPECT_LT(w.same_processing_pct.force, 0.5);
  EXPECT_GT(f.same_processing_pct.force, 5.0 * std::max(w.same_processing_pct.force, 0.2));
  bool harmonics_said = false, fundamental_said = false;
  for (const std::string& n : w.notes) harmonics_said = harmonics_said || n.find("with its harmonics") != std::string::npos;
  for (const std::string& n : f.notes) fundamental_said = fundamental_said || n.find("fundamental only") != std::string::npos;
  EXPECT_TRUE(harmonics_said);
  EXPECT_TRUE(fundamental_said);
}

// GIVEN a model file with two ripples, the first with a second harmonic
// WHEN replayed on a run whose plant has the second ripple alone
// THEN the plant's one ripple is the later one, harmonics and all: the
// earlier one's harmonic is not left in the extra force, and the replay
// says the earlier one was replaced
TEST(Replay, ALaterRippleReplacesAnEarlierOneWithItsHarmonics) {
  const LoggedRun run = rippled_run(10.0, 0.05, 0.3);
  const Controller c = controller_from_json(minimal_controller(), "c");
  const DriveParams d = true_drive();
  const json earlier = {{"amplitude_N", 4.0}, {"period_m", 0.02}, {"phase_rad", 0.0}, {"harmonics", 2},
                        {"harmonic_amplitudes_N", {4.0, 6.0}}, {"harmonic_phases_rad", {0.0, 1.0}}};
  const json later = {{"amplitude_N", 10.0}, {"period_m", 0.05}, {"phase_rad", 0.3}};
  json j = model_json(d, json::array({{{"kind", "position_ripple"}, {"parameters", earlier}},
                                      {{"kind", "position_ripple"}, {"parameters", later}}}));
  const ReplayResult both = replay(model_file_from_json(j, "m.json"), c, run, ReplayOptions{});
  j["effects"].erase(0);
  const ReplayResult alone = replay(model_file_from_json(j, "m.json"), c, run, ReplayOptions{});
  ASSERT_EQ(both.error, "");
  ASSERT_EQ(alone.error, "");
  EXPECT_LT(alone.same_processing_pct.force, 0.5);
  EXPECT_EQ(both.same_processing_pct.force, alone.same_processing_pct.force);
  // Its steps too: the earlier ripple's harmonic set no time scale.
  EXPECT_EQ(both.substeps, alone.substeps);
  EXPECT_EQ(both.shortest_time_scale_s, alone.shortest_time_scale_s);
  bool replaced_said = false;
  for (const std::string& n : both.notes) replaced_said = replaced_said || n.find("replaced by a later position_ripple") != std::string::npos;
  EXPECT_TRUE(replaced_said);
}

// A hand-written presliding element without "resets" is the plant's own
// kind (reset at reversals), and it is replayed: a review found it left
// out while the docs said it enters. Several elements are still not.
TEST(Replay, AHandWrittenPreslidingElementIsSimulated) {
  const json one = json::array({{{"kind", "presliding_hysteresis"}, {"parameters", {{"distance_m", 1e-4}, {"force_N", 5.0}}}}});
  const PlantEffects pe = plant_effects(one, 20.0);
  ASSERT_EQ(pe.error, "");
  ASSERT_EQ(pe.list.size(), 1u);
  EXPECT_TRUE(pe.list[0].simulated) << pe.list[0].note;
  EXPECT_DOUBLE_EQ(pe.effects.presliding_force_N, 5.0);
  const json ladder = json::array({{{"kind", "presliding_hysteresis"},
                                    {"parameters", {{"distance_m", 1e-4}, {"force_N", 5.0}, {"elements", json::array()}}}}});
  EXPECT_FALSE(plant_effects(ladder, 20.0).list.at(0).simulated);
}

// GIVEN model files whose effects or mass the plant cannot take, THEN the
// replay refuses each, naming the file, the effect and the key: no crash,
// no exception, no NaN or infinite figure with status ok.
TEST(Replay, AnEffectThePlantCannotTakeIsRefusedByName) {
  const LoggedRun run = simulated_run(true_drive(), 2.0);
  const Controller c = controller_from_json(minimal_controller(), "c");
  const DriveParams d = true_drive();
  const json base = {{"m", d.mass_kg}, {"pos", {{"sigma", d.pos.viscous_Ns_m}, {"fc", d.pos.coulomb_N}}},
                     {"neg", {{"sigma", d.neg.viscous_Ns_m}, {"fc", d.neg.coulomb_N}}}};
  const std::vector<std::pair<json, std::string>> bad = {
      {{{"kind", "position_friction"},
        {"parameters", {{"shape", "spline"}, {"level_N", {{"positive", 1.0}, {"negative", 1.0}}},
                        {"profile", {{"x_m", json::array()}, {"positive_N", json::array()}, {"negative_N", json::array()}}}}}},
       "'profile' needs"},
      {{{"kind", "position_friction"},
        {"parameters", {{"shape", "spline"}, {"level_N", {{"positive", 1.0}, {"negative", 1.0}}},
                        {"profile", {{"x_m", {0.1, 0.0}}, {"positive_N", {1.0, 2.0}}, {"negative_N", {1.0, 2.0}}}}}}},
       "'profile.x_m' must increase"},
      {{{"kind", "thermal_drift"}, {"parameters", json::object()}}, "'time_constant_s' is missing"},
      {{{"kind", "thermal_drift"}, {"parameters", {{"time_constant_s", 0.0}, {"coulomb_change_N", 1.0}}}},
       "'time_constant_s' must be > 0"},
      // An effect without its size was replayed as nil, its note saying it was simulated.
      {{{"kind", "thermal_drift"}, {"parameters", {{"time_constant_s", 10.0}}}},
       "'viscous_change_Ns_m' and 'coulomb_change_N' are missing"},
      {{{"kind", "offset"}}, "'force_N' is missing"},
      {{{"kind", "quadratic_viscous"}, {"parameters", json::object()}}, "'c2' is missing"},
      {{{"kind", "position_ripple"}, {"parameters", json::object()}}, "'amplitude_N' is missing"},
      {{{"kind", "position_ripple"}, {"parameters", {{"amplitude_N", 5.0}, {"period_m", 0.01}}}}, "'phase_rad' is missing"},
      {{{"kind", "position_friction"}, {"parameters", json::object()}}, "'delta_N' is missing"},
      {{{"kind", "presliding_hysteresis"}, {"parameters", {{"resets", "at reversals"}}}}, "'force_N' is missing"},
      {{{"kind", "compliance"}, {"parameters", {{"frequency_hz", 30.0}}}}, "'load_mass_kg' is missing"},
      {{{"kind", "position_friction"}, {"parameters", {{"delta_N", 5.0}, {"x_min_m", 0.03}, {"x_max_m", 0.01}}}},
       "'x_max_m' must be above 'x_min_m'"},
      {{{"kind", "quadratic_viscous"}, {"parameters", {{"c2", "x"}}}}, "'c2' must be a finite number"},
      {{{"kind", "position_ripple"}, {"parameters", {{"amplitude_N", 5.0}, {"period_m", 0.0}, {"phase_rad", 0.0}}}}, "'period_m' must be > 0"},
      {{{"kind", "position_ripple"},
        {"parameters", {{"amplitude_N", 5.0}, {"period_m", 0.01}, {"phase_rad", 0.0}, {"harmonics", 2}, {"harmonic_amplitudes_N", {5.0, 1.0}},
                        {"harmonic_phases_rad", {0.0}}}}},
       "'harmonic_amplitudes_N' and 'harmonic_phases_rad' must be lists of one length"},
      {{{"kind", "position_ripple"},
        {"parameters", {{"amplitude_N", 5.0}, {"period_m", 0.01}, {"phase_rad", 0.0}, {"harmonics", 3}, {"harmonic_amplitudes_N", {5.0, 1.0}},
                        {"harmonic_phases_rad", {0.0, 0.5}}}}},
       "'harmonics' is 3 but the lists give 2"},
      {{{"kind", "position_ripple"}, {"parameters", {{"amplitude_N", 5.0}, {"period_m", 0.01}, {"phase_rad", 0.0}, {"harmonics", 1.5}}}},
       "'harmonics' must be a whole number from 1 to 64"},
      {{{"kind", "position_ripple"}, {"parameters", {{"amplitude_N", 5.0}, {"period_m", 0.01}, {"phase_rad", 0.0}, {"harmonics", 1e20}}}},
       "'harmonics' must be a whole number from 1 to 64"},
      {{{"kind", "position_ripple"},
        {"parameters", {{"amplitude_N", 5.0}, {"period_m", 0.01}, {"phase_rad", 0.0}, {"harmonic_amplitudes_N", {5.0, 1.0, 0.5}},
                        {"harmonic_phases_rad", {0.0, 0.5, 1.0}}}}},
       "'harmonics' is 1 but the lists give 3"},
      {{{"kind", "presliding_hysteresis"}, {"parameters", {{"force_N", 5.0}, {"distance_m", 0.0}, {"resets", "at reversals"}}}},
       "'distance_m' must be > 0"},
  };
  for (const auto& [effect, says] : bad) {
    json j = base;
    j["effects"] = json::array({effect});
    const ModelFile m = model_file_from_json(j, "m.json");
    ASSERT_EQ(m.error, "") << effect.dump();
    const std::string why = replay(m, c, run, ReplayOptions{}).error;
    EXPECT_NE(why.find("m.json: effect \"" + effect["kind"].get<std::string>() + "\": " + says), std::string::npos)
        << effect.dump() << "\n" << why;
  }
  json tiny = base;
  tiny["m"] = 1e-300;
  EXPECT_NE(replay(model_file_from_json(tiny, "m.json"), c, run, ReplayOptions{}).error.find("far off"), std::string::npos);
}

/// The largest relative change of a figure (published comparison and both
/// sides processed alike) when opt's plant steps are doubled.
double halving_change(const ModelFile& model, const Controller& c, const LoggedRun& run, const ReplayOptions& opt) {
  const ReplayResult a = replay(model, c, run, opt);
  ReplayOptions fine = opt;
  fine.substeps = 2 * a.substeps;
  const ReplayResult b = replay(model, c, run, fine);
  EXPECT_EQ(a.error, "");
  EXPECT_EQ(b.error, "");
  double worst = 0.0;
  for (const auto& [fa, fb] : {std::pair{a.error_pct, b.error_pct}, std::pair{a.same_processing_pct, b.same_processing_pct}})
    for (const auto& [x, y] : {std::pair{fa.position, fb.position}, std::pair{fa.velocity, fb.velocity},
                               std::pair{fa.acceleration, fb.acceleration}, std::pair{fa.force, fb.force}})
      worst = std::max(worst, std::fabs(x - y) / std::fabs(y));
  return worst;
}

TEST(Replay, HalvingTheStepChangesNoFigureByMoreThanOnePercent) {
  const LoggedRun run = simulated_run(true_drive(), 7.0);
  const Controller c = controller_from_json(minimal_controller(), "c");
  DriveParams model = true_drive();  // a model somewhat off, so every figure is well above round-off
  model.mass_kg = 92.0;
  model.pos.coulomb_N = 17.0;
  EXPECT_LE(halving_change(model_of(model), c, run, ReplayOptions{}), 0.01);
}

/// The halving change with opt's substeps forced to `substeps`.
double halving_change_at(int substeps, const ModelFile& model, const Controller& c, const LoggedRun& run, ReplayOptions opt) {
  opt.substeps = substeps;
  return halving_change(model, c, run, opt);
}

/// A light axis (1 kg) in cogging wells: a slow run logged at 100 Hz whose
/// plant has a 3 N ripple of 1 mm, a spring of 2 pi A / P = 19 kN/m that
/// rings at 22 Hz, faster than the top speed crosses the period.
struct LightSlowAxis {
  DriveParams d;
  Effects ripple;
  LoggedRun run;
  Controller c;
  LightSlowAxis() {
    d.mass_kg = 1.0;
    d.pos = {2.0, 0.2, 0.06, 2e-3};
    d.neg = {2.3, 0.22, 0.05, 2e-3};
    ripple.ripple_amplitude_N = 3.0;
    ripple.ripple_period_m = 1e-3;
    SimConfig cfg;
    cfg.drive = d;
    cfg.effects = ripple;
    cfg.controller.servo_rate_hz = 100.0;
    cfg.controller.velocity_integral_hz = 0.0;
    cfg.controller.velocity_bandwidth_hz = 8.0;
    cfg.controller.position_gain_1_s = 12.0;
    cfg.controller.acceleration_feedforward = false;
    cfg.sensors.encoder_resolution_m = 0.0;
    cfg.plant_substeps = 200;
    ServoAxis axis(cfg);
    run.source = "light axis";
    for (int k = 0; k * 1e-2 <= 4.0; ++k) {
      const double t = k * 1e-2, pulse = std::fmod(t, 1.0) > 0.5 && std::fmod(t, 1.0) < 0.55 ? 0.5 : 0.0;
      const TraceSample s =
          axis.step(t, PathPoint{0.05 * reference_at(t), 0.0, 0.0}, PathPoint{0.05 * reference_at(t + 1e-2), 0.0, 0.0}, pulse);
      run.t.push_back(t);
      run.x.push_back(s.x_m);
      run.u.push_back(s.u_N);
      run.reference.push_back(0.05 * reference_at(t));
      run.extra.push_back(pulse);
    }
    json j = minimal_controller();
    j["kp"] = 12.0;
    j["kv"] = 2.0 * kPi * 8.0 * d.mass_kg;
    c = controller_from_json(j, "c");
  }
};

// GIVEN plants whose effects are faster than the rigid body, each in the
// run's plant and the model's, the model somewhat off: a resonance near
// the sampling rate, a narrow Stribeck dip, a ripple's own stiffness on a
// light slow axis, each of which one step per sample integrates too
// coarsely (halved, a figure moves by more than 1 %)
// THEN the automatic plant steps halved move no figure by more than 1 %;
// AND so on a position-friction range, whose step in x no step size
// resolves (its edges are located), and on effects one step already
// resolves (a bristle, a damped resonance, a drift in the plant and one
// per direction as the plant's extra force), which keep the rule too.
TEST(Replay, AutomaticStepsMeetTheHalvingRuleOnFastEffects) {
  const Controller c = controller_from_json(minimal_controller(), "c");
  DriveParams model = true_drive();
  model.mass_kg = 92.0;
  Effects resonance;
  resonance.compliance_frequency_hz = 150.0;
  resonance.compliance_damping_ratio = 0.03;
  ReplayOptions resonant;
  resonant.effects = resonance;
  const LoggedRun ringing = simulated_run(true_drive(), 4.0, 0.0, resonance);
  EXPECT_GT(halving_change_at(1, model_of(model), c, ringing, resonant), 0.01);
  EXPECT_LE(halving_change(model_of(model), c, ringing, resonant), 0.01);

  DriveParams narrow = true_drive();
  narrow.pos = {200.0, 20.0, 40.0, 1e-4};
  narrow.neg = {230.0, 22.0, 40.0, 1e-4};
  const LoggedRun dipping = simulated_run(narrow, 4.0);
  narrow.mass_kg = 92.0;
  EXPECT_GT(halving_change_at(1, model_of(narrow), c, dipping, {}), 0.01);
  EXPECT_LE(halving_change(model_of(narrow), c, dipping, {}), 0.01);

  const LightSlowAxis light;
  DriveParams light_model = light.d;
  light_model.mass_kg = 0.92;
  ReplayOptions rippled;
  rippled.effects = light.ripple;
  EXPECT_GT(halving_change_at(2, model_of(light_model), light.c, light.run, rippled), 0.01);
  EXPECT_LE(halving_change(model_of(light_model), light.c, light.run, rippled), 0.01);
  // The same ripple as a model file's second harmonic (of a 2 mm period):
  // the extra force's own stiffness sets the steps as the plant's ripple's does.
  ModelFile harmonic = model_of(light_model);
  harmonic.effects = json::array(
      {{{"kind", "position_ripple"},
        {"parameters", {{"amplitude_N", 0.0}, {"period_m", 2e-3}, {"phase_rad", 0.0}, {"harmonics", 2},
                        {"harmonic_amplitudes_N", {0.0, 3.0}}, {"harmonic_phases_rad", {0.0, 0.0}}}}}});
  EXPECT_GT(halving_change_at(2, harmonic, light.c, light.run, {}), 0.01);
  EXPECT_LE(halving_change(harmonic, light.c, light.run, {}), 0.01);

  std::vector<std::pair<std::string, Effects>> plants(5);
  plants[0].first = "position friction 150 N on [10, 30] mm";
  plants[0].second.position_friction_N = 150.0;
  plants[0].second.position_friction_x_min_m = 0.01;
  plants[0].second.position_friction_x_max_m = 0.03;
  plants[1].first = "compliance 40 Hz, damped";
  plants[1].second.compliance_frequency_hz = 40.0;
  plants[1].second.compliance_damping_ratio = 0.7;
  plants[2].first = "presliding";
  plants[2].second.presliding_force_N = 15.0;
  plants[2].second.presliding_distance_m = 3e-7;
  plants[3].first = "ripple of 2 mm";
  plants[3].second.ripple_amplitude_N = 20.0;
  plants[3].second.ripple_period_m = 2e-3;
  plants[4].first = "drift";
  plants[4].second.drift_fraction = 0.5;
  plants[4].second.drift_time_constant_s = 1.0;
  for (const auto& [name, fx] : plants) {
    const LoggedRun run = simulated_run(true_drive(), 4.0, 0.0, fx);
    ReplayOptions opt;
    opt.effects = fx;
    EXPECT_LE(halving_change(model_of(model), c, run, opt), 0.01) << name;
  }
  ModelFile drifting = model_of(model);
  drifting.effects = json::array({{{"kind", "thermal_drift"},
                                   {"parameters", {{"time_constant_s", 0.5}, {"viscous_change_Ns_m", 400.0}, {"coulomb_change_N", 10.0}}}}});
  EXPECT_LE(halving_change(drifting, c, dipping, {}), 0.01) << "drift per direction";

  // The time scales the steps resolve: the Stribeck dip's (m vs / Fs, below
  // m / sigma), a resonance's 1 / (2 pi f), and 5 steps within it.
  EXPECT_NEAR(replay(model_of(model), c, ringing, ReplayOptions{}).shortest_time_scale_s, 92.0 * 2e-3 / 6.0, 1e-12);
  const ReplayResult r = replay(model_of(model), c, ringing, resonant);
  EXPECT_NEAR(r.shortest_time_scale_s, 1.0 / (2.0 * kPi * 150.0), 1e-15);
  EXPECT_EQ(r.substeps, static_cast<int>(std::ceil(5.0 * 1e-3 * 2.0 * kPi * 150.0)));
}

/// A logged run 2 s long at 1 kHz in which the axis rests at 0 while the
/// loop (kp 60 1/s, kv 25 000 N s/m, no delay) pushes `push_N`: its
/// reference is push / (kp kv) ahead.
struct PushFromRest {
  LoggedRun run;
  Controller c;
  explicit PushFromRest(double push_N) {
    run.source = "pushed from rest";
    for (int k = 0; k < 2000; ++k) {
      run.t.push_back(k * 1e-3);
      run.x.push_back(0.0);
      run.u.push_back(push_N);
      run.reference.push_back(push_N / (60.0 * 25000.0));
    }
    json j = minimal_controller();
    j["kp"] = 60.0;
    j["kv"] = 25000.0;
    j.erase("extra_command");
    c = controller_from_json(j, "c");
  }
};

// GIVEN a model whose friction drifts per direction (the plant's extra
// force: 0 at rest, +10 N of Coulomb force the moment it slides) and a
// loop pushing 28 N against its 26 N of static friction plus that 10 N
// THEN the axis holds, as it does when the same 10 N is in the model's
// own Coulomb force (it crept before the drift's step entered the band)
TEST(Replay, FrictionInTheExtraForceHoldsTheAxisAtRest) {
  const PushFromRest loop(28.0);
  const LoggedRun& run = loop.run;
  const Controller& c = loop.c;
  ModelFile m = model_of(true_drive());
  m.effects = json::array({{{"kind", "thermal_drift"}, {"parameters", {{"time_constant_s", 100.0}, {"coulomb_change_N", 10.0}}}}});
  const ReplayResult r = replay(m, c, run, ReplayOptions{});
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(r.stuck_samples, r.samples);
  for (std::size_t k = 0; k < r.v_sim.size(); ++k) ASSERT_EQ(r.v_sim[k], 0.0) << k;
}

// GIVEN a run with one bad position sample (1 mm off for one row) and a
// ripple, whose time scale follows the run's top speed
// THEN the automatic steps are those of the run without it
TEST(Replay, OneBadSampleDoesNotSetTheTopSpeed) {
  Effects ripple;
  ripple.ripple_amplitude_N = 20.0;
  ripple.ripple_period_m = 2e-3;
  const LoggedRun clean = simulated_run(true_drive(), 2.0, 0.0, ripple);
  LoggedRun glitch = clean;
  glitch.x[1000] += 1e-3;
  const Controller c = controller_from_json(minimal_controller(), "c");
  ReplayOptions opt;
  opt.effects = ripple;
  const ReplayResult a = replay(model_of(true_drive()), c, clean, opt), b = replay(model_of(true_drive()), c, glitch, opt);
  ASSERT_EQ(a.error, "");
  ASSERT_EQ(b.error, "");
  EXPECT_EQ(b.shortest_time_scale_s, a.shortest_time_scale_s);
  EXPECT_EQ(b.substeps, a.substeps);
}

// GIVEN a model whose drift lowers its Coulomb force by 10 N (the plant's
// extra force), so that it slides at 16 N instead of 26, and a loop
// pushing 20 N from rest
// THEN the axis breaks away and moves toward the reference (a break-away
// the band allowed used to turn straight back: the drift read at v = 0
// was none, and the axis stayed put while its sampled acceleration said it
// moved)
TEST(Replay, FrictionTheExtraForceLowersLetsTheAxisBreakAway) {
  const PushFromRest loop(20.0);
  const LoggedRun& run = loop.run;
  const Controller& c = loop.c;
  ModelFile m = model_of(true_drive());
  m.effects = json::array({{{"kind", "thermal_drift"}, {"parameters", {{"time_constant_s", 100.0}, {"coulomb_change_N", -10.0}}}}});
  const ReplayResult r = replay(m, c, run, ReplayOptions{});
  ASSERT_EQ(r.error, "");
  EXPECT_GT(r.x_sim.back(), 1e-7);
  for (std::size_t k = 0; k + 1 < r.v_sim.size(); ++k)
    if (r.v_sim[k] == 0.0 && r.a_sim[k] != 0.0) ASSERT_NE(r.v_sim[k + 1], 0.0) << k;
}

TEST(Replay, StandingAxisDoesNotChatter) {
  // GIVEN a reference held 10 um from where the axis rests and a model
  // whose friction holds against the loop's push (kv kp 10 um = 15 N < 20 N)
  const PushFromRest loop(15.0);
  const LoggedRun& run = loop.run;
  const Controller& c = loop.c;
  const ReplayResult r = replay(model_of(true_drive()), c, run, ReplayOptions{});
  ASSERT_EQ(r.error, "");
  // THEN the simulated axis never moves and its force is the steady push
  for (std::size_t k = 0; k < r.v_sim.size(); ++k) {
    ASSERT_EQ(r.v_sim[k], 0.0) << k;
    ASSERT_EQ(r.a_sim[k], 0.0) << k;
  }
  EXPECT_EQ(r.stuck_samples, r.samples);
  EXPECT_NEAR(r.u_sim.back(), 15.0, 1e-9);
}

// GIVEN a p_pi law whose ki is left to the fit, THEN a fitted ki below 0
// within two standard errors (a loop without one) is replayed as 0, said
// in a note, while one far below 0 is still refused.
TEST(ReplayController, AFittedIntegralGainThatIsZeroWithinItsErrorIsZero) {
  json j = minimal_controller();
  j["law"] = "p_pi";
  const Controller c = controller_from_json(j, "c.json");
  ASSERT_EQ(c.error, "");
  GainFit fit;
  fit.done = true;
  fit.value = {60.0, 25000.0, -0.0011};
  fit.se = {0.01, 1.0, 0.0009};
  std::vector<std::string> notes;
  const Outcome<Gains> g = resolve_gains(c, fit, notes);
  ASSERT_TRUE(g.ok()) << g.error;
  EXPECT_EQ(g.value.ki, 0.0);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("0 within two standard errors"), std::string::npos) << notes[0];
  fit.value.ki = -0.01;
  EXPECT_FALSE(resolve_gains(c, fit, notes).ok());
}

TEST(Replay, MissingGainsAreIdentifiedFromTheLoggedCommand) {
  // GIVEN the simulated run and a controller file without kp and kv
  const LoggedRun run = simulated_run(true_drive(), 7.0);
  json j = minimal_controller();
  j.erase("kp");
  j.erase("kv");
  const Controller c = controller_from_json(j, "c");
  const ReplayResult r = replay(model_of(true_drive()), c, run, ReplayOptions{});
  ASSERT_EQ(r.error, "");
  // THEN the regression finds the loop's gains, with standard errors that cover them
  ASSERT_TRUE(r.gain_fit.done);
  const double kv = 2.0 * kPi * 40.0 * 100.0;
  EXPECT_NEAR(r.gain_fit.value.kp, 60.0, 0.005 * 60.0);
  EXPECT_NEAR(r.gain_fit.value.kv, kv, 0.005 * kv);
  EXPECT_GT(r.gain_fit.se.kp, 0.0);
  EXPECT_LT(r.gain_fit.se.kp, 0.01 * 60.0);
  EXPECT_EQ(r.gain_fit.lag_samples, 0);
  // AND the pulses are found to enter the command as logged (gain 1)
  EXPECT_NEAR(r.gain_fit.extra_gain, 1.0, 0.01);
  // AND the replay with them is as close as with the given gains
  EXPECT_LT(r.same_processing_pct.force, 0.5);
}

TEST(Replay, ProportionalIntegralLoopIsReplayedAndItsGainsFound) {
  // GIVEN a run of the simulator's PI velocity loop (zero at 8 Hz)
  const double kv = 2.0 * kPi * 40.0 * 100.0, ki = kv * 2.0 * kPi * 8.0;
  const LoggedRun run = simulated_run(true_drive(), 7.0, 8.0);
  json j = minimal_controller();
  j["law"] = "p_pi";
  j["ki"] = ki;
  // WHEN the true model is replayed in the p_pi law with the loop's gains
  const ReplayResult r = replay(model_of(true_drive()), controller_from_json(j, "c"), run, ReplayOptions{});
  ASSERT_EQ(r.error, "");
  // THEN it reproduces the run
  EXPECT_LT(r.same_processing_pct.velocity, 0.5);
  EXPECT_LT(r.same_processing_pct.force, 0.5);
  // WHEN the file gives no gains
  j.erase("kp");
  j.erase("kv");
  j.erase("ki");
  const ReplayResult f = replay(model_of(true_drive()), controller_from_json(j, "c"), run, ReplayOptions{});
  ASSERT_EQ(f.error, "");
  // THEN the regression finds all three
  EXPECT_NEAR(f.gain_fit.value.kp, 60.0, 0.005 * 60.0);
  EXPECT_NEAR(f.gain_fit.value.kv, kv, 0.005 * kv);
  EXPECT_NEAR(f.gain_fit.value.ki, ki, 0.01 * ki);
  EXPECT_LT(f.same_processing_pct.force, 0.5);
}

TEST(Replay, GainsFromAForceOfTheOtherSignAreRefused) {
  // GIVEN a log whose force has the other sign than the command, and no gains in the file
  LoggedRun run = simulated_run(true_drive(), 3.0);
  for (double& u : run.u) u = -u;
  json j = minimal_controller();
  j.erase("kp");
  j.erase("kv");
  const Controller c = controller_from_json(j, "c.json");
  // THEN the fit's negative gains are an error that says why, not a replay
  const std::string e = replay(model_of(true_drive()), c, run, ReplayOptions{}).error;
  EXPECT_NE(e.find("not those of a position loop"), std::string::npos) << e;
}

TEST(Replay, ReportPageShowsEverySignal) {
  const LoggedRun run = simulated_run(true_drive(), 2.0);
  ReplayOptions opt;
  opt.units = units_for(Axis::linear);
  const ReplayResult r = replay(model_of(true_drive()), controller_from_json(minimal_controller(), "c"), run, opt);
  ASSERT_EQ(r.error, "");
  const std::string dir = ::testing::TempDir() + "replay_report_test";
  std::string err;
  ASSERT_TRUE(write_replay_report(r, dir, "simulated", "feedid replay ...", err)) << err;
  std::ifstream f(dir + "/report.html");
  const std::string page((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  for (const char* signal : {"position", "velocity", "acceleration", "force"})
    EXPECT_NE(page.find(std::string("<h2>") + signal + "</h2>"), std::string::npos) << signal;
  EXPECT_NE(page.find("acceleration (m/s^2)"), std::string::npos);
  EXPECT_NE(page.find("the processing alone"), std::string::npos);
}

TEST(Replay, GapAndShortRunAreErrors) {
  LoggedRun run = simulated_run(true_drive(), 1.0);
  const Controller c = controller_from_json(minimal_controller(), "c");
  for (double& t : run.t)
    if (t > 0.5) t += 1.0;
  EXPECT_NE(replay(model_of(true_drive()), c, run, ReplayOptions{}).error.find("gap"), std::string::npos);
  // A lost row (a bad row the reader skipped) would put every later sample a period off.
  LoggedRun lost = simulated_run(true_drive(), 1.0);
  for (std::vector<double>* col : {&lost.t, &lost.x, &lost.u, &lost.reference, &lost.extra}) col->erase(col->begin() + 500);
  const std::string why = replay(model_of(true_drive()), c, lost, ReplayOptions{}).error;
  EXPECT_NE(why.find("rows missing after t = 0.499"), std::string::npos) << why;
  EXPECT_NE(why.find("a step of 2 periods"), std::string::npos) << why;
  LoggedRun shortrun = simulated_run(true_drive(), 0.05);
  EXPECT_NE(replay(model_of(true_drive()), c, shortrun, ReplayOptions{}).error.find("too short"),
            std::string::npos);
}

}  // namespace
