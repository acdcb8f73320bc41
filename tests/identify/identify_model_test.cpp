// The identified model as simulator parameters (identify.hpp,
// to_drive_params). GIVEN a direction without an identified Stribeck
// velocity, THEN the model has no dip (Fs = 0) instead of keeping Fs behind
// an invisible vs = 1e-9 m/s, and F(v) stays finite.
#include <gtest/gtest.h>

#include <cmath>

#include "identify/identify.hpp"
#include "model/model_file.hpp"
#include "test_support.hpp"

namespace feedid::test {
namespace {

TEST(ToDriveParams, NoStribeckVelocityMeansNoDip) {
  feedid::Estimate<double> e;
  e.mass_kg = 50.0;
  e.pos = {};
  e.pos.viscous_Ns_m = 600.0;
  e.pos.coulomb_N = 20.0;
  e.pos.breakaway_N = 7.0;
  e.pos.stribeck_velocity_m_s = 0.0;  // not identified
  e.neg = e.pos;
  e.neg.stribeck_velocity_m_s = 2e-3;
  const host::DriveParams p = host::to_drive_params(e);
  EXPECT_EQ(p.pos.breakaway_N, 0.0);
  EXPECT_DOUBLE_EQ(host::stribeck_friction(p, 1e-4), 20.0 + 600.0 * 1e-4);
  EXPECT_EQ(p.neg.breakaway_N, 7.0);
  EXPECT_DOUBLE_EQ(p.neg.stribeck_velocity_m_s, 2e-3);
}

// GIVEN a drive identified with its force labelled in volts, THEN the JSON
// and the summary give SysId's gains: kS and kV the directions' means, kG
// half the Coulomb difference, kA the mass; in N there is no such block.
TEST(SysIdGains, AForceInVoltsGetsKsKvKaKg) {
  const host::Trace tr = simulate(SimSpec{100.0, 2000.0, 1, 1e-8, 0.5, 30.0});
  host::IdentifyOptions volts;
  volts.units = host::units_for(host::Axis::linear, "V");
  const host::IdentifyResult r = host::identify(tr, volts);
  ASSERT_EQ(r.status, feedid::Status::ok) << r.error;
  const nlohmann::json j = host::to_json(r).at("sysid");
  const auto& e = r.estimate;
  EXPECT_DOUBLE_EQ(j.at("kS").get<double>(), 0.5 * (e.pos.coulomb_N + e.neg.coulomb_N));
  EXPECT_DOUBLE_EQ(j.at("kG").get<double>(), 0.5 * (e.pos.coulomb_N - e.neg.coulomb_N));
  EXPECT_DOUBLE_EQ(j.at("kV").get<double>(), 0.5 * (e.pos.viscous_Ns_m + e.neg.viscous_Ns_m));
  EXPECT_DOUBLE_EQ(j.at("kA").get<double>(), e.mass_kg);
  EXPECT_GT(j.at("kS_se").get<double>(), 0.0);
  EXPECT_EQ(j.at("units").at("kV").get<std::string>(), "V s/m");
  EXPECT_NE(host::summary(r).find("SysId gains: kS"), std::string::npos);
  EXPECT_TRUE(host::to_json(host::identify(tr, host::IdentifyOptions{})).at("sysid").is_null());
}

// GIVEN a drive whose position is left in counts of 0.1 um (scaled by 1e7),
// THEN the implausible mass and speed are each warned of, naming the scale;
// the same drive in m and N gets no warning.
TEST(ImplausibleMagnitudes, AnUnscaledPositionIsNamed) {
  host::Trace tr = simulate(SimSpec{100.0, 2000.0, 1, 1e-8, 0.5, 30.0});
  EXPECT_TRUE(host::implausible_magnitudes(host::identify(tr, host::IdentifyOptions{})).empty());
  for (auto& smp : tr.samples) {
    smp.x_m *= 1e7;
    smp.v_m_s *= 1e7;
  }
  const host::IdentifyResult r = host::identify(tr, host::IdentifyOptions{});
  ASSERT_EQ(r.status, feedid::Status::ok) << r.error;
  const auto w = host::implausible_magnitudes(r);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_NE(w[0].find("mass"), std::string::npos) << w[0];
  EXPECT_NE(w[1].find("--position-scale"), std::string::npos) << w[1];
  EXPECT_EQ(host::to_json(r).at("warnings").size(), 2u);
}

// GIVEN identify's own JSON as written, with and without a constant
// gravity term, on a linear axis, a rotary one and a force in volts,
// THEN the model reader passes over every key identify writes beside the
// model (kIdentifyReportKeys follows to_json, in the file's units), AND a
// typo beside them, at the top or in a direction, is warned of by name
// (it was passed over with them: an 'ofset_N' read as no offset without
// a word).
TEST(ModelFileOfIdentify, OnlyKeysIdentifyDoesNotWriteAreWarnedOf) {
  const host::Trace tr = simulate(SimSpec{100.0, 2000.0, 1, 1e-8, 0.5, 20.0});
  const host::Units rotary{"rad", "N m"}, volts{"m", "V"};
  for (const host::GravityTerm g : {host::GravityTerm::none, host::GravityTerm::constant})
  for (const host::Units& units : {host::Units{}, rotary, volts}) {
    SCOPED_TRACE(units.position + " " + units.force);
    host::IdentifyOptions opt;
    opt.gravity = g;
    opt.units = units;
    nlohmann::json j = host::json_as_written(host::to_json(host::identify(tr, opt)));
    j["truth"] = host::model_json(host::SimConfig{}.drive);  // as demo writes it beside the model
    const host::ModelFile clean = host::model_file_from_json(j, "id.json");
    ASSERT_TRUE(clean.error.empty()) << clean.error;
    EXPECT_TRUE(clean.warnings.empty()) << clean.warnings.front();
    j["ofset_N"] = 3.0;
    j["pos"]["sigmaa"] = 1.0;
    const host::ModelFile typo = host::model_file_from_json(j, "id.json");
    ASSERT_EQ(typo.warnings.size(), 2u);
    EXPECT_NE(typo.warnings[0].find("'pos.sigmaa'"), std::string::npos) << typo.warnings[0];
    EXPECT_NE(typo.warnings[1].find("'ofset_N'"), std::string::npos) << typo.warnings[1];
  }
}

}  // namespace
}  // namespace feedid::test
