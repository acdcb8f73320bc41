// Effects of other shapes (issue 28, item 3). GIVEN a simulated drive with
// an effect whose shape the catalogue's first form does not draw (a
// compliance damped far less than the fixed 0.05: a bare structure), WHEN diagnose runs on the
// trace alone, THEN the effect's family grows to it (a second damping
// column, chosen by held-out error with a penalty for size), names it, and
// reports the damping it found.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "diagnose/diagnose.hpp"
#include "diagnose/diagnose_catalogue.hpp"
#include "test_support.hpp"

namespace feedid::test {
namespace {

host::SimConfig damped_compliance(double damping_ratio) {
  SimSpec spec;
  spec.encoder_m = 5e-8;
  spec.seed = 9;
  spec.duration_s = 40.0;
  host::SimConfig cfg = logged_config(spec, host::ForceLog::instant, host::VelocityLog::low_pass);
  cfg.effects.compliance_frequency_hz = 30.0;
  cfg.effects.compliance_mass_fraction = 0.3;
  cfg.effects.compliance_damping_ratio = damping_ratio;
  return cfg;
}

TEST(DiagnoseFamilies, LightlyDampedComplianceIsNamedWithItsDamping) {
  const host::SimConfig cfg = damped_compliance(0.015);
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "compliance") << host::summary(r);
  const nlohmann::json& p = r.effect_parameters;
  ASSERT_TRUE(p.contains("damping_ratio")) << "the lightly damped form was kept: " << p.dump();
  EXPECT_LT(p["damping_ratio"].get<double>(), 0.03) << p.dump();  // 0.015 simulated; the fixed form says 0.05
  EXPECT_NEAR(p.value("load_mass_kg", 0.0), 0.3 * cfg.drive.mass_kg, 0.3 * 0.3 * cfg.drive.mass_kg) << p.dump();
  // Searched again at two dampings near the first's best (SearchAgain::near_first).
  EXPECT_NEAR(p.value("frequency_hz", 0.0), 30.0, 0.3) << p.dump();  // 29.95 Hz; a grid cell is 10 %
  EXPECT_FALSE(r.gap_remains) << host::summary(r);
}

// The damper acts between motor and load, so the load's acceleration
// follows the motor's through H(s) = (2 z w s + w^2)/(s^2 + 2 z w s + w^2):
// without the zero (a damper to ground) the fitted compliance closed 87.8 %
// and 88.7 % of the excess at damping 0.05 and 0.08; with it 92.6 % and 91.8 %.
TEST(DiagnoseFamilies, TheDamperBetweenTheMassesIsInTheLoadResponse) {
  for (const double zeta : {0.05, 0.08}) {
    const host::DiagnoseResult r = host::diagnose(host::simulate(damped_compliance(zeta)), host::DiagnoseOptions{});
    ASSERT_TRUE(r.error.empty()) << r.error;
    ASSERT_EQ(r.effect, "compliance") << host::summary(r);
    EXPECT_GT(r.closed_fraction, 0.9) << "damping " << zeta << "\n" << host::summary(r);
  }
}

TEST(DiagnoseFamilies, ComplianceAtTheFixedDampingKeepsIt) {
  const host::SimConfig cfg = damped_compliance(0.05);
  const host::DiagnoseResult r = host::diagnose(host::simulate(cfg), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "compliance") << host::summary(r);
  // Either form is allowed; if the mix is kept it must still say about 0.05.
  EXPECT_GT(r.effect_parameters.value("damping_ratio", 0.05), 0.035) << r.effect_parameters.dump();
}

}  // namespace
}  // namespace feedid::test

namespace feedid::test {
namespace {

// A warm-up that only one direction feels (a seal that drags one way, a
// nut preloaded against one flank): added to an effect-free trace's force
// as friction against positive motion, 6 N decaying over 12 s. The motion
// is the simulated one, as an open-loop plant that follows its reference
// would have it. One change shared by both directions is half the truth in
// each; the per-direction size must be chosen, and name the positive side.
TEST(DiagnoseFamilies, DriftFeltInOneDirectionIsNamedWithItsDirection) {
  SimSpec spec;
  spec.encoder_m = 5e-8;
  spec.seed = 4;
  spec.duration_s = 60.0;
  host::Trace trace = host::simulate(logged_config(spec, host::ForceLog::held, host::VelocityLog::backward_difference));
  for (auto& s : trace.samples)
    if (s.v_m_s > 0) s.u_N += 6.0 * std::exp(-s.t_s / 12.0);
  const host::DiagnoseResult r = host::diagnose(trace, host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "thermal_drift") << host::summary(r);
  const nlohmann::json& p = r.effect_parameters;
  const double pos = p["positive"].value("coulomb_change_N", 0.0), neg = p["negative"].value("coulomb_change_N", 0.0);
  EXPECT_NEAR(pos, 6.0, 1.5) << p.dump();
  EXPECT_LT(std::fabs(neg), 1.5) << p.dump();
  EXPECT_NEAR(p.value("time_constant_s", 0.0), 12.0, 3.0) << p.dump();
}

}  // namespace
}  // namespace feedid::test

