// The model file reader (host_sim/model/model_file.hpp): what a user may
// write by hand, what identify writes, and the errors and warnings.
#include <gtest/gtest.h>

#include <stdexcept>

#include "model/model_file.hpp"
#include "test_support.hpp"

namespace {

using namespace feedid::host;
using nlohmann::json;

json emps_reference() {
  return json{{"m", 95.1089},
              {"pos", {{"sigma", 203.5034}, {"fc", 20.3935}}},
              {"neg", {{"sigma", 203.5034}, {"fc", 20.3935}}},
              {"offset_N", -3.1648}};
}

TEST(ModelFile, HandWrittenMinimalModelHasNoStribeckDip) {
  // GIVEN the EMPS reference model written by hand, without fs and vs
  const ModelFile m = model_file_from_json(emps_reference(), "ref.json");
  // THEN every value is read, the dip is absent and nothing is warned
  EXPECT_DOUBLE_EQ(m.drive.mass_kg, 95.1089);
  EXPECT_DOUBLE_EQ(m.drive.neg.viscous_Ns_m, 203.5034);
  EXPECT_DOUBLE_EQ(m.drive.pos.coulomb_N, 20.3935);
  EXPECT_EQ(m.drive.pos.breakaway_N, 0.0);
  EXPECT_DOUBLE_EQ(m.load.offset_N, -3.1648);
  EXPECT_TRUE(m.warnings.empty());
  // AND the friction just above rest is the Coulomb force, the dip absent
  EXPECT_NEAR(stribeck_friction(m.drive, 1e-9), 20.3935, 1e-6);
}

TEST(ModelFile, MissingKeyIsNamed) {
  json j = emps_reference();
  j["neg"].erase("fc");
  EXPECT_NE(model_file_from_json(j, "ref.json").error.find("'neg.fc'"), std::string::npos);
  j = emps_reference();
  j.erase("m");
  const std::string e = model_file_from_json(j, "ref.json").error;
  EXPECT_NE(e.find("ref.json"), std::string::npos) << e;
  EXPECT_NE(e.find("'m'"), std::string::npos) << e;
}

TEST(ModelFile, UnknownKeyIsAWarningNotAnError) {
  // GIVEN a typo at the top and inside a direction
  json j = emps_reference();
  j.erase("offset_N");
  j["ofset_N"] = -3.0;
  j["pos"]["sigam"] = 1.0;
  const ModelFile m = model_file_from_json(j, "ref.json");
  // THEN both are named in warnings, and the model is still read
  ASSERT_EQ(m.warnings.size(), 2u);
  EXPECT_NE(m.warnings[0].find("'pos.sigam'"), std::string::npos) << m.warnings[0];
  EXPECT_NE(m.warnings[1].find("'ofset_N'"), std::string::npos) << m.warnings[1];
  EXPECT_EQ(m.load.offset_N, 0.0);
}

// GIVEN a hand-written model whose mass is in grams or far beyond any
// feed drive (a review replayed m = 1e-9 kg to an acceleration error of
// 8e13 % without a word), or in rotary units
// THEN it is read and warned of, as identify warns of its own result
// (drive_model.hpp, implausible_parameters); a plausible one is not
TEST(ModelFile, AnImplausibleMassIsWarnedOfAsIdentifyDoes) {
  for (const double m : {1e-9, 1e12}) {
    json j = emps_reference();
    j["m"] = m;
    const ModelFile f = model_file_from_json(j, "ref.json");
    EXPECT_EQ(f.error, "");
    ASSERT_EQ(f.warnings.size(), 1u) << m;
    EXPECT_NE(f.warnings[0].find("mass of"), std::string::npos) << f.warnings[0];
    EXPECT_NE(f.warnings[0].find("ref.json"), std::string::npos) << f.warnings[0];
  }
  json rotary = emps_reference();
  rotary["m"] = 1e-6;  // kg m^2: a small motor's inertia, plausible
  rotary["units"] = {{"position", "rad"}, {"force", "N m"}};
  EXPECT_TRUE(model_file_from_json(rotary, "rot.json").warnings.empty());
  rotary["m"] = 1e-12;
  EXPECT_EQ(model_file_from_json(rotary, "rot.json").warnings.size(), 1u);
}

TEST(ModelFile, StribeckNeedsBothFsAndVs) {
  json j = emps_reference();
  j["pos"]["vs"] = 1e-3;
  EXPECT_NE(model_file_from_json(j, "x").error.find("'pos.vs'"), std::string::npos);
  j = emps_reference();
  j["pos"]["fs"] = 5.0;
  EXPECT_NE(model_file_from_json(j, "x").error.find("'pos.vs'"), std::string::npos);
  j["pos"]["vs"] = 2e-3;
  const ModelFile m = model_file_from_json(j, "x");
  EXPECT_EQ(m.drive.pos.breakaway_N, 5.0);
  EXPECT_EQ(m.drive.pos.stribeck_velocity_m_s, 2e-3);
}

TEST(ModelFile, NonPhysicalOrNonNumericIsAnError) {
  json j = emps_reference();
  j["m"] = -1.0;
  EXPECT_NE(model_file_from_json(j, "x").error.find("the model is not physical"), std::string::npos);
  j = emps_reference();
  j["pos"]["sigma"] = "203";
  EXPECT_NE(model_file_from_json(j, "x").error.find("'pos.sigma' must be a finite number"), std::string::npos);
  // In the file's own units (a review saw "m = -0.0005073 kg" of a model in V and rad).
  j = emps_reference();
  j.erase("offset_N");
  j["m"] = -1.0;
  j["units"] = {{"position", "rad"}, {"force", "V"}};
  const std::string why = model_file_from_json(j, "x").error;
  EXPECT_NE(why.find("m = -1 V s^2/rad"), std::string::npos) << why;
}

TEST(ModelFile, IdentifyReportKeysAreNotWarnedButAFailedStatusIsAnError) {
  // GIVEN the shape identify writes: the model among report keys
  json j = emps_reference();
  j.erase("offset_N");
  j["status"] = "ok";
  j["standard_errors"] = json::object();
  j["m_se"] = 0.1;
  j["pos"]["sigma_se"] = 1.0;
  j["pos"]["fs"] = 0.0;
  j["pos"]["vs"] = 0.0;  // identify writes vs = 0 when there is no dip
  const ModelFile m = model_file_from_json(j, "id.json");
  EXPECT_TRUE(m.warnings.empty());
  EXPECT_GT(m.drive.pos.stribeck_velocity_m_s, 0.0);  // F(v) stays defined
  // WHEN identify failed
  j["status"] = "insufficient_data";
  EXPECT_NE(model_file_from_json(j, "id.json").error.find("status"), std::string::npos);
}

TEST(ModelFile, ADirectionIdentifyNeverSawOrFlaggedIsWarnedOf) {
  // GIVEN identify's model of a trace that moved one way: neg no_data, its friction 0
  json j = emps_reference();
  j.erase("offset_N");
  j["status"] = "ok";
  j["standard_errors"] = json::object();
  j["pos"]["fs"] = 0.0;
  j["pos"]["identifiable"] = {{"sigma", true}, {"fc", true}, {"fs", false}, {"vs", false}};
  j["pos"]["flags"] = json::array({"stribeck_uncertain"});
  j["neg"] = {{"sigma", 0.0}, {"fc", 0.0}, {"fs", 0.0}, {"vs", 0.0}, {"flags", json::array({"no_data"})},
              {"identifiable", {{"sigma", false}, {"fc", false}, {"fs", false}, {"vs", false}}}};
  // THEN replay, diagnose --model, validate and compensate (all read it
  // here) are told, once, that the negative friction is a placeholder; the
  // positive direction's Stribeck flags are not warned of: no dip is in it
  const ModelFile m = model_file_from_json(j, "onedir.json");
  ASSERT_EQ(m.error, "");
  ASSERT_EQ(m.warnings.size(), 1u);
  EXPECT_NE(m.warnings[0].find("never saw the negative direction"), std::string::npos) << m.warnings[0];
  // AND a hand-written file (no status) is not read for identify's flags
  j.erase("status");
  j.erase("standard_errors");
  for (const char* d : {"pos", "neg"}) j[d].erase("identifiable"), j[d].erase("flags");
  EXPECT_TRUE(model_file_from_json(j, "hand.json").warnings.empty());
}

TEST(ModelFile, AnOffsetByItsSINameIsReadInAnyUnits) {
  // GIVEN a hand-written rotary model in volts with the documented offset_N
  json j = emps_reference();
  j["units"] = {{"position", "rad"}, {"force", "V"}};
  const ModelFile m = model_file_from_json(j, "hand.json");
  // THEN it is the load, and nothing is warned of
  EXPECT_DOUBLE_EQ(m.load.offset_N, -3.1648);
  EXPECT_TRUE(m.warnings.empty()) << m.warnings.front();
  // AND under the name the tool writes on such an axis too
  j.erase("offset_N");
  j["offset_V"] = 1.5;
  EXPECT_DOUBLE_EQ(model_file_from_json(j, "tool.json").load.offset_N, 1.5);
}

TEST(ModelFile, AGravityTermIsTheModelsLoad) {
  // GIVEN identify's constant form, its arm form, and an arm written by hand
  json constant = emps_reference(), arm = emps_reference(), by_hand = emps_reference();
  constant["gravity"] = {{"form", "constant"}, {"G", 5.0}};
  arm["gravity"] = {{"form", "angle"}, {"G", 30.0}, {"angle0_rad", 0.4}};
  by_hand["gravity"] = {{"G", 30.0}, {"angle0_rad", 0.4}, {"q0", 1.0}};
  // THEN a constant G adds to the offset, and the arm's weight is a load that turns with q
  const ModelFile c = model_file_from_json(constant, "c.json");
  EXPECT_DOUBLE_EQ(c.load.offset_N, -3.1648 + 5.0);
  EXPECT_FALSE(c.load.depends_on_position());
  for (const json& j : {arm, by_hand}) {
    const ModelFile a = model_file_from_json(j, "a.json");
    EXPECT_DOUBLE_EQ(a.load.gravity_N, 30.0);
    EXPECT_DOUBLE_EQ(a.load.at(0.4), -3.1648 + 30.0);
    EXPECT_NEAR(a.load.at(0.4 + 1.5707963267948966), -3.1648, 1e-12);
    // AND only a log with a position can carry the arm's weight (one rule
    // for validate, replay and diagnose), which the refusal names
    EXPECT_TRUE(a.load.refusal("run.csv", true).empty());
    const std::string why = a.load.refusal("run.csv", false);
    EXPECT_EQ(why.rfind("run.csv: ", 0), 0u) << why;
    EXPECT_NE(why.find("give the position column"), std::string::npos) << why;
  }
  EXPECT_TRUE(c.load.refusal("run.csv", false).empty()) << "a constant load needs no position";
  // AND a typo inside it is a warning, a form it does not know an error
  EXPECT_EQ(model_file_from_json(by_hand, "h.json").warnings.size(), 1u);
  arm["gravity"]["form"] = "sine";
  EXPECT_NE(model_file_from_json(arm, "x").error.find("gravity.form"), std::string::npos);
}

}  // namespace
