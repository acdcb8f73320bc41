// Pooled recordings are joined with a time gap between them (Trace::runs).
// No block, block pair or force tap may span it (identify.cpp,
// for_each_block), and the core's counters are attributed to the run whose
// samples made them (run_core).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "identify/identify.hpp"

namespace feedid::test {
namespace {

using host::DriveParams;
using host::Signals;

/// A drive moving one way (v = 0.1 + 0.05 sin 2 pi t m/s) at 1 kHz for
/// `seconds` from t0, its force the model's plus a slow ripple the model
/// lacks (so the block residual is not zero), logged as held.
Signals moving_one_way(const DriveParams& p, double t0, double seconds) {
  Signals s;
  s.sample_rate_hz = 1000.0;
  s.force_lag_samples = -0.5;
  const int n = static_cast<int>(seconds * s.sample_rate_hz);
  const double w = 2.0 * M_PI;
  for (int k = 0; k < n; ++k) {
    const double t = t0 + k / s.sample_rate_hz;
    const double v = 0.1 + 0.05 * std::sin(w * t), a = 0.05 * w * std::cos(w * t);
    s.t.push_back(t);
    s.x.push_back(0.1 * t - 0.05 / w * std::cos(w * t));
    s.v.push_back(v);
    s.u.push_back(p.mass_kg * a + host::stribeck_friction(p, v) + 5.0 * std::sin(3.0 * t));
  }
  s.has_position = true;
  return s;
}

Signals joined(const Signals& a, const Signals& b) {
  Signals s = a;
  for (std::size_t k = 0; k < b.t.size(); ++k) {
    s.t.push_back(b.t[k]);
    s.x.push_back(b.x[k]);
    s.v.push_back(b.v[k]);
    s.u.push_back(b.u[k]);
  }
  return s;
}

// GIVEN two runs of a drive moving one way, joined as pooled recordings are
// (the second starts 10 s after the first ends, still moving), WHEN the
// block residual and the block mass are taken over the joined signals,
// THEN they equal those of the two runs taken apart: the 10 s step into the
// second run is in no block (it made one block of 10 s before), and the
// second run's first forces pair with no force of the first.
TEST(Blocks, NoBlockOrForceTapSpansTheGapBetweenRuns) {
  const DriveParams p;
  const Signals first = moving_one_way(p, 0.0, 2.0037);
  const Signals second = moving_one_way(p, 12.0037, 1.5);
  const Signals both = joined(first, second);
  ASSERT_TRUE(both.gap_before(first.t.size()));
  const double v_min = 0.01, block_s = 0.01;
  const host::BlockResidual r1 = host::block_residual(first, p, v_min, block_s);
  const host::BlockResidual r2 = host::block_residual(second, p, v_min, block_s);
  const host::BlockResidual r = host::block_residual(both, p, v_min, block_s);
  ASSERT_GT(r1.blocks, 100u);
  EXPECT_EQ(r.blocks, r1.blocks + r2.blocks);
  EXPECT_NEAR(r.sum_squares, r1.sum_squares + r2.sum_squares, 1e-9 * r.sum_squares);

  DriveParams light = p;
  light.mass_kg = 0.5 * p.mass_kg;  // friction held, the mass refitted on the blocks
  const host::BlockMass m = host::block_mass(both, light, v_min, block_s);
  ASSERT_TRUE(m.ok);
  EXPECT_NEAR(m.mass_kg, p.mass_kg, 0.01 * p.mass_kg);
}

/// Counters of run i from the snapshots at the runs' starts and the end.
feedid::Diagnostics run_counters(const host::CoreRun& run, std::size_t i) {
  const feedid::Diagnostics& a = run.counters_at[i];
  const feedid::Diagnostics& b = run.counters_at[i + 1];
  feedid::Diagnostics d;
  d.samples_accepted = b.samples_accepted - a.samples_accepted;
  d.samples_rejected = b.samples_rejected - a.samples_rejected;
  d.sections_split = b.sections_split - a.sections_split;
  return d;
}

// GIVEN two runs joined by a gap, moving when the gap comes (so it splits
// the first run's open section), WHEN the second run's first sample is
// rejected (a force beyond max_force_N), THEN each run's counters are as
// with that sample good but for the one rejection, which is the second
// run's: the split still belongs to the first run, although the gap is
// closed only by the second run's first accepted sample.
TEST(RunCounters, ARejectedFirstSampleLeavesTheGapsSplitWithTheRunBefore) {
  const DriveParams p;
  const Signals first = moving_one_way(p, 0.0, 3.0);
  Signals both = joined(first, moving_one_way(p, 13.0, 3.0));
  const std::vector<std::size_t> starts = {0, first.t.size()};
  host::IdentifyOptions quiet;
  quiet.select_friction_model = false;
  const feedid::Config<double> cfg = host::auto_config(both, quiet);
  const host::CoreRun clean = host::run_core(both, cfg, quiet, 0, static_cast<std::size_t>(-1), starts);
  both.u[first.t.size()] = 10.0 * cfg.max_force_N;
  const host::CoreRun bad = host::run_core(both, cfg, quiet, 0, static_cast<std::size_t>(-1), starts);
  ASSERT_EQ(clean.counters_at.size(), 3u);
  ASSERT_EQ(bad.counters_at.size(), 3u);
  ASSERT_GE(run_counters(clean, 0).sections_split, 1u);
  for (std::size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(run_counters(bad, i).sections_split, run_counters(clean, i).sections_split);
    EXPECT_EQ(run_counters(bad, i).samples_rejected, i == 1 ? 1u : 0u);
    EXPECT_EQ(run_counters(bad, i).samples_accepted + run_counters(bad, i).samples_rejected,
              run_counters(clean, i).samples_accepted);
  }
}

}  // namespace
}  // namespace feedid::test
