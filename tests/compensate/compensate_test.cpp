// Friction compensation: the table a drive loads (host_sim/compensate/compensate.cpp)
// and the core's feed-forward (core/feedid/feedforward.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <utility>
#include <vector>

#include "compensate/circle.hpp"
#include "compensate/compensate.hpp"
#include "feedid/feedid.hpp"
#include "identify/identify.hpp"
#include "test_support.hpp"

namespace feedid::host {
namespace {

TEST(CompensationTable, InterpolatesTheModelWithinItsReportedError) {
  const DriveParams m;  // the simulator's default drive: Stribeck dip of 8 N below about 2 mm/s
  const double top = 0.15;
  const CompensationTable t = make_compensation_table(m, top, 20);
  ASSERT_EQ(t.dir[0].size(), 20u);
  ASSERT_EQ(t.dir[1].size(), 20u);
  for (int d = 0; d < 2; ++d) {
    EXPECT_EQ(t.dir[d].front().speed_m_s, 0.0);
    EXPECT_NEAR(t.dir[d].back().speed_m_s, top, 1e-12);
    for (std::size_t k = 1; k < t.dir[d].size(); ++k) EXPECT_GT(t.dir[d][k].speed_m_s, t.dir[d][k - 1].speed_m_s);
    // An independent, finer check than the one that set the reported error.
    EXPECT_LE(table_error(t, d, 200000), t.max_interpolation_error_N * (1.0 + 1e-6) + 1e-12);
  }
  // Breakpoints go where the curve bends: most of them inside the dip.
  int in_dip = 0;
  for (const auto& p : t.dir[0]) in_dip += p.speed_m_s < 4.0 * m.pos.stribeck_velocity_m_s;
  EXPECT_GE(in_dip, 10);
  // Small against the friction it compensates.
  EXPECT_LT(t.max_interpolation_error_N, 0.002 * m.pos.coulomb_N);
}

TEST(CompensationTable, MorePointsNeverIncreaseTheError) {
  const DriveParams m;
  double prev = 1e300;
  for (int n : {3, 5, 10, 20, 40}) {
    const double e = make_compensation_table(m, 0.15, n).max_interpolation_error_N;
    EXPECT_LE(e, prev * (1.0 + 1e-9)) << n << " points";
    prev = e;
  }
  // Placed where the curve bends, 20 points beat 20 evenly spaced ones many times over.
  CompensationTable even = make_compensation_table(m, 0.15, 20);
  for (int k = 0; k < 20; ++k) {
    const double s = 0.15 * k / 19.0;
    even.dir[0][static_cast<std::size_t>(k)] = {s, model_friction(m, 0, s)};
  }
  EXPECT_LT(make_compensation_table(m, 0.15, 20).max_interpolation_error_N, 0.2 * table_error(even, 0));
}

TEST(CompensationTable, CoulombViscousModelIsExactWithTwoPoints) {
  DriveParams m;
  m.pos.breakaway_N = m.neg.breakaway_N = 0.0;
  m.pos.stribeck_velocity_m_s = m.neg.stribeck_velocity_m_s = 0.0;
  const CompensationTable t = make_compensation_table(m, 0.2, 2);
  EXPECT_LT(t.max_interpolation_error_N, 1e-9);
  const nlohmann::json j = to_json(t, CompensateOptions{});
  EXPECT_DOUBLE_EQ(j["parameter_form"]["offset_pos_N"].get<double>(), m.pos.coulomb_N);
  EXPECT_DOUBLE_EQ(j["parameter_form"]["offset_neg_N"].get<double>(), -m.neg.coulomb_N);
  EXPECT_GT(j["neg"][0]["force_N"].get<double>(), 0.0);  // magnitudes are positive
  EXPECT_NE(make_compensation_table(m, 0.2, 1).error.find("--points 1"), std::string::npos);
  EXPECT_NE(make_compensation_table(m, 0.0, 20).error.find("--max-speed"), std::string::npos);
  EXPECT_EQ(make_compensation_table(m, 0.2, 2).error, "");
}

TEST(CompensationTable, AStraightLineStillGetsTheCountAsked) {
  // GIVEN a Coulomb + viscous model, which two points represent exactly
  DriveParams m;
  m.pos.breakaway_N = m.neg.breakaway_N = 0.0;
  m.pos.stribeck_velocity_m_s = m.neg.stribeck_velocity_m_s = 0.0;
  // WHEN 20 points are asked  THEN each direction has 20 distinct, rising speeds, still exact
  const CompensationTable t = make_compensation_table(m, 0.2, 20);
  for (int d = 0; d < 2; ++d) {
    ASSERT_EQ(t.dir[d].size(), 20u);
    for (std::size_t k = 1; k < t.dir[d].size(); ++k) EXPECT_GT(t.dir[d][k].speed_m_s, t.dir[d][k - 1].speed_m_s);
  }
  EXPECT_LT(t.max_interpolation_error_N, 1e-9);
}

TEST(CompensationTable, DriveUnitsDivideByTheForceScale) {
  const DriveParams m;
  CompensateOptions o;
  o.force_scale = 12.5;  // N per A
  o.force_unit = "A";
  const nlohmann::json j = to_json(make_compensation_table(m, 0.15, 5), o);
  EXPECT_DOUBLE_EQ(j["pos"][0]["force"].get<double>(), j["pos"][0]["force_N"].get<double>() / 12.5);
  EXPECT_EQ(j["force_unit"], "A");
}

// GIVEN a model file and a negative or zero --force-scale (a review loaded
// -2 and got negative magnitudes, exit 0: friction doubled, not cancelled),
// or a diagnose --model-out file without --max-speed, or one with effects
// THEN the scale is refused naming the rule, the missing top speed is named
// without calling the file a truth file, and the effects left out are said
TEST(CompensationTable, ANonPositiveScaleIsRefusedAndWhatIsLeftOutIsSaid) {
  const nlohmann::json model = {{"m", 95.0}, {"pos", {{"sigma", 200.0}, {"fc", 20.0}}},
                                {"neg", {{"sigma", 210.0}, {"fc", 21.0}}},
                                {"effects", nlohmann::json::array({{{"kind", "offset"}, {"parameters", {{"force_N", 1.0}}}}})}};
  CompensateOptions o;
  o.max_speed_m_s = 0.2;
  for (const double scale : {-2.0, 0.0}) {
    o.force_scale = scale;
    EXPECT_NE(compensate_model(model, o, "m.json").error.find("must be finite and > 0"), std::string::npos) << scale;
  }
  o.force_scale = 2.0;
  const ModelCompensation c = compensate_model(model, o, "m.json");
  ASSERT_EQ(c.error, "");
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("effect(s)"), std::string::npos) << c.warnings[0];
  EXPECT_GT(c.json["pos"][1]["force"].get<double>(), 0.0);
  o.max_speed_m_s = 0.0;
  const std::string e = compensate_model(model, o, "m.json").error;
  EXPECT_NE(e.find("give --max-speed"), std::string::npos) << e;
  EXPECT_EQ(e.find("truth file"), std::string::npos) << e;
}

// GIVEN a model identified with its force in A (identify --force-unit A)
// WHEN a table is asked with --force-scale (meant for a model in N)
// THEN it is refused: the scale divided the amperes again, 12.5 times too
// small beside a force_A key holding the right values. Its CSV's header
// names A, as the JSON's keys do, not force_N.
TEST(CompensationTable, AModelInADriveUnitIsNotScaledAgainAndItsCsvSaysItsUnit) {
  const nlohmann::json model = {{"m", 8.0}, {"pos", {{"sigma", 56.0}, {"fc", 2.0}}}, {"neg", {{"sigma", 57.0}, {"fc", 2.1}}},
                                {"units", {{"position", "m"}, {"force", "A"}}}};
  CompensateOptions o;
  o.max_speed_m_s = 0.2;
  o.force_scale = 12.5;
  o.force_unit = "A";
  const std::string e = compensate_model(model, o, "idA.json").error;
  EXPECT_NE(e.find("is in A already"), std::string::npos) << e;
  o.force_scale = 1.0;
  o.force_unit = "";
  const ModelCompensation c = compensate_model(model, o, "idA.json");
  ASSERT_EQ(c.error, "");
  const std::string csv = to_csv(c.table, o, c.units);
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "direction,speed_m_s,force_A") << csv;
  EXPECT_EQ(to_csv(c.table, o).substr(0, 31), "direction,speed_m_s,force_N\npos") << "a model in N keeps N";
  // A rotary model in N m is in SI: N m per A converts it
  nlohmann::json rotary = model;
  rotary["units"] = {{"position", "rad"}, {"force", "N m"}};
  o.force_scale = 0.5;
  o.force_unit = "A";
  const ModelCompensation r = compensate_model(rotary, o, "spindle.json");
  EXPECT_EQ(r.error, "");
  EXPECT_EQ(to_csv(r.table, o, r.units).substr(0, 40), "direction,speed_rad_s,force_N_m,force_A\n");
}

