// Units: a rotary axis, a scaled input and a labelled force go through the
// same arithmetic as a linear SI log, and only the labels change
// (host_sim/io/units.hpp). The identification must therefore be equivariant:
// the same motion in other units gives the same parameters in those units.
#include <gtest/gtest.h>

#include <string>

#include "io/csv_trace.hpp"
#include "identify/identify.hpp"
#include "report/report.hpp"
#include "test_support.hpp"

namespace feedid::host {
namespace {

// A ball screw of 10 mm lead: 1 m of table travel is 2 pi / 0.01 rad of
// motor, and 1 N on the table is 0.01 / (2 pi) N m at the motor.
constexpr double kLead_m = 0.01;
constexpr double kRadPerM = 2.0 * 3.14159265358979323846 / kLead_m;
constexpr double kNmPerN = 1.0 / kRadPerM;

Trace to_rotary(Trace t) {
  for (auto& s : t.samples) {
    s.x_m *= kRadPerM;
    s.v_m_s *= kRadPerM;
    s.u_N *= kNmPerN;
  }
  return t;
}

/// value_rotary, brought back to linear units, within `se_fraction` of the
/// linear value's standard error (and 1e-9 relative, for exact agreement).
void expect_same(const char* name, double linear, double linear_se, double rotary, double to_linear, double se_fraction) {
  const double back = rotary * to_linear;
  EXPECT_NEAR(back, linear, se_fraction * linear_se + 1e-9 * std::fabs(linear)) << name;
}

TEST(Units, RotaryAxisIdentifiesTheSameDriveInItsOwnUnits) {
  test::SimSpec spec;
  spec.duration_s = 40.0;
  const Trace linear = test::simulate(spec);
  IdentifyOptions lin_opt, rot_opt;
  rot_opt.units = units_for(Axis::rotary);
  const IdentifyResult a = identify(linear, lin_opt);
  const IdentifyResult b = identify(to_rotary(linear), rot_opt);
  ASSERT_TRUE(a.error.empty()) << a.error;
  ASSERT_TRUE(b.error.empty()) << b.error;

  // Force per acceleration: N m / (rad/s^2) = kg m^2; back to kg by / (kNmPerN / kRadPerM).
  const double mass_back = 1.0 / (kNmPerN / kRadPerM), viscous_back = mass_back, force_back = 1.0 / kNmPerN;
  // Data-driven choices (the velocity filter, the lag grid) may pick a
  // neighbouring candidate on the scaled data; the estimates must still
  // agree well inside their own uncertainty.
  const double tol = 0.5;
  expect_same("m", a.estimate.mass_kg, a.estimate.mass_se_kg, b.estimate.mass_kg, mass_back, tol);
  for (int d = 0; d < 2; ++d) {
    const auto& x = d == 0 ? a.estimate.pos : a.estimate.neg;
    const auto& y = d == 0 ? b.estimate.pos : b.estimate.neg;
    expect_same("sigma", x.viscous_Ns_m, x.viscous_se, y.viscous_Ns_m, viscous_back, tol);
    expect_same("Fc", x.coulomb_N, x.coulomb_se, y.coulomb_N, force_back, tol);
    expect_same("Fs", x.breakaway_N, x.breakaway_se, y.breakaway_N, force_back, tol);
    expect_same("vs", x.stribeck_velocity_m_s, x.stribeck_velocity_se, y.stribeck_velocity_m_s, 1.0 / kRadPerM, tol);
    // The standard errors scale too (within 30 %: the jackknife's chunks see the same data).
    EXPECT_NEAR(y.coulomb_se * force_back / x.coulomb_se, 1.0, 0.3);
  }

  // Every label follows the axis.
  const nlohmann::json j = to_json(b);
  EXPECT_EQ(j["units"]["m"], "kg m^2");
  EXPECT_EQ(j["units"]["sigma"], "N m s/rad");
  EXPECT_EQ(j["units"]["fc"], "N m");
  EXPECT_EQ(j["units"]["vs"], "rad/s");
  const std::string text = summary(b, nullptr);
  EXPECT_NE(text.find("kg m^2"), std::string::npos) << text;
  EXPECT_NE(text.find("N m s/rad"), std::string::npos) << text;
  EXPECT_EQ(text.find("N s/m"), std::string::npos) << text;
}

TEST(Units, ForceLabelGivesSysIdStyleUnits) {
  const Units u = units_for(Axis::rotary, "V");
  EXPECT_EQ(u.force, "V");
  EXPECT_EQ(u.viscous(), "V s/rad");  // SysId's kV
  EXPECT_EQ(u.mass(), "V s^2/rad");   // SysId's kA
  EXPECT_EQ(units_for(Axis::linear).mass(), "kg");
  EXPECT_EQ(units_for(Axis::linear, "A").viscous(), "A s/m");
}

TEST(Units, AModelInOtherUnitsThanTheLogIsNamed) {
  // GIVEN a rotary model in V (as identify writes SysId's) and logs read linear and rotary
  const nlohmann::json rotary_v = {{"m", 1.0}, {"units", units_json(units_for(Axis::rotary, "V"))}};
  // THEN applying it to a linear log in N is refused, naming both units and the fix
  const std::string why = model_units_mismatch(rotary_v, units_for(Axis::linear));
  EXPECT_NE(why.find("rad"), std::string::npos) << why;
  EXPECT_NE(why.find("--axis"), std::string::npos) << why;
  // AND to a rotary log in V it is not, nor is a model that states no units
  EXPECT_EQ(model_units_mismatch(rotary_v, units_for(Axis::rotary, "V")), "");
  EXPECT_EQ(model_units_mismatch(nlohmann::json{{"m", 1.0}}, units_for(Axis::linear)), "");
  // AND a linear model on a rotary log is refused too
  const nlohmann::json linear = {{"units", units_json(units_for(Axis::linear))}};
  EXPECT_NE(model_units_mismatch(linear, units_for(Axis::rotary)), "");
}

TEST(Units, ScalesApplyAsTheCsvIsRead) {
  CsvColumns cols;
  cols.position_scale = 1e-6;  // encoder counts of 1 um
  cols.force_scale = 2.5;      // N per A
  const CsvResult r = parse_trace_csv("t,x,v,u\n0,0,0,1\n0.001,1000,1000000,2\n", "mem.csv", cols);
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.trace.samples.size(), 2u);
  EXPECT_DOUBLE_EQ(r.trace.samples[1].x_m, 1e-3);
  EXPECT_DOUBLE_EQ(r.trace.samples[1].v_m_s, 1.0);
  EXPECT_DOUBLE_EQ(r.trace.samples[1].u_N, 5.0);

