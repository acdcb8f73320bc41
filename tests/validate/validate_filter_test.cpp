// The comparison's position filter as applied: a cut-off beyond the log's
// reach (0.4 of its rate, applied_cutoff_hz) is reported as applied and
// said, in validate and in replay alike.
#include <gtest/gtest.h>

#include "test_support.hpp"
#include "validate/validate.hpp"

namespace feedid::host {
namespace {

// GIVEN a 2 kHz trace and its own model
// WHEN validated with --filter 5000 Hz (beyond the log's 1 kHz Nyquist)
// THEN the figures are those at 800 Hz, the cut-off it was applied at, and
// the JSON and the note say 800 Hz, not 5000 (a 5000 Hz "zero-phase
// Butterworth" was recorded while 450-5000 Hz all gave the same figure)
TEST(ValidateFilter, ACutOffBeyondTheRatesReachIsReportedAsApplied) {
  const Trace tr = host::simulate(test::sim_config(test::SimSpec{}));
  const DriveParams model = test::sim_config(test::SimSpec{}).drive;
  ValidateOptions beyond;
  beyond.filter_hz = 5000.0;
  const ValidateResult r = validate(model, tr, beyond);
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_NEAR(r.filter_applied_hz, 800.0, 1e-6);
  EXPECT_NE(r.filter_note().find("filtered at 800 Hz"), std::string::npos) << r.filter_note();
  const nlohmann::json j = to_json(r, model, beyond);
  EXPECT_NEAR(j["protocol"]["filter_hz"].get<double>(), 800.0, 1e-6);
  EXPECT_DOUBLE_EQ(j["protocol"]["filter_requested_hz"].get<double>(), 5000.0);
  ValidateOptions at;
  at.filter_hz = 800.0;
  const ValidateResult same = validate(model, tr, at);
  EXPECT_DOUBLE_EQ(same.relative_error_pct, r.relative_error_pct);
  EXPECT_EQ(same.filter_note(), "") << "a cut-off within reach is applied as asked";
}

}  // namespace
}  // namespace feedid::host
