// A model's load reaches every command that takes the model: identify
// --gravity writes it, the model file reads it, validate predicts with it
// (host_sim/model/drive_model.hpp ModelLoad, issue 31).
#include <gtest/gtest.h>

#include "identify/gravity.hpp"
#include "model/model_file.hpp"
#include "test_support.hpp"
#include "validate/validate.hpp"

namespace feedid::host {
namespace {

TEST(ModelLoad, AnArmIdentifiedWithItsWeightIsValidatedWithIt) {
  // GIVEN an arm whose weight is 30 N m at 0.4 rad, identified with the angle term
  const Trace loaded = test::arm_trace(30.0, 0.4);
  IdentifyOptions o;
  o.units = units_for(Axis::rotary);
  o.gravity = GravityTerm::angle;
  const IdentifyResult r = identify(loaded, o);
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.gravity.form, GravityTerm::angle) << r.gravity.note;
  // WHEN its JSON is read back as a model file
  const ModelFile m = model_file_from_json(to_json(r), "arm.json");
  // THEN the weight is the model's load, as fitted
  EXPECT_DOUBLE_EQ(m.load.gravity_N, r.gravity.G);
  EXPECT_DOUBLE_EQ(m.load.gravity_angle0_rad, r.gravity.angle0_rad);
  // AND validate predicts the loaded arm with it as well as the friction
  // alone predicts the unloaded arm; without it the error is over twice that
  ValidateOptions with, without;
  with.units = without.units = o.units;
  with.load = m.load;
  const double e_with = validate(m.drive, loaded, with).relative_error_pct;
  const double e_without = validate(m.drive, loaded, without).relative_error_pct;
  const double e_unloaded = validate(m.drive, test::arm_trace(0.0, 0.4), without).relative_error_pct;
  EXPECT_LT(e_with, 1.1 * e_unloaded) << e_with << " % against " << e_unloaded << " %";
  EXPECT_GT(e_without, 2.0 * e_with);
  // AND its JSON states the load it predicted with
  const nlohmann::json j = to_json(validate(m.drive, loaded, with), m.drive, with);
  EXPECT_DOUBLE_EQ(j.at("model").at("gravity").at("G").get<double>(), r.gravity.G);
}

TEST(ModelLoad, AnArmsWeightWithoutAPositionIsRefused) {
  Trace no_position = test::arm_trace(30.0, 0.4);
  no_position.has_position = false;
  ValidateOptions o;
  o.load.gravity_N = 30.0;
  const std::string why = validate(DriveParams{}, no_position, o).error;
  EXPECT_NE(why.find("no position"), std::string::npos) << why;
}

}  // namespace
}  // namespace feedid::host