  cols.force_scale = 0.0;
  const CsvResult bad = parse_trace_csv("t,x,v,u\n0,0,0,1\n", "mem.csv", cols);
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.error.find("--force-scale"), std::string::npos) << bad.error;
}

}  // namespace
TEST(Units, KeysNameTheUnitsTheirValuesAreInAndReadBack) {
  // GIVEN keys in m and N, and an axis in rad and N m, and a drive logged in volts
  const Units rotary = units_for(Axis::rotary), volts = units_for(Axis::rotary, "V");
  // THEN each names the units its value is in
  EXPECT_EQ(key_in_units("velocity_max_m_s", rotary), "velocity_max_rad_s");
  EXPECT_EQ(key_in_units("max_acceleration_m_s2", rotary), "max_acceleration_rad_s2");
  EXPECT_EQ(key_in_units("force_N", rotary), "force_N_m");
  EXPECT_EQ(key_in_units("load_mass_kg", rotary), "load_mass_kg_m2");
  EXPECT_EQ(key_in_units("viscous_change_Ns_m", volts), "viscous_change_V_s_rad");
  EXPECT_EQ(key_in_units("mass_from_windows_kg", volts), "mass_from_windows_V_s2_rad");
  EXPECT_EQ(key_in_units("period_m", volts), "period_rad");
  // AND keys of no unit, and every key of a log in m and N, stay as they are
  for (const char* k : {"m", "sigma", "time_constant_s", "frequency_hz", "relative_error_pct"})
    EXPECT_EQ(key_in_units(k, rotary), k);
  EXPECT_EQ(key_in_units("force_N", Units{}), "force_N");
  // AND what reads them back gets the m and N names again
  for (const Units& u : {rotary, volts})
    for (const char* k : {"velocity_max_m_s", "max_acceleration_m_s2", "force_N", "load_mass_kg", "viscous_change_Ns_m",
                          "period_m", "x_m", "time_constant_s"})
      EXPECT_EQ(key_in_si(key_in_units(k, u), u), k) << k << " in " << u.position << ", " << u.force;
  // AND an angle's key is rad on every axis: read back as it is
  for (const char* k : {"phase_rad", "angle0_rad", "angle0_se_rad"}) EXPECT_EQ(key_in_si(k, rotary), k);
  // AND a command's JSON is renamed through its objects and lists by the units it states
  const nlohmann::json j = {{"units", units_json(volts)}, {"effects", {{{"parameters", {{"force_N", 1.0}}}}}}};
  EXPECT_EQ(json_as_written(j)["effects"][0]["parameters"]["force_V"], 1.0);
}

}  // namespace feedid::host
