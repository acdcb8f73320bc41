// Parameter recovery on the core's own traces (core_trace.hpp): a ladder
// of strokes of a known drive, streamed through the estimator in double
// and float and solved by the bands method (the project's) and the paper
// method. The closed-loop simulator's drives are in tests/sim/.
#include <gtest/gtest.h>

#include <memory>

#include "core/core_trace.hpp"

namespace {

using namespace feedid;
using core_test::rel_err;

template <typename T> std::unique_ptr<Estimator<T>> streamed(const std::vector<Sample<double>>& samples,
                                                              const core_test::StrokeSpec& spec) {
  auto est = std::make_unique<Estimator<T>>();
  if (est->init(core_test::default_config<T>(spec.encoder_m, spec.rate_hz)) != Status::ok) return nullptr;
  for (const Sample<double>& s : samples) (void)est->push(core_test::as<T>(s));
  return est;
}

void expect_direction_within(const DirectionEstimate<double>& e, const DirectionEstimate<double>& t, double tol_sigma_fc,
                             double tol_stribeck, const char* dir) {
  EXPECT_LT(rel_err(e.viscous_Ns_m, t.viscous_Ns_m), tol_sigma_fc) << dir << " sigma " << e.viscous_Ns_m;
  EXPECT_LT(rel_err(e.coulomb_N, t.coulomb_N), tol_sigma_fc) << dir << " Fc " << e.coulomb_N;
  EXPECT_LT(rel_err(e.breakaway_N, t.breakaway_N), tol_stribeck) << dir << " Fs " << e.breakaway_N;
  EXPECT_LT(rel_err(e.stribeck_velocity_m_s, t.stribeck_velocity_m_s), tol_stribeck) << dir << " vs " << e.stribeck_velocity_m_s;
}

class StrokeLadderRecovery : public ::testing::TestWithParam<Method> {};

TEST_P(StrokeLadderRecovery, RecoversAllNineParametersWithoutFlags) {
  // GIVEN 56 s of strokes from 0.2 mm/s to 150 mm/s each way, 10 nm counts, 0.5 N force noise
  const core_test::StrokeSpec spec;
  const Estimate<double> truth = core_test::default_drive();
  auto est = streamed<double>(core_test::stroke_ladder(truth, spec), spec);
  ASSERT_NE(est, nullptr);
  // WHEN solved
  ASSERT_EQ(est->solve(GetParam()), Status::ok);
  const Estimate<double>& e = est->estimate();
  // THEN every parameter is within a few per cent, and nothing is flagged
  EXPECT_LT(rel_err(e.mass_kg, truth.mass_kg), 0.01) << "mass " << e.mass_kg;
  expect_direction_within(e.pos, truth.pos, 0.02, 0.1, "pos");
  expect_direction_within(e.neg, truth.neg, 0.02, 0.1, "neg");
  EXPECT_EQ(e.mass_flags, 0u);
  EXPECT_EQ(e.pos.flags, 0u);
  EXPECT_EQ(e.neg.flags, 0u);
}

INSTANTIATE_TEST_SUITE_P(Methods, StrokeLadderRecovery, ::testing::Values(Method::bands, Method::paper),
                         [](const ::testing::TestParamInfo<Method>& i) { return i.param == Method::bands ? "bands" : "paper"; });

TEST(StrokeLadder, FloatAgreesWithDouble) {
  // GIVEN the same ladder streamed in float and in double
  const core_test::StrokeSpec spec;
  const auto samples = core_test::stroke_ladder(core_test::default_drive(), spec);
  auto d = streamed<double>(samples, spec);
  auto f = streamed<float>(samples, spec);
  ASSERT_NE(d, nullptr);
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(d->solve(), Status::ok);
  ASSERT_EQ(f->solve(), Status::ok);
  // THEN float's rounding moves no parameter by more than 0.5 %
  const Estimate<double>& a = d->estimate();
  const Estimate<float>& b = f->estimate();
  EXPECT_LT(rel_err(b.mass_kg, a.mass_kg), 0.005);
  EXPECT_LT(rel_err(b.pos.viscous_Ns_m, a.pos.viscous_Ns_m), 0.005);
  EXPECT_LT(rel_err(b.neg.coulomb_N, a.neg.coulomb_N), 0.005);
  EXPECT_LT(rel_err(b.pos.stribeck_velocity_m_s, a.pos.stribeck_velocity_m_s), 0.005);
  EXPECT_EQ(f->diagnostics().samples_accepted, d->diagnostics().samples_accepted);
}

TEST(StrokeLadder, OneDirectionOnlyFlagsTheOtherAndKeepsTheMass) {
  // GIVEN the ladder with every negative stroke replaced by rest
  const core_test::StrokeSpec spec;
  const Estimate<double> truth = core_test::default_drive();
  auto samples = core_test::stroke_ladder(truth, spec);
  double x_rest = 0.0;
  for (Sample<double>& s : samples) {
    if (s.velocity_m_s < 0 || (s.velocity_m_s == 0 && s.force_N < 0)) {
      s.velocity_m_s = 0.0;
      s.force_N = 0.0;
      s.position_m = x_rest;
    }
    x_rest = s.position_m;
  }
  auto est = streamed<double>(samples, spec);
  ASSERT_NE(est, nullptr);
  // WHEN solved  THEN the negative side says it has no data, the positive side and the mass stand
  (void)est->solve();
  const Estimate<double>& e = est->estimate();
  EXPECT_NE(e.neg.flags & flag_no_data, 0u);
  EXPECT_LT(rel_err(e.pos.coulomb_N, truth.pos.coulomb_N), 0.02);
  EXPECT_LT(rel_err(e.mass_kg, truth.mass_kg), 0.02);
}

}  // namespace