// GIVEN identify's model of a trace too short to settle the friction
// (sigma and fc flagged not identifiable), or a --max-speed far above the
// speeds it was identified at, THEN the table is written with a warning
// that names the flagged parameters, and the extrapolation: a flat 31 N
// table up to 0.15 m/s, where the friction is 130 N, went out without one.
TEST(CompensationTable, FlaggedParametersAndExtrapolationAreWarnedOf) {
  const nlohmann::json model = {
      {"status", "ok"}, {"standard_errors", nlohmann::json::object()}, {"m", 100.0},
      {"pos", {{"sigma", 0.0}, {"fc", 31.0}, {"fs", 0.0}, {"vs", 1.0},
               {"identifiable", {{"sigma", false}, {"fc", false}, {"fs", false}, {"vs", false}}},
               {"flags", {"friction_still_falling"}}}},
      {"neg", {{"sigma", 700.0}, {"fc", 25.0}, {"fs", 0.0}, {"vs", 1.0},
               {"identifiable", {{"sigma", true}, {"fc", true}, {"fs", false}, {"vs", false}}}, {"flags", nlohmann::json::array()}}},
      {"config", {{"velocity_max_m_s", 0.005}}}};
  CompensateOptions o;
  ModelCompensation c = compensate_model(model, o, "id10.json");
  ASSERT_EQ(c.error, "");
  ASSERT_EQ(c.warnings.size(), 1u) << "fs and vs are not in a model without the dip: not warned of";
  EXPECT_NE(c.warnings[0].find("pos.sigma, pos.fc not identifiable"), std::string::npos) << c.warnings[0];
  o.max_speed_m_s = 0.15;
  c = compensate_model(model, o, "id10.json");
  ASSERT_EQ(c.warnings.size(), 2u);
  EXPECT_NE(c.warnings[1].find("30 times the fastest speed"), std::string::npos) << c.warnings[1];
}

