// The benchmark's baselines (host_sim/bench/baselines.hpp) recover a simulated
// drive roughly, refuse a trace without motion, and the SVG plot writer
// draws what it is given. Kept short: the accuracy figures that matter are
// measured by `feedid bench` (docs/benchmarks.md), not asserted here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "bench/baselines.hpp"
#include "io/svg_plot.hpp"
#include "test_support.hpp"

namespace {

using feedid::host::BaselineOptions;
using feedid::host::BaselineResult;
using feedid::host::DriveParams;

const feedid::host::Trace& default_trace() {
  // GIVEN the default simulated drive (100 kg, 2 kHz), 20 s of strokes
  static const feedid::host::Trace tr = [] {
    feedid::test::SimSpec s;
    s.duration_s = 20.0;
    return feedid::test::simulate(s);
  }();
  return tr;
}

DriveParams truth() { return feedid::test::sim_config(feedid::test::SimSpec{}).drive; }

void expect_recovers(const BaselineResult& r, double max_error) {
  ASSERT_TRUE(r.ok) << r.method << ": " << r.status;
  int worst = 0;
  const double err = feedid::host::max_rel_error(r.params, truth(), &worst);
  EXPECT_LT(err, max_error) << r.method << ": worst parameter " << feedid::host::kParamNames[worst] << " off by "
                            << 100 * err << " %; " << r.status;
  EXPECT_GT(r.rows, 1000u);
  EXPECT_GT(r.seconds, 0.0);
}

TEST(Baselines, BatchLmRecoversTheDrive) {
  // WHEN Levenberg-Marquardt fits every moving sample
  const BaselineResult r = feedid::host::batch_lm(default_trace(), BaselineOptions{});
  // THEN it converges and every parameter is within 5 % (it measures about 1.5 %)
  EXPECT_TRUE(r.converged) << r.status;
  expect_recovers(r, 0.05);
  EXPECT_GT(feedid::host::friction_curve_r2(r.params, truth(), 4e-5, 0.15), 0.999);
}

TEST(Baselines, BatchLmFromTheNaiveStartAlsoConverges) {
  BaselineOptions o;
  o.lm_naive_start = true;
  const BaselineResult r = feedid::host::batch_lm(default_trace(), o);
  EXPECT_TRUE(r.converged) << r.status;
  expect_recovers(r, 0.05);
}

TEST(Baselines, StatedConventionsSkipTheSearchesForEveryMethod) {
  // GIVEN the bench's conditioning with the conventions stated (bench --stated-conventions)
  const feedid::host::IdentifyOptions searched = feedid::host::bench_identify_options(default_trace(), false);
  const feedid::host::IdentifyOptions stated = feedid::host::bench_identify_options(default_trace(), true);
  EXPECT_EQ(searched.velocity_filter_hz, 0.0);
  EXPECT_EQ(searched.alignment, "auto");
  EXPECT_NEAR(stated.velocity_filter_hz, 0.4 / std::sqrt(2.0) * 2000.0, 1e-6);
  EXPECT_EQ(stated.alignment, "held-backward");
  // WHEN identify and batch LM run on it
  const feedid::host::IdentifyResult a = feedid::host::identify(default_trace(), searched);
  const feedid::host::IdentifyResult b = feedid::host::identify(default_trace(), stated);
  BaselineOptions o;
  o.stated_conventions = true;
  const BaselineResult lm = feedid::host::batch_lm(default_trace(), o);
  // THEN identify makes fewer core passes (no lag or cut-off search) and still recovers the drive
  ASSERT_TRUE(a.error.empty() && b.error.empty()) << a.error << b.error;
  EXPECT_LT(b.core_passes + 3.0, a.core_passes);
  EXPECT_LT(feedid::host::max_rel_error(feedid::host::to_drive_params(b.estimate), truth()), 0.05);
  EXPECT_TRUE(lm.converged) << lm.status;
  expect_recovers(lm, 0.05);
}

TEST(Baselines, RlsRecoversTheDrive) {
  // WHEN the bank of RLS filters runs once over the stream
  const BaselineResult r = feedid::host::recursive_least_squares(default_trace(), BaselineOptions{});
  // THEN every parameter is within 5 % (mass is biased low by the noise of
  // the differenced velocity, about 1.5 %), with a fixed, small state
  expect_recovers(r, 0.05);
  EXPECT_GT(r.state_bytes, 0u);
  EXPECT_LT(r.state_bytes, 16u * 1024u);
}

TEST(Baselines, GeneticAlgorithmGetsCloseWithASmallBudget) {
  // WHEN differential evolution runs a small budget (24 x 61 evaluations)
  BaselineOptions o;
  o.ga_population = 24;
  o.ga_generations = 60;
  const BaselineResult r = feedid::host::genetic_algorithm(default_trace(), o);
  // THEN it is in the neighbourhood (the default bench budget does better)
  expect_recovers(r, 0.30);
  EXPECT_EQ(r.evaluations, 24 * 61);
  EXPECT_EQ(r.iterations, 60);
}

TEST(Baselines, TraceWithoutMotionIsRefused) {
  // GIVEN an axis that never moves
  feedid::host::Trace tr;
  for (int k = 0; k < 2000; ++k) tr.samples.push_back({k * 5e-4, 0.0, 0.0, 0.1 * std::sin(0.1 * k)});
  // THEN no baseline claims an estimate
  EXPECT_FALSE(feedid::host::batch_lm(tr, BaselineOptions{}).ok);
  BaselineOptions o;
  o.ga_generations = 2;
  EXPECT_FALSE(feedid::host::genetic_algorithm(tr, o).ok);
  EXPECT_FALSE(feedid::host::recursive_least_squares(tr, BaselineOptions{}).ok);
}

// One speed per direction: Coulomb and viscous friction are the same
// column, the linear start has no solution, and the baselines say so (they
// used to start from all-ones parameters).
TEST(Baselines, SingularStartIsReportedNotReplacedByOnes) {
  feedid::host::Trace tr;
  for (int k = 0; k < 8000; ++k) {
    // Two recordings 10 s apart, so that no smoothing of the derived
    // velocity makes a third speed out of the reversal; speeds in an
    // irrational ratio, so that their steps are not read as an encoder's.
    const double t = k * 1e-3 + (k < 4000 ? 0.0 : 10.0), v = k < 4000 ? 0.01 : -0.01 * std::sqrt(2.0);
    const double x = k < 4000 ? v * t : 0.04 + v * (t - 14.0);
    tr.samples.push_back({t, x, v, v > 0 ? 30.0 : -30.0});
  }
  for (const BaselineResult& r : {feedid::host::batch_lm(tr, BaselineOptions{}), feedid::host::genetic_algorithm(tr, BaselineOptions{})}) {
    EXPECT_FALSE(r.ok) << r.method;
    EXPECT_NE(r.status.find("singular"), std::string::npos) << r.method << ": " << r.status;
  }
}

TEST(Baselines, ErrorMeasures) {
  const DriveParams t = truth();
  EXPECT_EQ(feedid::host::max_rel_error(t, t), 0.0);
  EXPECT_NEAR(feedid::host::friction_curve_r2(t, t, 1e-4, 0.1), 1.0, 1e-12);
  DriveParams e = t;
  e.neg.stribeck_velocity_m_s *= 1.2;
  int worst = -1;
  EXPECT_NEAR(feedid::host::max_rel_error(e, t, &worst), 0.2, 1e-12);
  EXPECT_STREQ(feedid::host::kParamNames[worst], "vs-");
  EXPECT_LT(feedid::host::friction_curve_r2(e, t, 1e-4, 0.1), 1.0);
}

TEST(SvgPlot, DrawsSeriesAxesAndLegend) {
  feedid::host::PlotSpec p;
  p.title = "time <against> length";
  p.x = {"trace length (samples)", true};
  p.y = {"wall time (s)", true};
  feedid::host::PlotSeries a;
  a.label = "batch_lm";
  a.x = {1e4, 1e5, 1e6};
  a.y = {0.01, 0.1, 1.0};
  feedid::host::PlotSeries b;
  b.label = "with a gap";
  b.x = {1e4, 1e5, 1e6, 1e7};
  b.y = {1e-3, 0.0, 1e-2, 1e-1};  // 0 cannot be drawn on a log axis: the line breaks there
  p.series = {a, b};
  const std::string svg = feedid::host::render_svg(p);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_NE(svg.find("time &lt;against&gt; length"), std::string::npos);
  EXPECT_NE(svg.find("trace length (samples)"), std::string::npos);
  EXPECT_NE(svg.find("wall time (s)"), std::string::npos);
  EXPECT_NE(svg.find(">batch_lm<"), std::string::npos);
  EXPECT_NE(svg.find(">with a gap<"), std::string::npos);
  // Two paths; the second has two pieces (a move-to after the gap).
  std::size_t paths = 0, pos = 0;
  while ((pos = svg.find("<path d=\"", pos)) != std::string::npos) { ++paths; ++pos; }
  EXPECT_EQ(paths, 2u);
  const std::size_t second = svg.rfind("<path d=\"");
  const std::string d = svg.substr(second, svg.find('"', second + 9) - second);
  EXPECT_EQ(std::count(d.begin(), d.end(), 'M'), 2);
  // Decade ticks 10^-3 .. 10^0 on y, 10^4 .. 10^7 on x.
  EXPECT_NE(svg.find(">-3</tspan>"), std::string::npos);
  EXPECT_NE(svg.find(">7</tspan>"), std::string::npos);
}

TEST(SvgPlot, LinearAxesAndEmptyPlot) {
  feedid::host::PlotSpec p;
  p.x = {"speed (m/s)", false};
  p.y = {"friction (N)", false};
  // No series at all still gives a valid document with a frame.
  std::string svg = feedid::host::render_svg(p);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  feedid::host::PlotSeries s;
  s.label = "F(v)";
  s.x = {-0.1, 0.0, 0.1};
  s.y = {-95.0, 0.0, 95.0};
  p.series = {s};
  svg = feedid::host::render_svg(p);
  EXPECT_NE(svg.find(">-100<"), std::string::npos);  // nice ticks cover the data
  EXPECT_NE(svg.find(">100<"), std::string::npos);
}

}  // namespace
