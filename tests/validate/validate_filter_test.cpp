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

// GIVEN production motion, with dwells, and its own model
// WHEN its positions are moved by 0.5 m and by 1000 m
// THEN validate's errors are the same (at standstill the sign of the
// filtered position's rounding put +-Fc in the prediction: the full-rate
// error went from 26.8 to 28.0 % at 0.5 m and 28.6 % at 1000 m)
TEST(ValidateStandstill, MovingThePositionsOriginChangesNoFigure) {
  SimConfig cfg = test::sim_config(test::SimSpec{});
  cfg.motion.program = Program::production;
  cfg.motion.duration_s = 30.0;
  const Trace tr = host::simulate(cfg);
  const ValidateResult at0 = validate(cfg.drive, tr, ValidateOptions{});
  ASSERT_TRUE(at0.error.empty()) << at0.error;
  for (const double origin : {0.5, 1000.0}) {
    SCOPED_TRACE(origin);
    Trace moved = tr;
    for (TraceSample& s : moved.samples) s.x_m += origin;
    const ValidateResult r = validate(cfg.drive, moved, ValidateOptions{});
    ASSERT_TRUE(r.error.empty()) << r.error;
    EXPECT_NEAR(r.relative_error_full_pct, at0.relative_error_full_pct, 1e-4 * at0.relative_error_full_pct);
    EXPECT_NEAR(r.relative_error_pct, at0.relative_error_pct, 1e-4 * at0.relative_error_pct);
  }
}

}  // namespace
}  // namespace feedid::host