// The issue's bar, on drives the tests simulate: a table from `identify`
// matches the TRUE friction within 3 % or 0.5 N above twice vs, and within
// 10 % in the Stribeck region.
TEST(CompensationTable, TableFromAnIdentifiedTraceMatchesTheTrueFriction) {
  for (const double mass : {20.0, 100.0, 400.0}) {
    test::SimSpec spec;
    spec.mass_kg = mass;
    spec.duration_s = 60.0;
    const host::SimConfig cfg = test::sim_config(spec);
    const IdentifyResult r = identify(host::simulate(cfg), IdentifyOptions{});
    ASSERT_TRUE(r.error.empty()) << r.error;
    const CompensationTable t = make_compensation_table(to_drive_params(r.estimate), r.config.velocity_max_m_s, 20);
    feedid::FrictionTable<double, 20> ft;
    for (int d = 0; d < 2; ++d) {
      ft.count[d] = static_cast<int>(t.dir[d].size());
      for (int k = 0; k < ft.count[d]; ++k) ft.speed_m_s[d][k] = t.dir[d][k].speed_m_s, ft.force_N[d][k] = t.dir[d][k].force_N;
    }
    for (int d = 0; d < 2; ++d) {
      const double vs = (d == 0 ? cfg.drive.pos : cfg.drive.neg).stribeck_velocity_m_s;
      for (int i = 1; i <= 2000; ++i) {
        const double s = t.max_speed_m_s * i / 2000.0;
        const double truth = model_friction(cfg.drive, d, s), got = ft.magnitude(d, s);
        const double tol = s > 2.0 * vs ? std::max(0.03 * truth, 0.5) : 0.10 * truth;
        ASSERT_NEAR(got, truth, tol) << "mass " << mass << " dir " << d << " speed " << s;
      }
    }
  }
}

