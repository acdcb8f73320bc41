// The estimator built without the paper method (the firmware's build,
// FEEDID_PAPER_METHOD=0 or Estimator<T, B, C, false>; issue 34): its
// servo path keeps other partial sums (the mass window's band cells, a fold
// spread over 2 x Bands pushes, a cached band), so these tests hold it to
// the estimator with the paper method on the same streams: the same bands
// estimate to rounding, the same counters, and solve(Method::paper)
// refused without touching anything.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "core/core_trace.hpp"
#include "feedid/footprint_budget.hpp"

namespace {

using namespace feedid;

using Full = Estimator<double>;
using Lean = Estimator<double, 32, 16, false>;

static_assert(Full::paper_method, "the host default keeps the paper method");
static_assert(!Lean::paper_method, "");
static_assert(sizeof(Estimator<float, 32, 16, false>) <= fw::estimator_float_ram_budget,
              "the firmware's Estimator<float> (no paper method) exceeds its 8 KiB budget");

/// Relative agreement of two estimates of the same stream that differ only
/// in the order of additions: far below any standard error, far above the
/// rounding of double sums (the fold periods differ).
constexpr double kSameTol = 1e-9;

void expect_same(double lean, double full, const char* what) {
  EXPECT_NEAR(lean, full, kSameTol * (std::fabs(full) + 1e-12)) << what;
}

/// sections_alike: whether complete sections are counted alike. With the
/// paper method a fold period ends at each section and after max_fold_s of
/// one direction's quasi-steady time, which splits (uncounts) a longer
/// section; without it a fold never splits a section.
void expect_same_estimate(const Estimate<double>& lean, const Estimate<double>& full, bool sections_alike) {
  expect_same(lean.mass_kg, full.mass_kg, "mass");
  EXPECT_EQ(lean.mass_flags, full.mass_flags);
  const DirectionEstimate<double>* l[2] = {&lean.pos, &lean.neg};
  const DirectionEstimate<double>* f[2] = {&full.pos, &full.neg};
  for (int d = 0; d < 2; ++d) {
    SCOPED_TRACE(d == 0 ? "positive" : "negative");
    expect_same(l[d]->viscous_Ns_m, f[d]->viscous_Ns_m, "sigma");
    expect_same(l[d]->coulomb_N, f[d]->coulomb_N, "Fc");
    expect_same(l[d]->breakaway_N, f[d]->breakaway_N, "Fs");
    expect_same(l[d]->stribeck_velocity_m_s, f[d]->stribeck_velocity_m_s, "vs");
    EXPECT_EQ(l[d]->flags, f[d]->flags);
    EXPECT_EQ(l[d]->bands_used, f[d]->bands_used);
    if (sections_alike) EXPECT_EQ(l[d]->sections, f[d]->sections);
  }
}

struct Pair {
  std::unique_ptr<Full> full = std::make_unique<Full>();
  std::unique_ptr<Lean> lean = std::make_unique<Lean>();
  void init(const Config<double>& cfg) {
    ASSERT_EQ(full->init(cfg), Status::ok);
    ASSERT_EQ(lean->init(cfg), Status::ok);
  }
  void push(const Sample<double>& s) { EXPECT_EQ(lean->push(s), full->push(s)); }
  void solve_and_compare(bool sections_alike = true) {
    const Status sf = full->solve(), sl = lean->solve();
    EXPECT_EQ(sl, sf);
    expect_same_estimate(lean->estimate(), full->estimate(), sections_alike);
    const Diagnostics a = lean->diagnostics(), b = full->diagnostics();
    EXPECT_EQ(a.samples_accepted, b.samples_accepted);
    EXPECT_EQ(a.samples_rejected, b.samples_rejected);
    if (sections_alike) {
      EXPECT_EQ(a.sections_complete[0], b.sections_complete[0]);
      EXPECT_EQ(a.sections_complete[1], b.sections_complete[1]);
    }
    EXPECT_EQ(a.sections_short, b.sections_short);
    EXPECT_EQ(a.mass_windows, b.mass_windows);
    EXPECT_EQ(a.continuity_breaks, b.continuity_breaks);
  }
};

std::vector<Sample<double>> ladder(int strokes = 8) {
  core_test::StrokeSpec spec;
  spec.strokes_per_direction = strokes;
  return core_test::stroke_ladder(core_test::default_drive(), spec);
}

// GIVEN the stroke ladder WHEN both builds take it, with a solve mid-stream
// THEN both solves agree to rounding, and so do the counters.
TEST(LeanEstimator, SameEstimateAsWithThePaperMethod) {
  const std::vector<Sample<double>> tr = ladder();
  Pair p;
  p.init(core_test::default_config<double>(1e-8, 1000.0));
  for (std::size_t k = 0; k < tr.size(); ++k) {
    p.push(tr[k]);
    if (k == tr.size() / 2) p.solve_and_compare();
  }
  p.solve_and_compare();
  EXPECT_EQ(p.lean->diagnostics().samples_accepted, tr.size());
  // A real identification, not two empty ones: m near the drive's 100 kg.
  EXPECT_NEAR(p.lean->estimate().mass_kg, 100.0, 5.0);
  EXPECT_GT(p.lean->estimate().pos.bands_used, 10u);
  EXPECT_GT(p.lean->diagnostics().mass_windows, 100u);
}

// GIVEN folds every 0.3 s (many spread folds, some overlapping a window's
// close) and a gap that breaks continuity THEN the same estimate (the
// paper method's build splits the 1 s strokes at its folds, so complete
// sections are not compared).
TEST(LeanEstimator, SpreadFoldsAndGapsLoseNothing) {
  std::vector<Sample<double>> tr = ladder(6);
  tr[tr.size() / 3].dt_s = 0.5;  // a gap beyond max_gap_s: continuity breaks
  Config<double> cfg = core_test::default_config<double>(1e-8, 1000.0);
  cfg.max_fold_s = 0.3;
  Pair p;
  p.init(cfg);
  for (const Sample<double>& s : tr) p.push(s);
  p.solve_and_compare(false);
  EXPECT_EQ(p.lean->diagnostics().continuity_breaks, 1u);
  // A fold period shorter than one sample: every push starts a fold and
  // folds one band; the sums still all arrive.
  cfg.max_fold_s = 1e-4;
  p.init(cfg);
  for (const Sample<double>& s : tr) p.push(s);
  p.solve_and_compare(false);
}

// GIVEN rejected samples in the stream THEN both builds count and bridge them alike.
TEST(LeanEstimator, RejectedSamplesCountedAlike) {
  std::vector<Sample<double>> tr = ladder(4);
  for (std::size_t k = 500; k < tr.size(); k += 997) tr[k].force_N = std::nan("");
  Pair p;
  p.init(core_test::default_config<double>(1e-8, 1000.0));
  for (const Sample<double>& s : tr) p.push(s);
  p.solve_and_compare();
  EXPECT_GT(p.lean->diagnostics().samples_rejected, 0u);
  EXPECT_EQ(p.lean->diagnostics().samples_accepted + p.lean->diagnostics().samples_rejected, tr.size());
}

// GIVEN an estimator without the paper method WHEN solve(Method::paper)
// THEN method_not_built, and the statistics and the last estimate stay.
TEST(LeanEstimator, PaperMethodRefused) {
  const std::vector<Sample<double>> tr = ladder(4);
  auto lean = std::make_unique<Lean>();
  ASSERT_EQ(lean->init(core_test::default_config<double>(1e-8, 1000.0)), Status::ok);
  for (const Sample<double>& s : tr) (void)lean->push(s);
  ASSERT_EQ(lean->solve(), Status::ok);
  const Estimate<double> before = lean->estimate();
  std::vector<unsigned char> stats(sizeof(Lean::Stats));
  std::memcpy(stats.data(), &lean->statistics(), stats.size());
  EXPECT_EQ(lean->solve(Method::paper), Status::method_not_built);
  EXPECT_EQ(std::memcmp(stats.data(), &lean->statistics(), stats.size()), 0);
  EXPECT_EQ(lean->estimate().method, Method::bands);
  EXPECT_EQ(lean->estimate().mass_kg, before.mass_kg);
  EXPECT_STREQ(status_name(Status::method_not_built), "method_not_built");
}

}  // namespace