namespace feedid::test {
namespace {

/// Positions a trace covers, end to end (m).
double travel_of(const host::Trace& trace) {
  double lo = trace.samples.front().x_m, hi = lo;
  for (const auto& s : trace.samples) lo = std::min(lo, s.x_m), hi = std::max(hi, s.x_m);
  return hi - lo;
}

host::SimConfig ripple_of_period(double period_m) {
  SimSpec spec;
  spec.seed = 5;
  spec.duration_s = 40.0;
  host::SimConfig cfg = logged_config(spec, host::ForceLog::held, host::VelocityLog::backward_difference);
  cfg.effects.ripple_amplitude_N = 4.0;
  cfg.effects.ripple_period_m = period_m;
  return cfg;
}

// A ripple seen over only one or two of its periods (a screw's pitch error
// over a short stroke, a cable's pull): the period is found from the data
// beyond a third of the travel. The grid stopped there; half the travel
// was `unexplained` at 9 times the noise floor, 0.7 of it named as
// compliance and position friction.
TEST(DiagnoseFamilies, RippleOfALongPeriodIsNamedWithItsPeriod) {
  const double travel = travel_of(host::simulate(ripple_of_period(0.005)));
  for (const double share : {0.45, 0.7}) {
    const double period = share * travel;
    const host::DiagnoseResult r = host::diagnose(host::simulate(ripple_of_period(period)), host::DiagnoseOptions{});
    ASSERT_TRUE(r.error.empty()) << r.error;
    ASSERT_EQ(r.effect, "position_ripple") << "period " << share << " of the travel\n" << host::summary(r);
    const nlohmann::json& p = r.effect_parameters;
    EXPECT_NEAR(p.value("period_m", 0.0) / period, 1.0, 0.02) << p.dump();
    EXPECT_NEAR(p.value("amplitude_N", 0.0), 4.0, 0.2) << p.dump();
    EXPECT_FALSE(p.contains("period_note")) << p.dump();
    EXPECT_FALSE(r.gap_remains) << host::summary(r);
  }
}

// Beyond the travel the period is seen over less than one of itself: it is
// still found, and the report says it is less certain.
TEST(DiagnoseFamilies, RippleLongerThanTheTravelIsNamedAndSaysSo) {
  const double travel = travel_of(host::simulate(ripple_of_period(0.005)));
  const host::DiagnoseResult r = host::diagnose(host::simulate(ripple_of_period(1.6 * travel)), host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "position_ripple") << host::summary(r);
  const nlohmann::json& p = r.effect_parameters;
  EXPECT_NE(p.value("period_note", std::string()).find("longer than the travel"), std::string::npos) << p.dump();
  EXPECT_NEAR(p.value("period_m", 0.0) / (1.6 * travel), 1.0, 0.1) << p.dump();
  EXPECT_FALSE(r.gap_remains) << host::summary(r);
}

// A load that changes smoothly with position and not with the direction
// (a gas spring, a cable's pull): 60 N/m over the travel, added to an
// effect-free trace's force as the drift above is. It was `unexplained`
// at 4 times the noise floor; a ripple of a period beyond the travel draws
// it, and the report says what such a period means.
TEST(DiagnoseFamilies, ASpringsPullIsDrawnByARippleBeyondTheTravel) {
  host::SimConfig effect_free = ripple_of_period(0.005);
  effect_free.effects.ripple_amplitude_N = 0.0;
  host::Trace trace = host::simulate(effect_free);
  const double travel = travel_of(trace);
  for (auto& s : trace.samples) s.u_N += 60.0 * (s.x_m - 0.5 * travel);
  const host::DiagnoseResult r = host::diagnose(trace, host::DiagnoseOptions{});
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.effect, "position_ripple") << host::summary(r);
  const nlohmann::json& p = r.effect_parameters;
  EXPECT_GT(p.value("period_m", 0.0), travel) << p.dump();
  EXPECT_FALSE(p.value("period_note", std::string()).empty()) << p.dump();
  // Each harmonic with its phase, so that the replay draws the load's shape.
  if (p.value("harmonics", 1) > 1) {
    ASSERT_TRUE(p.contains("harmonic_phases_rad")) << p.dump();
    EXPECT_EQ(p["harmonic_phases_rad"].size(), p["harmonic_amplitudes_N"].size()) << p.dump();
  }
  EXPECT_GT(r.closed_fraction, 0.9) << host::summary(r);
}

}  // namespace
}  // namespace feedid::test


