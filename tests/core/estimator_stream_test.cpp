// The estimator as a stream: float against double over an hour of data,
// section detection, rejection of bad samples, config checks, memory
// budget and the from_position velocity source.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <future>
#include <limits>
#include <memory>
#include <ostream>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "feedid/footprint_budget.hpp"
#include "test_support.hpp"

namespace {

using namespace feedid;
using feedid::test::rel_err;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------
// (1) float against double, one hour at 4 kHz
// ---------------------------------------------------------------------------

TEST(Stream, FloatMatchesDoubleOverOneHourAt4kHz) {
  // GIVEN one hour of a 100 kg drive at 4 kHz (14.4 M samples): 60 simulated
  // minutes with different seeds, back to back, each joined to the previous
  // one by a 1 s step (a continuity break: the minutes start at rest at x=0)
  const int minutes = 60;
  // (5 RK4 substeps per 4 kHz period instead of 20: the plant is still
  // integrated at 20 kHz, the estimates move by < 0.3 %, the test runs 3.5x faster)
  auto minute = [](int i) {
    test::SimSpec s;
    s.mass_kg = 100.0;
    s.rate_hz = 4000.0;
    s.seed = 1000 + static_cast<std::uint64_t>(i);
    s.duration_s = 60.0;
    host::SimConfig c = test::sim_config(s);
    c.plant_substeps = 5;
    return host::simulate(c);
  };
  const host::SimConfig sc = test::sim_config(test::SimSpec{100.0, 4000.0});
  auto est_f = std::make_unique<Estimator<float>>();
  auto est_d = std::make_unique<Estimator<double>>();
  ASSERT_EQ(est_f->init(test::default_config<float>(sc)), Status::ok);
  ASSERT_EQ(est_d->init(test::default_config<double>(sc)), Status::ok);
  // WHEN every minute is pushed through both estimators as it is produced
  // (two minutes simulated at a time, one per core; never more in memory)
  std::size_t samples = 0, rejected_f = 0, rejected_d = 0;
  for (int i = 0; i < minutes; i += 2) {
    std::future<host::Trace> second = std::async(std::launch::async, minute, i + 1);
    host::Trace a = minute(i);
    host::Trace b = second.get();
    for (const host::Trace* tr : {&a, &b}) {
      const double first_dt = samples == 0 ? 0.0 : 1.0;
      const test::PushCounts nf = test::push_trace(*est_f, *tr, first_dt);
      const test::PushCounts nd = test::push_trace(*est_d, *tr, first_dt);
      rejected_f += nf.rejected;
      rejected_d += nd.rejected;
      samples += tr->samples.size();
    }
  }
  ASSERT_EQ(samples, static_cast<std::size_t>(minutes) * 240001u);
  EXPECT_EQ(rejected_f, 0u);
  EXPECT_EQ(rejected_d, 0u);
  EXPECT_EQ(est_d->diagnostics().continuity_breaks, static_cast<std::uint32_t>(minutes - 1));
  ASSERT_EQ(est_f->solve(), Status::ok);
  ASSERT_EQ(est_d->solve(), Status::ok);
  const Estimate<float>& f = est_f->estimate();
  const Estimate<double>& d = est_d->estimate();
  std::printf("  mass float %.6f double %.6f (truth %.1f)\n", double(f.mass_kg), d.mass_kg, sc.drive.mass_kg);
  for (int k = 0; k < 2; ++k) {
    const DirectionEstimate<float>& ef = k == 0 ? f.pos : f.neg;
    const DirectionEstimate<double>& ed = k == 0 ? d.pos : d.neg;
    std::printf("  %s float/double: sigma %.4f/%.4f Fc %.5f/%.5f Fs %.5f/%.5f vs %.6g/%.6g flags %x/%x\n",
                k == 0 ? "pos" : "neg", double(ef.viscous_Ns_m), ed.viscous_Ns_m, double(ef.coulomb_N),
                ed.coulomb_N, double(ef.breakaway_N), ed.breakaway_N, double(ef.stribeck_velocity_m_s),
                ed.stribeck_velocity_m_s, ef.flags, ed.flags);
  }
  // THEN float agrees with double: mass, sigma, Fc within 0.5 %; Fs, vs within 2 %
  EXPECT_LT(rel_err(f.mass_kg, d.mass_kg), 0.005);
  EXPECT_EQ(f.mass_flags, d.mass_flags);
  for (int k = 0; k < 2; ++k) {
    const DirectionEstimate<float>& ef = k == 0 ? f.pos : f.neg;
    const DirectionEstimate<double>& ed = k == 0 ? d.pos : d.neg;
    const char* dir = k == 0 ? "pos" : "neg";
    EXPECT_LT(rel_err(ef.viscous_Ns_m, ed.viscous_Ns_m), 0.005) << dir;
    EXPECT_LT(rel_err(ef.coulomb_N, ed.coulomb_N), 0.005) << dir;
    EXPECT_LT(rel_err(ef.breakaway_N, ed.breakaway_N), 0.02) << dir;
    EXPECT_LT(rel_err(ef.stribeck_velocity_m_s, ed.stribeck_velocity_m_s), 0.02) << dir;
    EXPECT_EQ(ef.flags, ed.flags) << dir;
  }
  // AND the double estimate is still accurate against the truth
  EXPECT_LT(rel_err(d.mass_kg, sc.drive.mass_kg), 0.01);
  EXPECT_EQ(d.mass_flags, 0u);
  for (int k = 0; k < 2; ++k) {
    const DirectionEstimate<double>& ed = k == 0 ? d.pos : d.neg;
    const host::DirectionFriction& t = k == 0 ? sc.drive.pos : sc.drive.neg;
    const char* dir = k == 0 ? "pos" : "neg";
    EXPECT_EQ(ed.flags, 0u) << dir;
    EXPECT_LT(rel_err(ed.viscous_Ns_m, t.viscous_Ns_m), 0.01) << dir;
    EXPECT_LT(rel_err(ed.coulomb_N, t.coulomb_N), 0.01) << dir;
    EXPECT_LT(rel_err(ed.breakaway_N, t.breakaway_N), 0.03) << dir;
    EXPECT_LT(rel_err(ed.stribeck_velocity_m_s, t.stribeck_velocity_m_s), 0.03) << dir;
  }
}

// ---------------------------------------------------------------------------
// (2) section detection
// ---------------------------------------------------------------------------

// solve() never publishes a non-finite number: force readings that are
// finite one by one and inside a configured max_force_N but overflow the sums
// give numerical_error, and the last good estimate stays (the status had been
// documented and never returned).
TEST(Stream, OverflowingSumsGiveNumericalErrorAndKeepTheLastEstimate) {
  test::SimSpec spec;
  spec.duration_s = 30.0;
  const host::SimConfig sc = test::sim_config(spec);
  const host::Trace tr = host::simulate(sc);
  auto est = std::make_unique<Estimator<double>>();
  Config<double> cfg = test::default_config<double>(sc);
  cfg.max_force_N = 1e307;  // the input gate would reject such readings at the default 1e6 N
  ASSERT_EQ(est->init(cfg), Status::ok);
  test::push_trace(*est, tr);
  ASSERT_EQ(est->solve(), Status::ok);
  const double good_mass = est->estimate().mass_kg;
  host::Trace huge = tr;
  for (auto& x : huge.samples) x.u_N = 1e306;
  test::push_trace(*est, huge, 1.0 / sc.controller.servo_rate_hz);
  EXPECT_EQ(est->solve(), Status::numerical_error);
  EXPECT_EQ(est->estimate().mass_kg, good_mass);
}

TEST(Stream, RestJitterOpensNoSections) {
  // GIVEN 30 s of velocity jitter of up to +-3 quanta around zero and random
  // force (sections open at 2 * velocity_min = 4 quanta)
  const double rate = 1000.0, quantum = 1e-5;
  const host::Trace tr = test::rest_jitter_trace(rate, quantum, 3, 5.0, 30.0, 5);
  auto est = std::make_unique<Estimator<double>>();
  ASSERT_EQ(est->init(test::default_config<double>(1e-8, rate)), Status::ok);
  // WHEN it is streamed
  const test::PushCounts n = test::push_trace(*est, tr);
  // THEN every sample is accepted and no section is ever opened
  EXPECT_EQ(n.rejected, 0u);
  const Diagnostics& g = est->diagnostics();
  EXPECT_EQ(g.sections_complete[0], 0u);
  EXPECT_EQ(g.sections_complete[1], 0u);
  EXPECT_EQ(g.sections_short, 0u);
  EXPECT_EQ(g.sections_split, 0u);
}

TEST(Stream, JitterOneQuantumAboveEntryDoesOpenSections) {
  // GIVEN the same jitter reaching 5 quanta, above the 4-quantum entry level
  // (so the test above is not passing for lack of motion detection)
  const double rate = 1000.0, quantum = 1e-5;
  const host::Trace tr = test::rest_jitter_trace(rate, quantum, 5, 5.0, 30.0, 5);
  auto est = std::make_unique<Estimator<double>>();
  ASSERT_EQ(est->init(test::default_config<double>(1e-8, rate)), Status::ok);
  test::push_trace(*est, tr);
  // THEN sections (short ones at least) are opened
  const Diagnostics& g = est->diagnostics();
  EXPECT_GT(g.sections_short + g.sections_complete[0] + g.sections_complete[1], 0u);
}

/// Strokes of the simulator's reciprocating reference (drive_sim.hpp) whose
/// motion ends before the trace does: [positive, negative]. Each speed level
/// gives one positive then one negative trapezoid stroke (cruise shortened to
/// the travel limit) followed by a dwell; the level list repeats.
std::pair<int, int> complete_strokes(const host::MotionParams& m) {
  std::vector<double> speeds;
  for (int i = 0; i < m.speed_levels; ++i)
    speeds.push_back(m.speed_levels == 1 ? m.fastest_speed_m_s
                                         : m.slowest_speed_m_s * std::pow(m.fastest_speed_m_s / m.slowest_speed_m_s,
                                                                          double(i) / (m.speed_levels - 1)));
  int counts[2] = {0, 0};
  double t = 0.0;
  for (std::size_t k = 0;; ++k) {
    double V = speeds[(k / 2) % speeds.size()];
    const double A = m.acceleration_m_s2;
    double cruise = V * m.cruise_time_s;
    if (V * V / A + cruise > m.max_travel_m) {
      cruise = m.max_travel_m - V * V / A;
      if (cruise < 0.0) { V = std::sqrt(A * m.max_travel_m); cruise = 0.0; }
    }
    const double moving = 2.0 * V / A + cruise / V;
    if (t + moving >= m.duration_s) break;
    ++counts[k % 2];
    t += moving + m.dwell_s;
  }
  return {counts[0], counts[1]};
}

// solve() on target runs periodically while samples keep arriving. It folds
// and splits the section open at that moment (docs/reference.md, "solve()
// while moving"): that one section no longer counts for the paper method,
// and nothing else changes.
TEST(Stream, PeriodicSolveSplitsOnlyTheOpenSectionAndKeepsTheBandsEstimate) {
  // GIVEN 60 s of the default drive streamed twice, once solved every 5 s on the way
  test::SimSpec spec;
  spec.rate_hz = 4000.0;
  const host::SimConfig sc = test::sim_config(spec);
  const host::Trace tr = host::simulate(sc);
  auto once = std::make_unique<Estimator<double>>(), periodic = std::make_unique<Estimator<double>>();
  ASSERT_EQ(once->init(test::default_config<double>(sc)), Status::ok);
  ASSERT_EQ(periodic->init(test::default_config<double>(sc)), Status::ok);
  const std::size_t every = static_cast<std::size_t>(5.0 * spec.rate_hz);
  unsigned mid_solves = 0;
  for (std::size_t k = 0; k < tr.samples.size(); ++k) {
    const double dt = k == 0 ? 0.0 : tr.samples[k].t_s - tr.samples[k - 1].t_s;
    (void)once->push(test::to_sample<double>(tr.samples[k], dt));
    (void)periodic->push(test::to_sample<double>(tr.samples[k], dt));
    if (k > 0 && k % every == 0) {
      EXPECT_EQ(periodic->solve(), Status::ok) << "mid-stream solve at sample " << k;
      ++mid_solves;
    }
  }
  ASSERT_EQ(once->solve(), Status::ok);
  ASSERT_EQ(periodic->solve(), Status::ok);
  // THEN at most one section per mid-stream solve is split and lost to the paper method
  const Diagnostics& a = once->diagnostics();
  const Diagnostics& b = periodic->diagnostics();
  EXPECT_GE(b.sections_split, a.sections_split);
  EXPECT_LE(b.sections_split, a.sections_split + mid_solves);
  const unsigned complete_a = a.sections_complete[0] + a.sections_complete[1];
  const unsigned complete_b = b.sections_complete[0] + b.sections_complete[1];
  EXPECT_LE(complete_b, complete_a);
  EXPECT_GE(complete_b + mid_solves, complete_a);
  EXPECT_GT(complete_b, 20u) << "the paper method keeps the sections no solve fell into";
  // AND the bands estimate is the same (the bands do not need whole sections)
  const Estimate<double>& ea = once->estimate();
  const Estimate<double>& eb = periodic->estimate();
  EXPECT_NEAR(eb.mass_kg, ea.mass_kg, 1e-3 * ea.mass_kg);
  EXPECT_NEAR(eb.pos.coulomb_N, ea.pos.coulomb_N, 1e-3 * ea.pos.coulomb_N);
  EXPECT_NEAR(eb.neg.viscous_Ns_m, ea.neg.viscous_Ns_m, 1e-3 * ea.neg.viscous_Ns_m);
  // AND the paper method still solves on what is left
  EXPECT_EQ(periodic->solve(Method::paper), Status::ok);
}

struct SectionCase {
  double mass_kg, rate_hz;
};

void PrintTo(const SectionCase& c, std::ostream* os) { *os << c.mass_kg << " kg, " << c.rate_hz << " Hz"; }

class SectionCount : public ::testing::TestWithParam<SectionCase> {};

// Cases where the closed loop settles without reverse excursions. (At 1 kHz
// the 100 and 400 kg drives overshoot each stop by ~2e-4 m/s for a few ms and
// creep back over ~20 ms: real rest-to-rest motions above the entry speed,
// which the detector rightly counts as extra sections.)
TEST_P(SectionCount, OneSectionPerStroke) {
  // GIVEN the reciprocating simulation of 60 s
  test::SimSpec spec;
  spec.mass_kg = GetParam().mass_kg;
  spec.rate_hz = GetParam().rate_hz;
  const host::SimConfig sc = test::sim_config(spec);
  const auto [pos, neg] = complete_strokes(sc.motion);
  ASSERT_GT(pos, 30);  // sanity of the stroke count itself
  ASSERT_GT(neg, 30);
  // WHEN it is streamed
  auto est = std::make_unique<Estimator<double>>();
  ASSERT_EQ(est->init(test::default_config<double>(sc)), Status::ok);
  test::push_trace(*est, host::simulate(sc));
  // THEN each direction has one complete section per stroke (+-2 for the end)
  const Diagnostics& g = est->diagnostics();
  std::printf("  strokes %d/%d, sections %u/%u, short %u\n", pos, neg, g.sections_complete[0],
              g.sections_complete[1], g.sections_short);
  EXPECT_NEAR(double(g.sections_complete[0]), pos, 2.0);
  EXPECT_NEAR(double(g.sections_complete[1]), neg, 2.0);
}

INSTANTIATE_TEST_SUITE_P(Drives, SectionCount,
                         ::testing::Values(SectionCase{20, 1000}, SectionCase{20, 4000}, SectionCase{100, 4000},
                                           SectionCase{400, 4000}),
                         [](const ::testing::TestParamInfo<SectionCase>& i) {
                           return "m" + std::to_string(int(i.param.mass_kg)) + "_" +
                                  std::to_string(int(i.param.rate_hz)) + "Hz";
                         });

// ---------------------------------------------------------------------------
// (3) bad samples
// ---------------------------------------------------------------------------

using Est = Estimator<double>;
using Stats = Est::Stats;

std::vector<unsigned char> bytes_of(const Stats& s) {
  std::vector<unsigned char> b(sizeof s);
  std::memcpy(b.data(), &s, sizeof s);
  return b;
}

/// Diagnostics counter that a rejection status increments.
std::uint64_t counter_for(const Diagnostics& g, Status s) {
  switch (s) {
    case Status::rejected_not_finite: return g.rejected_not_finite;
    case Status::rejected_time_not_increasing: return g.rejected_time_not_increasing;
    case Status::rejected_out_of_range: return g.rejected_out_of_range;
    case Status::rejected_velocity_jump: return g.rejected_velocity_jump;
    default: return ~0ull;
  }
}

struct BadSample {
  const char* name;
  Status expected;
  // Corrupts the sample (dt_s already set from the trace).
  void (*corrupt)(Sample<double>& s, double v_prev);
};

const BadSample kBadSamples[] = {
    {"nan_velocity", Status::rejected_not_finite, [](Sample<double>& s, double) { s.velocity_m_s = kNaN; }},
    {"inf_velocity", Status::rejected_not_finite, [](Sample<double>& s, double) { s.velocity_m_s = -kInf; }},
    {"nan_force", Status::rejected_not_finite, [](Sample<double>& s, double) { s.force_N = kNaN; }},
    {"inf_force", Status::rejected_not_finite, [](Sample<double>& s, double) { s.force_N = kInf; }},
    {"nan_dt", Status::rejected_not_finite, [](Sample<double>& s, double) { s.dt_s = kNaN; }},
    {"inf_dt", Status::rejected_not_finite, [](Sample<double>& s, double) { s.dt_s = kInf; }},
    {"zero_dt", Status::rejected_time_not_increasing, [](Sample<double>& s, double) { s.dt_s = 0.0; }},
    {"negative_dt", Status::rejected_time_not_increasing, [](Sample<double>& s, double) { s.dt_s = -1e-3; }},
    {"speed_above_max", Status::rejected_out_of_range, [](Sample<double>& s, double) { s.velocity_m_s = -25.0; }},
    {"force_above_max", Status::rejected_out_of_range, [](Sample<double>& s, double) { s.force_N = 2e6; }},
    {"velocity_jump", Status::rejected_velocity_jump,
     [](Sample<double>& s, double v_prev) { s.velocity_m_s = v_prev + 1.0; }},
};

void PrintTo(const BadSample& b, std::ostream* os) { *os << b.name; }

class BadSamples : public ::testing::TestWithParam<BadSample> {
 protected:
  static const host::Trace& trace() {
    static const host::Trace tr = test::simulate(test::SimSpec{100.0, 1000.0, 1, 1e-8, 0.5, 20.0});
    return tr;
  }
  static std::size_t moving_index() {  // first sample after 5 s with |v| > 1 mm/s
    const host::Trace& tr = trace();
    for (std::size_t k = 0; k < tr.samples.size(); ++k)
      if (tr.samples[k].t_s > 5.0 && std::fabs(tr.samples[k].v_m_s) > 1e-3) return k;
    return 0;
  }
  static Sample<double> sample(std::size_t k) {
    const host::Trace& tr = trace();
    return test::to_sample<double>(tr.samples[k], k == 0 ? 0.0 : tr.samples[k].t_s - tr.samples[k - 1].t_s);
  }
  static Config<double> config() { return test::default_config<double>(1e-8, 1000.0); }
};

TEST_P(BadSamples, RejectedWithItsStatusAndChangesNothing) {
  const BadSample& bad = GetParam();
  const host::Trace& tr = trace();
  const std::size_t k0 = moving_index();
  ASSERT_GT(k0, 0u);
  // GIVEN an estimator that has taken the stream up to a sample in motion
  auto a = std::make_unique<Est>();
  ASSERT_EQ(a->init(config()), Status::ok);
  for (std::size_t k = 0; k < k0; ++k) ASSERT_EQ(a->push(sample(k)), Status::ok);
  const std::vector<unsigned char> stats_before = bytes_of(a->statistics());
  const Diagnostics diag_before = a->diagnostics();
  // WHEN sample k0 arrives corrupted
  Sample<double> s = sample(k0);
  bad.corrupt(s, tr.samples[k0 - 1].v_m_s);
  const Status st = a->push(s);
  // THEN it is rejected with its own status
  EXPECT_EQ(st, bad.expected) << status_name(st);
  // AND exactly its counter and the rejection total went up by one
  const Diagnostics& g = a->diagnostics();
  EXPECT_EQ(g.samples_rejected, diag_before.samples_rejected + 1);
  EXPECT_EQ(g.samples_accepted, diag_before.samples_accepted);
  for (Status c : {Status::rejected_not_finite, Status::rejected_time_not_increasing, Status::rejected_out_of_range,
                   Status::rejected_velocity_jump})
    EXPECT_EQ(counter_for(g, c), counter_for(diag_before, c) + (c == bad.expected ? 1 : 0)) << status_name(c);
  // AND the statistics are byte for byte what they were
  EXPECT_EQ(bytes_of(a->statistics()), stats_before);

  // AND the rest of the stream ends exactly as if sample k0 had never been
  // sent, its time (when it had a valid one) added to the next step, else
  // the chain restarted there
  auto b = std::make_unique<Est>();
  ASSERT_EQ(b->init(config()), Status::ok);
  for (std::size_t k = 0; k < k0; ++k) ASSERT_EQ(b->push(sample(k)), Status::ok);
  const bool time_kept = std::isfinite(s.dt_s) && s.dt_s > 0.0;
  for (std::size_t k = k0 + 1; k < tr.samples.size(); ++k) {
    ASSERT_EQ(a->push(sample(k)), Status::ok) << k;
    Sample<double> sb = sample(k);
    // The same sum the estimator forms; with the rejected sample's time
    // unknown (NaN/Inf dt) no integral may span it: a restart, as after a gap.
    if (k == k0 + 1 && time_kept) sb.dt_s += s.dt_s;
    if (k == k0 + 1 && !std::isfinite(s.dt_s)) sb.dt_s = 1e3;
    ASSERT_EQ(b->push(sb), Status::ok) << k;
  }
  ASSERT_EQ(a->solve(), Status::ok);
  ASSERT_EQ(b->solve(), Status::ok);
  EXPECT_EQ(bytes_of(a->statistics()), bytes_of(b->statistics()));
  EXPECT_EQ(a->estimate().mass_kg, b->estimate().mass_kg);
  EXPECT_EQ(a->estimate().pos.coulomb_N, b->estimate().pos.coulomb_N);
  EXPECT_EQ(a->estimate().neg.stribeck_velocity_m_s, b->estimate().neg.stribeck_velocity_m_s);
}

INSTANTIATE_TEST_SUITE_P(Kinds, BadSamples, ::testing::ValuesIn(kBadSamples),
                         [](const ::testing::TestParamInfo<BadSample>& i) { return std::string(i.param.name); });

/// Streams a 60 s simulation twice: as is, and with 1 % of the samples
/// (chosen at random, never the first) corrupted by `corrupt`. Returns the
/// number of corrupted samples; checks each was rejected as not finite.
template <typename Corrupt>
std::size_t stream_clean_and_corrupted(Est& clean, Est& dirty, Corrupt corrupt) {
  const host::SimConfig sc = test::sim_config(test::SimSpec{100.0, 1000.0, 3});
  const host::Trace tr = host::simulate(sc);
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const Config<double> cfg = test::default_config<double>(sc);
  EXPECT_EQ(clean.init(cfg), Status::ok);
  EXPECT_EQ(dirty.init(cfg), Status::ok);
  std::size_t corrupted = 0, rejected = 0;
  for (std::size_t k = 0; k < tr.samples.size(); ++k) {
    const double dt = k == 0 ? 0.0 : tr.samples[k].t_s - tr.samples[k - 1].t_s;
    const Sample<double> s = test::to_sample<double>(tr.samples[k], dt);
    EXPECT_EQ(clean.push(s), Status::ok);
    Sample<double> d = s;
    if (k > 0 && u01(rng) < 0.01) {
      ++corrupted;
      corrupt(d, rng);
    }
    if (dirty.push(d) != Status::ok) ++rejected;
  }
  EXPECT_EQ(rejected, corrupted);
  EXPECT_EQ(dirty.diagnostics().rejected_not_finite, corrupted);
  EXPECT_GT(corrupted, tr.samples.size() / 200);  // about 1 %, at least 0.5 %
  EXPECT_LT(corrupted, tr.samples.size() / 50);
  EXPECT_EQ(clean.solve(), Status::ok);
  EXPECT_EQ(dirty.solve(), Status::ok);
  return corrupted;
}

void expect_estimates_close(const Estimate<double>& d, const Estimate<double>& c, double tol) {
  std::printf("  mass %+.4f%%\n", 100 * (d.mass_kg / c.mass_kg - 1));
  EXPECT_LT(rel_err(d.mass_kg, c.mass_kg), tol) << "mass " << d.mass_kg << " vs " << c.mass_kg;
  EXPECT_EQ(d.mass_flags, c.mass_flags);
  for (int k = 0; k < 2; ++k) {
    const DirectionEstimate<double>& ec = k == 0 ? c.pos : c.neg;
    const DirectionEstimate<double>& ed = k == 0 ? d.pos : d.neg;
    const char* dir = k == 0 ? "pos" : "neg";
    std::printf("  %s: sigma %+.4f%% Fc %+.4f%% Fs %+.4f%% vs %+.4f%%\n", dir,
                100 * (ed.viscous_Ns_m / ec.viscous_Ns_m - 1), 100 * (ed.coulomb_N / ec.coulomb_N - 1),
                100 * (ed.breakaway_N / ec.breakaway_N - 1),
                100 * (ed.stribeck_velocity_m_s / ec.stribeck_velocity_m_s - 1));
    EXPECT_LT(rel_err(ed.viscous_Ns_m, ec.viscous_Ns_m), tol) << dir;
    EXPECT_LT(rel_err(ed.coulomb_N, ec.coulomb_N), tol) << dir;
    EXPECT_LT(rel_err(ed.breakaway_N, ec.breakaway_N), tol) << dir;
    EXPECT_LT(rel_err(ed.stribeck_velocity_m_s, ec.stribeck_velocity_m_s), tol) << dir;
    EXPECT_EQ(ed.flags, ec.flags) << dir;
  }
}

TEST(Stream, OnePercentNaNReadingsBarelyMoveTheEstimate) {
  // GIVEN a 60 s stream, and a copy in which 1 % of the samples have a NaN
  // velocity or force reading (the servo clock, hence dt, stays valid)
  auto clean = std::make_unique<Est>();
  auto dirty = std::make_unique<Est>();
  // WHEN both are streamed and solved
  stream_clean_and_corrupted(*clean, *dirty, [](Sample<double>& d, std::mt19937_64& rng) {
    if (std::uniform_int_distribution<int>(0, 1)(rng) == 0) d.velocity_m_s = kNaN;
    else d.force_N = kNaN;
  });
  // THEN every parameter is within 0.5 % of the clean stream's
  expect_estimates_close(dirty->estimate(), clean->estimate(), 0.005);
}

// Core issue (reported): when a rejected sample's dt is not finite, its time
// is dropped, and the next good sample's interval (dt of one period) is used
// for a velocity change and a force that span two periods. With 1 % of
// samples wholly NaN (dt included) the mass comes out 1.4 % low (0.9-1.4 %
// over three seeds when only dt is NaN), against 0.1 % when only velocity or
// force is NaN. Bridging a sample of unknown duration would need a
// continuity break instead.
TEST(StreamBadSamples, OnePercentWhollyNaNSamplesBarelyMoveTheEstimate) {
  auto clean = std::make_unique<Est>();
  auto dirty = std::make_unique<Est>();
  stream_clean_and_corrupted(*clean, *dirty, [](Sample<double>& d, std::mt19937_64&) {
    d.dt_s = d.velocity_m_s = d.position_m = d.force_N = kNaN;
  });
  expect_estimates_close(dirty->estimate(), clean->estimate(), 0.005);
}

// ---------------------------------------------------------------------------
// (4) configuration checks
// ---------------------------------------------------------------------------

struct BadConfig {
  const char* name;
  const char* field;  ///< expected in config_error()
  void (*corrupt)(Config<double>& c);
};

const BadConfig kBadConfigs[] = {
    {"velocity_min_zero", "velocity_min_m_s", [](Config<double>& c) { c.velocity_min_m_s = 0.0; }},
    {"velocity_min_negative", "velocity_min_m_s", [](Config<double>& c) { c.velocity_min_m_s = -1e-4; }},
    {"velocity_min_nan", "velocity_min_m_s", [](Config<double>& c) { c.velocity_min_m_s = kNaN; }},
    {"velocity_min_inf", "velocity_min_m_s", [](Config<double>& c) { c.velocity_min_m_s = kInf; }},
    {"velocity_max_nan", "velocity_max_m_s", [](Config<double>& c) { c.velocity_max_m_s = kNaN; }},
    {"velocity_max_below_4_min", "velocity_max_m_s",
     [](Config<double>& c) { c.velocity_max_m_s = 3.9 * c.velocity_min_m_s; }},
    {"velocity_max_equal_4_min", "velocity_max_m_s",
     [](Config<double>& c) { c.velocity_max_m_s = 4.0 * c.velocity_min_m_s; }},
    {"resolution_negative", "velocity_resolution_m_s", [](Config<double>& c) { c.velocity_resolution_m_s = -1e-5; }},
    {"resolution_nan", "velocity_resolution_m_s", [](Config<double>& c) { c.velocity_resolution_m_s = kNaN; }},
    {"section_enter_nan", "section_enter_m_s", [](Config<double>& c) { c.section_enter_m_s = kNaN; }},
    {"rest_samples_zero", "rest_samples", [](Config<double>& c) { c.rest_samples = 0; }},
    {"min_section_negative", "min_section_s", [](Config<double>& c) { c.min_section_s = -0.01; }},
    {"max_fold_zero", "max_fold_s", [](Config<double>& c) { c.max_fold_s = 0.0; }},
    {"mass_window_nan", "mass_window_s", [](Config<double>& c) { c.mass_window_s = kNaN; }},
    {"max_acceleration_negative", "max_acceleration_m_s2", [](Config<double>& c) { c.max_acceleration_m_s2 = -1.0; }},
    {"max_speed_zero", "max_speed_m_s", [](Config<double>& c) { c.max_speed_m_s = 0.0; }},
    {"max_force_inf", "max_force_N", [](Config<double>& c) { c.max_force_N = kInf; }},
    {"max_gap_zero", "max_gap_s", [](Config<double>& c) { c.max_gap_s = 0.0; }},
    {"max_step_ratio_zero", "max_step_speed_ratio", [](Config<double>& c) { c.max_step_speed_ratio = 0.0; }},
    {"stribeck_min_negative", "stribeck_min", [](Config<double>& c) { c.stribeck_min_m_s = -1e-3; }},
    {"stribeck_range_inverted", "stribeck_max_m_s",
     [](Config<double>& c) {
       c.stribeck_min_m_s = 1e-2;
       c.stribeck_max_m_s = 1e-3;
     }},
    {"stribeck_range_too_narrow", "stribeck_max_m_s",
     [](Config<double>& c) {
       c.stribeck_min_m_s = 1e-3;
       c.stribeck_max_m_s = 1.5e-3;
     }},
    {"stribeck_min_above_default_max", "stribeck_max_m_s",
     [](Config<double>& c) { c.stribeck_min_m_s = 0.5 * c.velocity_max_m_s; }},
    {"vs_iterations_zero", "max_vs_iterations", [](Config<double>& c) { c.max_vs_iterations = 0; }},
    {"vs_iterations_too_many", "max_vs_iterations", [](Config<double>& c) { c.max_vs_iterations = 201; }},
    {"velocity_source_unknown", "velocity_source",
     [](Config<double>& c) { c.velocity_source = static_cast<VelocitySource>(7); }},
    {"force_lag_positive", "force_lag_samples",
     [](Config<double>& c) { c.force_lag_samples = 0.5; }},
    {"force_lag_beyond_history", "force_lag_samples",
     [](Config<double>& c) { c.force_lag_samples = -5.5; }},
    {"force_lag_nan", "force_lag_samples",
     [](Config<double>& c) { c.force_lag_samples = std::numeric_limits<double>::quiet_NaN(); }},
};

void PrintTo(const BadConfig& b, std::ostream* os) { *os << b.name; }

class InitRejects : public ::testing::TestWithParam<BadConfig> {};

TEST_P(InitRejects, InvalidConfigNamesTheFieldAndLeavesEstimatorUnusable) {
  const BadConfig& bad = GetParam();
  // GIVEN an estimator that was working with a valid config
  auto est = std::make_unique<Est>();
  Config<double> cfg = test::default_config<double>(1e-8, 1000.0);
  ASSERT_EQ(est->init(cfg), Status::ok);
  EXPECT_EQ(est->config_error(), nullptr);
  ASSERT_EQ(est->push(Sample<double>{}), Status::ok);
  // WHEN it is re-initialised with one bad field
  bad.corrupt(cfg);
  // THEN init says invalid_config and names the field
  EXPECT_EQ(est->init(cfg), Status::invalid_config);
  ASSERT_NE(est->config_error(), nullptr);
  EXPECT_NE(std::string(est->config_error()).find(bad.field), std::string::npos) << est->config_error();
  // AND push and solve refuse to work
  Sample<double> s;
  s.dt_s = 1e-3;
  EXPECT_EQ(est->push(s), Status::not_initialized);
  EXPECT_EQ(est->solve(), Status::not_initialized);
  EXPECT_EQ(est->diagnostics().samples_accepted, 0u);
}

INSTANTIATE_TEST_SUITE_P(Fields, InitRejects, ::testing::ValuesIn(kBadConfigs),
                         [](const ::testing::TestParamInfo<BadConfig>& i) { return std::string(i.param.name); });

TEST(Init, FloatConfigWithNaNIsRejected) {
  auto est = std::make_unique<Estimator<float>>();
  Config<float> cfg = test::default_config<float>(1e-8, 1000.0);
  cfg.velocity_min_m_s = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(est->init(cfg), Status::invalid_config);
  EXPECT_NE(est->config_error(), nullptr);
}

TEST(Init, DefaultAndTestConfigsAreValid) {
  auto est = std::make_unique<Est>();
  EXPECT_EQ(est->init(Config<double>{}), Status::ok) << est->config_error();
  EXPECT_EQ(est->init(test::default_config<double>(1e-7, 1000.0)), Status::ok) << est->config_error();
  Config<double> edge = test::default_config<double>(1e-8, 1000.0);
  edge.velocity_max_m_s = 4.001 * edge.velocity_min_m_s;  // just above the limit
  EXPECT_EQ(est->init(edge), Status::ok) << est->config_error();
  EXPECT_EQ(est->config_error(), nullptr);
}

TEST(Init, PushAndSolveBeforeInitAreNotInitialized) {
  // GIVEN a fresh estimator, never initialised
  auto est = std::make_unique<Est>();
  Sample<double> s;
  s.dt_s = 1e-3;
  s.velocity_m_s = 0.01;
  // WHEN used  THEN every call says so, and nothing is counted
  EXPECT_EQ(est->push(s), Status::not_initialized);
  EXPECT_EQ(est->solve(), Status::not_initialized);
  EXPECT_EQ(est->solve(Method::paper), Status::not_initialized);
  EXPECT_EQ(est->diagnostics().samples_accepted, 0u);
  EXPECT_EQ(est->diagnostics().samples_rejected, 0u);
  // AND after a good init the same sample is taken
  ASSERT_EQ(est->init(test::default_config<double>(1e-8, 1000.0)), Status::ok);
  EXPECT_EQ(est->push(s), Status::ok);
}

// ---------------------------------------------------------------------------
// (5) memory budget
// ---------------------------------------------------------------------------

constexpr std::size_t kFirmwareRamBudget = feedid::fw::estimator_float_ram_budget;
static_assert(sizeof(feedid::Estimator<float>) <= kFirmwareRamBudget,
              "Estimator<float> exceeds the 8 KiB firmware RAM budget");

TEST(Memory, FloatEstimatorFitsFirmwareBudget) {
  std::printf("  sizeof(Estimator<float>) = %zu bytes, sizeof(Estimator<double>) = %zu bytes\n",
              sizeof(Estimator<float>), sizeof(Estimator<double>));
  RecordProperty("sizeof_estimator_float", static_cast<int>(sizeof(Estimator<float>)));
  RecordProperty("sizeof_estimator_double", static_cast<int>(sizeof(Estimator<double>)));
  EXPECT_LE(sizeof(Estimator<float>), kFirmwareRamBudget);
}

// ---------------------------------------------------------------------------
// (6) velocity from position
// ---------------------------------------------------------------------------

TEST(Stream, VelocityFromPositionMatchesReportedVelocity) {
  // GIVEN a simulated stream, whose reported velocity is the backward
  // difference of the quantised position over the servo period 1/rate.
  // dt is that period (what a fixed-rate servo reports), so both velocity
  // paths are the same division. (With dt from differences of t, the two
  // velocities differ by ~1e-12 relative; with velocity_min = 2 quanta, a
  // speed of exactly 2 quanta then falls on either side of the rest
  // threshold, which moves Fs and vs by up to 5e-5 relative: a threshold
  // tie, not a from_position error.)
  const host::SimConfig sc = test::sim_config(test::SimSpec{100.0, 1000.0, 4});
  const host::Trace tr = host::simulate(sc);
  Config<double> measured = test::default_config<double>(sc);
  Config<double> from_x = measured;
  from_x.velocity_source = VelocitySource::from_position;
  const double period = 1.0 / sc.controller.servo_rate_hz;
  auto a = std::make_unique<Est>();
  auto b = std::make_unique<Est>();
  ASSERT_EQ(a->init(measured), Status::ok);
  ASSERT_EQ(b->init(from_x), Status::ok);
  // WHEN one estimator takes the velocity and the other only the position,
  // with garbage in its velocity field
  for (std::size_t k = 0; k < tr.samples.size(); ++k) {
    const Sample<double> s = test::to_sample<double>(tr.samples[k], k == 0 ? 0.0 : period);
    Sample<double> g = s;
    g.velocity_m_s = k % 2 ? kNaN : 1e30;
    ASSERT_EQ(a->push(s), Status::ok) << k;
    ASSERT_EQ(b->push(g), Status::ok) << k;
  }
  // THEN both give the same estimate within 1e-6 relative, by either method
  EXPECT_EQ(a->diagnostics().sections_complete[0], b->diagnostics().sections_complete[0]);
  EXPECT_EQ(a->diagnostics().sections_complete[1], b->diagnostics().sections_complete[1]);
  for (Method m : {Method::bands, Method::paper}) {
    ASSERT_EQ(a->solve(m), Status::ok);
    ASSERT_EQ(b->solve(m), Status::ok);
    const Estimate<double>& ea = a->estimate();
    const Estimate<double>& eb = b->estimate();
    const char* name = m == Method::bands ? "bands" : "paper";
    EXPECT_LT(rel_err(eb.mass_kg, ea.mass_kg), 1e-6) << name;
    EXPECT_EQ(eb.mass_flags, ea.mass_flags) << name;
    for (int k = 0; k < 2; ++k) {
      const DirectionEstimate<double>& pa = k == 0 ? ea.pos : ea.neg;
      const DirectionEstimate<double>& pb = k == 0 ? eb.pos : eb.neg;
      EXPECT_LT(rel_err(pb.viscous_Ns_m, pa.viscous_Ns_m), 1e-6) << name << k;
      EXPECT_LT(rel_err(pb.coulomb_N, pa.coulomb_N), 1e-6) << name << k;
      EXPECT_LT(rel_err(pb.breakaway_N, pa.breakaway_N), 1e-6) << name << k;
      EXPECT_LT(rel_err(pb.stribeck_velocity_m_s, pa.stribeck_velocity_m_s), 1e-6) << name << k;
      EXPECT_EQ(pb.flags, pa.flags) << name << k;
    }
  }
  // AND the estimate is the drive's, not a constant of the garbage
  EXPECT_LT(rel_err(b->estimate().mass_kg, sc.drive.mass_kg), 0.03);
}

TEST(Stream, FromPositionRejectsNonFinitePosition) {
  // GIVEN an estimator that differences position
  auto est = std::make_unique<Est>();
  Config<double> cfg = test::default_config<double>(1e-8, 1000.0);
  cfg.velocity_source = VelocitySource::from_position;
  ASSERT_EQ(est->init(cfg), Status::ok);
  Sample<double> s;
  ASSERT_EQ(est->push(s), Status::ok);
  // WHEN a position is NaN  THEN the sample is rejected as not finite
  s.dt_s = 1e-3;
  s.position_m = kNaN;
  EXPECT_EQ(est->push(s), Status::rejected_not_finite);
  EXPECT_EQ(est->diagnostics().rejected_not_finite, 1u);
}

}  // namespace
