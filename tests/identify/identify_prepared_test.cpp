// Identification of prepared signals (identify.hpp, identify_prepared;
// condition.hpp, select_samples): the one conditioning serves every later
// stage (issue 29). GIVEN a trace, THEN identify() is prepare_signals then
// identify_prepared, number for number. GIVEN a selection of prepared
// signals (diagnose's identification folds), THEN the samples left out
// play no part: corrupting them changes nothing, and the cut is a gap that
// no force tap or integral spans.
#include <gtest/gtest.h>

#include <cmath>

#include "identify/identify.hpp"
#include "signals/condition.hpp"
#include "signals/force_outliers.hpp"
#include "test_support.hpp"

namespace feedid::test {
namespace {

host::Trace drive_trace() { return simulate(SimSpec{100.0, 2000.0, 3, 1e-8, 0.5, 30.0}); }

void expect_same_estimate(const host::IdentifyResult& a, const host::IdentifyResult& b) {
  const auto pa = host::to_drive_params(a.estimate), pb = host::to_drive_params(b.estimate);
  EXPECT_EQ(pa.mass_kg, pb.mass_kg);
  EXPECT_EQ(pa.pos.coulomb_N, pb.pos.coulomb_N);
  EXPECT_EQ(pa.neg.viscous_Ns_m, pb.neg.viscous_Ns_m);
  EXPECT_EQ(pa.neg.stribeck_velocity_m_s, pb.neg.stribeck_velocity_m_s);
  EXPECT_EQ(a.estimate.mass_se_kg, b.estimate.mass_se_kg);
}

TEST(IdentifyPrepared, IdentifyIsPrepareThenIdentifyPrepared) {
  const host::Trace tr = drive_trace();
  const host::IdentifyOptions opt;
  const host::IdentifyResult whole = host::identify(tr, opt);
  ASSERT_EQ(whole.status, feedid::Status::ok) << whole.error;
  host::ForceOutliers outliers;
  const host::IdentifyResult prepared =
      host::identify_prepared(host::prepare_signals(host::bridge_force_outliers(tr, "N", outliers), opt), opt, tr.source);
  ASSERT_EQ(prepared.status, feedid::Status::ok) << prepared.error;
  expect_same_estimate(whole, prepared);
}

TEST(IdentifyPrepared, SamplesLeftOutOfASelectionPlayNoPart) {
  const host::Trace tr = drive_trace();
  const host::IdentifyOptions opt;
  const host::Signals s = host::prepare_signals(tr, opt);
  // Keep the first and last 12 s: a 6 s hole in the middle, as a held-out fold.
  std::vector<char> keep(s.t.size());
  std::size_t first_after_hole = 0;
  for (std::size_t k = 0; k < s.t.size(); ++k) {
    keep[k] = s.t[k] - s.t.front() < 12.0 || s.t[k] - s.t.front() >= 18.0;
    if (k > 0 && keep[k] && !keep[k - 1]) first_after_hole = k;
  }
  const host::Signals kept = host::select_samples(s, keep);
  const std::size_t at_cut = first_after_hole - (s.t.size() - kept.t.size());
  ASSERT_GT(at_cut, 0u);
  EXPECT_TRUE(kept.gap_before(at_cut));
  EXPECT_EQ(kept.force_lag_samples, s.force_lag_samples);
  EXPECT_EQ(kept.velocity_filter_hz, s.velocity_filter_hz);
  // The rival cut-offs' velocities, derived once on the whole signals,
  // are selected with the samples, not derived again across the hole.
  ASSERT_FALSE(s.velocity_filter_rivals_hz.empty());
  ASSERT_EQ(kept.rival_velocities.size(), s.velocity_filter_rivals_hz.size());
  EXPECT_EQ(kept.rival_velocities[0][at_cut], s.rival_velocities[0][first_after_hole]);
  EXPECT_EQ(kept.rival_velocities[0].size(), kept.t.size());

  host::Signals corrupted = s;
  for (std::size_t k = 0; k < s.t.size(); ++k)
    if (!keep[k]) corrupted.u[k] = 1e9, corrupted.v[k] = -3.0, corrupted.x[k] = 42.0;
  const host::IdentifyResult a = host::identify_prepared(kept, opt, "selection");
  const host::IdentifyResult b = host::identify_prepared(host::select_samples(corrupted, keep), opt, "selection");
  ASSERT_EQ(a.status, feedid::Status::ok) << a.error;
  ASSERT_EQ(b.status, feedid::Status::ok) << b.error;
  expect_same_estimate(a, b);
  EXPECT_NEAR(a.estimate.mass_kg, 100.0, 1.0);

  // The route diagnose took before: a trace of the kept rows, conditioned
  // again with the conventions stated. The two differ only where the
  // velocity filter meets the hole.
  host::Trace cut = tr;
  cut.samples.clear();
  for (std::size_t k = 0; k < tr.samples.size(); ++k)
    if (keep[k]) cut.samples.push_back(tr.samples[k]);
  const host::IdentifyResult c = host::identify(cut, host::with_conventions_of(s, opt));
  ASSERT_EQ(c.status, feedid::Status::ok) << c.error;
  EXPECT_NEAR(a.estimate.mass_kg, c.estimate.mass_kg, a.estimate.mass_se_kg);
  EXPECT_NEAR(a.estimate.pos.coulomb_N, c.estimate.pos.coulomb_N, a.estimate.pos.coulomb_se);
  EXPECT_NEAR(a.estimate.neg.coulomb_N, c.estimate.neg.coulomb_N, a.estimate.neg.coulomb_se);
}

}  // namespace
}  // namespace feedid::test