namespace feedid::test {
namespace {

/// The ripple's period grid over a travel of `travel_m` (the catalogue's
/// second family).
std::vector<double> ripple_grid(double travel_m) {
  host::Signals s;
  s.sample_rate_hz = 1000.0;
  s.has_position = true;
  for (int k = 0; k < 4000; ++k) {
    s.t.push_back(k / s.sample_rate_hz);
    s.x.push_back(0.05 * k / s.sample_rate_hz);
    s.v.push_back(0.05);
    s.u.push_back(20.0);
  }
  const double v_min = 1e-3;
  const host::diag::Observations obs(s, v_min, 0.005, host::diag::make_folds(s, 40, v_min));
  host::diag::TraceExtent e = host::diag::trace_extent(obs);
  e.travel = travel_m;
  const std::vector<host::diag::EffectModel> catalogue = host::diag::effect_catalogue(obs, e, 0.0, {});
  EXPECT_EQ(catalogue.at(1).kind, "position_ripple");
  return catalogue.at(1).grid;
}

// The grid ascends from the shortest period to three travels, so that the
// golden section between a grid point's neighbours has a bracket; on a
// travel under 1.2 mm, whose third is below the shortest period (0.4 mm),
// nothing is appended past the grid it had.
TEST(DiagnoseFamilies, RipplePeriodsAscendToThreeTravels) {
  const std::vector<double> g = ripple_grid(0.1);
  ASSERT_EQ(g.size(), 176u);
  EXPECT_DOUBLE_EQ(g.front(), 4e-4);
  EXPECT_NEAR(g.back(), 0.3, 1e-12);
  for (std::size_t i = 1; i < g.size(); ++i) EXPECT_GT(g[i], g[i - 1]) << i;
  const std::vector<double> tiny = ripple_grid(1e-3);
  EXPECT_EQ(tiny, host::diag::log_grid(4e-4, 1e-3 / 3.0, 160));
}

/// Observations of a back-and-forth motion over 0.1 m (positive, then
/// negative, with dwells at the ends), 1 kHz.
struct SweepObservations {
  host::Signals s;
  std::unique_ptr<host::diag::Observations> obs;
  SweepObservations() {
    s.sample_rate_hz = 1000.0;
    s.has_position = true;
    double x = 0.0;
    for (int k = 0; k < 8000; ++k) {
      const int phase = (k / 1000) % 4;  // out, dwell, back, dwell
      const double v = phase == 0 ? 0.1 : phase == 2 ? -0.1 : 0.0;
      s.t.push_back(k / s.sample_rate_hz);
      s.x.push_back(x);
      s.v.push_back(v);
      s.u.push_back(20.0 * (v > 0) - 20.0 * (v < 0));
      x += v / s.sample_rate_hz;
    }
    const double v_min = 1e-3;
    obs = std::make_unique<host::diag::Observations>(s, v_min, 0.005, host::diag::make_folds(s, 40, v_min));
  }
};

// A family that says which values of a segment it wrote (a spline's four)
// draws the columns it would draw writing them without saying so, also
// where successive segments write different bands.
TEST(DiagnoseFamilies, ABandedDrawIsTheFullDraw) {
  const SweepObservations so;
  using Obs = host::diag::Observations;
  for (const Obs::Resolution res : {Obs::Resolution::fine, Obs::Resolution::coarse})
    for (const Obs::Rows rows : {Obs::Rows::all, Obs::Rows::identification}) {
      // The band moves with position, and its last value is left to the
      // zeroing: what an earlier segment wrote there must not stay.
      const auto values = [](const host::diag::Segment& sg, double* out) {
        const int at = static_cast<int>(std::fabs(sg.x0) * 100.0) % 7;
        for (int k = 0; k < 3; ++k) out[at + k] = sg.v * (k + 1) + sg.x1;
        return Obs::Band{at, at + 4};
      };
      const host::diag::Mat full = so.obs->segment_columns(10, false, {res, rows}, [&](std::size_t, const host::diag::Segment& sg, double* out) {
        values(sg, out);
      });
      const host::diag::Mat banded = so.obs->segment_columns(10, false, {res, rows}, [&](std::size_t, const host::diag::Segment& sg, double* out) {
        return values(sg, out);
      });
      ASSERT_GT(full.cwiseAbs().sum(), 0.0);
      EXPECT_EQ(banded, full);
    }
}

// Where a family's sizes are nested (EffectModel::columns_per_size), a
// smaller size's columns are the larger size's first ones to the bit: the
// size search reads the smaller sizes off the largest draw, and adopt()
// takes the columns the evaluation drew rather than drawing them again.
TEST(DiagnoseFamilies, NestedSizesAreTheLargestDrawsFirstColumnsToTheBit) {
  const SweepObservations so;
  const host::diag::TraceExtent e = host::diag::trace_extent(*so.obs);
  const std::vector<host::diag::EffectModel> catalogue = host::diag::effect_catalogue(*so.obs, e, 0.0, {});
  int nested = 0;
  for (const host::diag::EffectModel& em : catalogue) {
    if (em.columns_per_size <= 0 || em.sizes.size() < 2) continue;
    ++nested;
    const double p = em.grid.empty() ? 0.0 : em.grid[em.grid.size() / 3];
    const host::diag::Mat largest = em.columns(p, em.sizes.back(), {});
    ASSERT_GT(largest.cwiseAbs().sum(), 0.0) << em.kind;
    for (const int size : em.sizes) {
      const host::diag::Mat alone = em.columns(p, size, {});
      ASSERT_EQ(alone.cols(), static_cast<Eigen::Index>(size) * em.columns_per_size) << em.kind;
      EXPECT_TRUE(alone == largest.leftCols(alone.cols())) << em.kind << " size " << size;
    }
  }
  EXPECT_GE(nested, 2);  // the ripple's harmonics and the compliance's dampings at least
}

// Position friction's ranges, drawn as the share below the upper edge less
// the share below the lower one, are each segment's share inside the
// range, signed as the motion.
TEST(DiagnoseFamilies, APositionRangeIsItsEdgesDifference) {
  const SweepObservations so;
  using Obs = host::diag::Observations;
  const host::diag::TraceExtent e = host::diag::trace_extent(*so.obs);
  const std::vector<host::diag::EffectModel> catalogue = host::diag::effect_catalogue(*so.obs, e, 0.0, {});
  const host::diag::EffectModel& pf = catalogue.at(2);
  ASSERT_EQ(pf.kind, "position_friction");
  ASSERT_TRUE(pf.edges_of);
  for (const double code : {10.0 * 1000 + 20, 0.0 * 1000 + 190, 55.0 * 1000 + 56, 150.0 * 1000 + 200}) {
    const auto [a, b] = pf.edges_of(code);
    const double xa = e.x_lo + e.travel * a / 200, xb = e.x_lo + e.travel * b / 200;
    const host::diag::Mat got = pf.columns(code, 0, {Obs::Resolution::fine, Obs::Rows::all});
    const host::diag::Mat want = so.obs->segment_columns(1, false, {Obs::Resolution::fine, Obs::Rows::all}, [&](std::size_t, const host::diag::Segment& sg, double* out) {
      const double lo = std::min(sg.x0, sg.x1), hi = std::max(sg.x0, sg.x1);
      const double inside = hi - lo < 1e-12 ? (lo >= xa && lo < xb ? 1.0 : 0.0) : std::max(0.0, std::min(hi, xb) - std::max(lo, xa)) / (hi - lo);
      out[0] = inside * (sg.v > 0 ? 1.0 : -1.0);
    });
    ASSERT_GT(want.cwiseAbs().sum(), 0.0) << code;
    EXPECT_LT((got - want).cwiseAbs().maxCoeff(), 1e-12) << code;
  }
}

}  // namespace
}  // namespace feedid::test