// The issue's circle bar on the default drives, identified on the spot:
// the largest quadrant glitch at least 80 % lower with the compensation.
TEST(CircleTest, IdentifiedCompensationCutsTheQuadrantGlitches) {
  // (and the four runs report their progress, rising to 1: at 1 MHz they
  // ran minutes without a word)
  std::vector<double> shares;
  CircleOptions with_progress;
  with_progress.progress = [&shares](double f) { shares.push_back(f); };
  const CircleResult r = run_circle(with_progress);
  ASSERT_GE(shares.size(), 5u);
  EXPECT_TRUE(std::is_sorted(shares.begin(), shares.end()));
  EXPECT_EQ(shares.back(), 1.0);
  ASSERT_EQ(r.runs.size(), 4u);
  const auto worst = [](const CircleRun& run) { return *std::max_element(run.glitch_um.begin(), run.glitch_um.end()); };
  EXPECT_GT(worst(r.runs[0]), 5.0) << "no glitch to cut: the test would prove nothing";
  EXPECT_GE(r.glitch_reduction, 0.8) << "none " << worst(r.runs[0]) << " um, identified " << worst(r.runs[1]) << " um";
  // A model 20 % off in either direction does worse than the identified one,
  // and still better than none.
  for (int k : {2, 3}) {
    EXPECT_GT(worst(r.runs[k]), worst(r.runs[1])) << r.runs[k].name;
    EXPECT_LT(worst(r.runs[k]), worst(r.runs[0])) << r.runs[k].name;
  }
  const nlohmann::json j = to_json(r, CircleOptions{});
  EXPECT_EQ(j["runs"]["wrong_minus"]["glitch_um"].size(), 4u);
  EXPECT_TRUE(j["runs"]["identified"]["rms_um"].is_number());
}

// GIVEN options that give no sound circle test, THEN each is refused by name
// before anything runs: a radius in mm (hours of simulation), a sensitivity
// that makes friction negative or swaps its runs, a model of another axis.
TEST(CircleTest, OptionsThatGiveNoSoundTestAreRefused) {
  CircleOptions mm;
  mm.radius_m = 100.0;
  EXPECT_NE(run_circle(mm).error.find("a radius in mm?"), std::string::npos);
  for (double wrong : {1.5, -0.2}) {
    CircleOptions o;
    o.wrong_fraction = wrong;
    EXPECT_NE(run_circle(o).error.find("--wrong"), std::string::npos) << wrong;
  }
  const std::string rotary = ::testing::TempDir() + "feedid_circle_rotary.json";
  std::ofstream(rotary) << R"({"m": 0.01, "pos": {"sigma": 0.2, "fc": 0.1}, "neg": {"sigma": 0.2, "fc": 0.1},
                              "units": {"position": "rad", "force": "V"}})";
  CircleOptions other;
  other.model_paths = {rotary, rotary};
  EXPECT_NE(run_circle(other).error.find("the circle's axes are linear"), std::string::npos) << run_circle(other).error;
}

}  // namespace
}  // namespace feedid::host

namespace feedid {
namespace {

template <typename T> Estimate<T> default_estimate() {
  Estimate<T> e;
  e.mass_kg = T(100);
  e.pos = {T(700), T(25), T(8), T(0.002)};
  e.neg = {T(720), T(26), T(7.5), T(0.0018)};
  return e;
}

template <typename T> void expect_continuous_through_zero() {
  const Estimate<T> e = default_estimate<T>();
  const EstimateFriction<T> model{e};
  FeedforwardConfig<T> c;
  c.zero_band_m_s = T(0.0005);
  ASSERT_EQ(check_feedforward(c), Status::ok);
  // Largest step between neighbouring velocities on a fine grid across the
  // band: bounded by the band's slope times the step, never a jump of 2 Fc.
  const T step = T(1e-6);
  const T slope = (friction_magnitude(e.pos, c.zero_band_m_s) + friction_magnitude(e.neg, c.zero_band_m_s)) /
                  (T(2) * c.zero_band_m_s);
  T prev = feedforward(model, c, T(-0.002), T(0));
  for (T v = T(-0.002) + step; v <= T(0.002); v += step) {
    const T f = feedforward(model, c, v, T(0));
    EXPECT_LE(std::fabs(f - prev), T(1.05) * slope * step + T(2e-3)) << "v = " << v;
    prev = f;
  }
  // Outside the band it is the model, with the sign of the motion.
  EXPECT_NEAR(feedforward(model, c, T(0.01), T(0)), friction_magnitude(e.pos, T(0.01)), T(1e-3));
  EXPECT_NEAR(feedforward(model, c, T(-0.01), T(0)), -friction_magnitude(e.neg, T(0.01)), T(1e-3));
  // m a when asked.
  c.mass_kg = e.mass_kg;
  EXPECT_NEAR(feedforward(model, c, T(0.01), T(2)) - feedforward(model, c, T(0.01), T(0)), T(200), T(1e-3));
}

TEST(Feedforward, ContinuousThroughZeroVelocityInFloatAndDouble) {
  expect_continuous_through_zero<float>();
  expect_continuous_through_zero<double>();
}

TEST(Feedforward, FromATableEqualsTheTable) {
  FrictionTable<float, 4> t;
  for (int d = 0; d < 2; ++d) {
    t.count[d] = 3;
    const float s[3] = {0.0f, 0.002f, 0.1f}, f[3] = {33.0f, 28.0f, 95.0f};
    for (int k = 0; k < 3; ++k) t.speed_m_s[d][k] = s[k], t.force_N[d][k] = f[k];
  }
  ASSERT_EQ(check_table(t), Status::ok);
  FeedforwardConfig<float> c{0.0005f, 0.0f};
  EXPECT_NEAR(feedforward(t, c, 0.051f, 0.0f), 28.0f + 67.0f * 0.049f / 0.098f, 1e-3f);
  EXPECT_NEAR(feedforward(t, c, -0.2f, 0.0f), -(95.0f + 67.0f * 0.1f / 0.098f), 1e-3f);  // last segment continues

  t.speed_m_s[1][2] = 0.001f;  // not increasing
  EXPECT_EQ(check_table(t), Status::invalid_config);
  EXPECT_EQ(check_feedforward(FeedforwardConfig<float>{0.0f, 0.0f}), Status::invalid_config);
  EXPECT_EQ(check_feedforward(FeedforwardConfig<float>{0.001f, -1.0f}), Status::invalid_config);
}

// GIVEN a NaN or infinite reference, a reference so fast the viscous force
// overflows a float, an estimate with a NaN term, and an unchecked NaN band,
// THEN feedforward() gives 0 (no feed-forward), never a NaN or Inf into the
// current loop (it passed them through); a finite input still gives the model.
TEST(Feedforward, ANonFiniteInputGivesZeroNeverNaN) {
  const Estimate<float> e = default_estimate<float>();
  const EstimateFriction<float> model{e};
  const FeedforwardConfig<float> c{0.0005f, 100.0f};
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  for (const auto& [v, a] : {std::pair<float, float>{nan, 0.0f}, {0.01f, nan}, {inf, 0.0f}, {-inf, 0.0f}, {0.01f, inf},
                             {3e36f, 0.0f}})
    EXPECT_EQ(feedforward(model, c, v, a), 0.0f) << v << " " << a;
  Estimate<float> broken = e;
  broken.neg.viscous_Ns_m = nan;
  EXPECT_EQ(feedforward(EstimateFriction<float>{broken}, c, -0.01f, 0.0f), 0.0f);
  EXPECT_EQ(feedforward(model, FeedforwardConfig<float>{nan, 0.0f}, 0.001f, 0.0f), 0.0f);
  EXPECT_NEAR(feedforward(model, c, 0.01f, 0.0f), friction_magnitude(e.pos, 0.01f), 1e-3f);
}

}  // namespace
}  // namespace feedid
