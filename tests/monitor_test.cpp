// Friction health: the core's ChangeMonitor on synthetic epoch estimates,
// and `feedid monitor`'s pipeline (CSV stream, epochs, alarms) on simulated
// production logs with and without a change in service.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <string>

#include "csv_trace.hpp"
#include "drive_sim.hpp"
#include "feedid/monitor.hpp"
#include "monitor.hpp"

namespace feedid {
namespace {

/// An epoch estimate around the default drive, each parameter drawn with
/// its standard error; Fs and vs not identifiable (production motion).
Estimate<double> epoch(std::mt19937_64& rng, double fc_neg = 26.0) {
  std::normal_distribution<double> n(0.0, 1.0);
  Estimate<double> e;
  e.mass_kg = 100.0 + 0.05 * n(rng);
  e.mass_se_kg = 0.05;
  e.pos = {700.0 + 0.5 * n(rng), 25.0 + 0.03 * n(rng), 0.0, 0.0};
  e.neg = {720.0 + 0.5 * n(rng), fc_neg + 0.03 * n(rng), 0.0, 0.0};
  for (auto* d : {&e.pos, &e.neg}) {
    d->viscous_se = 0.5;
    d->coulomb_se = 0.03;
    d->flags = flag_stribeck_uncertain;
  }
  return e;
}

TEST(ChangeMonitor, NoAlarmOnAThousandChangeFreeEpochs) {
  ChangeMonitor<double> m;
  ASSERT_EQ(m.init(MonitorConfig<double>{}), Status::ok);
  std::mt19937_64 rng(7);
  int fresh = 0;
  for (int k = 0; k < 1000; ++k) ASSERT_EQ(m.update(epoch(rng), 10.0 * k, 10.0 * (k + 1), fresh), Status::ok);
  EXPECT_EQ(m.alarm_count(), 0);
  double ref = 0, se = 0;
  ASSERT_TRUE(m.reference(6, ref, se));  // Fc-
  EXPECT_NEAR(ref, 26.0, 0.05);
  EXPECT_FALSE(m.reference(3, ref, se)) << "Fs+ is never identifiable here, so never referenced";
}

TEST(ChangeMonitor, AFivePercentStepInOneCoulombForceIsNamedWithinTwoEpochsOrThree) {
  ChangeMonitor<float> m;
  ASSERT_EQ(m.init(MonitorConfig<float>{}), Status::ok);
  std::mt19937_64 rng(3);
  int fresh = 0, raised_at = -1;
  for (int k = 0; k < 40 && raised_at < 0; ++k) {
    const Estimate<double> d = epoch(rng, k >= 20 ? 26.0 * 1.05 : 26.0);
    Estimate<float> f;
    f.mass_kg = float(d.mass_kg), f.mass_se_kg = float(d.mass_se_kg);
    for (int s = 0; s < 2; ++s) {
      const auto& a = s ? d.neg : d.pos;
      auto& b = s ? f.neg : f.pos;
      b.viscous_Ns_m = float(a.viscous_Ns_m), b.coulomb_N = float(a.coulomb_N);
      b.viscous_se = float(a.viscous_se), b.coulomb_se = float(a.coulomb_se), b.flags = a.flags;
    }
    m.update(f, 10.0f * k, 10.0f * (k + 1), fresh);
    if (fresh > 0) raised_at = k;
  }
  ASSERT_EQ(m.alarm_count(), 1);
  const ChangeAlarm<float>& a = m.alarm(0);
  EXPECT_EQ(a.parameter, Tracked::coulomb);
  EXPECT_EQ(a.direction, -1);
  EXPECT_FLOAT_EQ(a.t_s, 200.0f);
  EXPECT_NEAR(a.change, 1.3f, 0.05f);
  EXPECT_LE(raised_at, 22) << "at most three epochs after the step";
}

TEST(ChangeMonitor, OneStrayEpochCannotRaiseAnAlarm) {
  ChangeMonitor<double> m;
  ASSERT_EQ(m.init(MonitorConfig<double>{}), Status::ok);
  std::mt19937_64 rng(11);
  int fresh = 0;
  for (int k = 0; k < 30; ++k) {
    Estimate<double> e = epoch(rng);
    if (k == 15) e.pos.coulomb_N = 40.0;  // a fit gone astray, with a small standard error
    m.update(e, 10.0 * k, 10.0 * (k + 1), fresh);
  }
  EXPECT_EQ(m.alarm_count(), 0);
}

TEST(ChangeMonitor, TwoStrayEpochsWithoutAChangeInTheirRunRaiseNone) {
  ChangeMonitor<double> m;
  ASSERT_EQ(m.init(MonitorConfig<double>{}), Status::ok);
  std::mt19937_64 rng(5);
  int fresh = 0;
  for (int k = 0; k < 40; ++k) {
    Estimate<double> e = epoch(rng);
    if (k == 15 || k == 17) {  // two fits gone astray, wide but far out: each clipped z adds 0.6 h
      e.neg.viscous_Ns_m = 3000.0;
      e.neg.viscous_se = 100.0;
    }
    m.update(e, 10.0 * k, 10.0 * (k + 1), fresh);
  }
  EXPECT_EQ(m.alarm_count(), 0) << "the run's pooled mean has not moved: no change to report";
}

TEST(ChangeMonitor, ChecksItsConfiguration) {
  ChangeMonitor<double> m;
  int fresh = 0;
  EXPECT_EQ(m.update(Estimate<double>{}, 0.0, 1.0, fresh), Status::not_initialized);
  MonitorConfig<double> c;
  c.reference_epochs = 2;
  EXPECT_EQ(m.init(c), Status::invalid_config);
  c = MonitorConfig<double>{};
  c.threshold = 0.0;
  EXPECT_EQ(m.init(c), Status::invalid_config);
}

}  // namespace
}  // namespace feedid

namespace feedid::host {
namespace {

MonitorResult monitor_simulated(const SimConfig& c, const std::string& name) {
  const std::string path = ::testing::TempDir() + name;
  std::string err;
  EXPECT_TRUE(write_trace_csv(path, simulate(c), err)) << err;
  CsvStream in(path, CsvColumns{});
  EXPECT_TRUE(in.ok()) << in.error();
  return monitor(in, MonitorOptions{});
}

SimConfig production(std::uint64_t seed) {
  SimConfig c;
  c.motion.program = Program::production;
  c.motion.duration_s = 240.0;
  c.seed = seed;
  c.logging.force = ForceLog::averaged;
  c.logging.velocity = VelocityLog::low_pass;
  return c;
}

TEST(Monitor, StepInNegativeCoulombOnProductionMotionIsNamedWithinAMinute) {
  SimConfig c = production(4);
  c.change.time_s = 123.0;
  c.change.coulomb_fraction = 0.05;
  c.change.direction = -1;
  const MonitorResult r = monitor_simulated(c, "feedid_monitor_step.csv");
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.epochs.size(), 24u);
  ASSERT_EQ(r.alarms.size(), 1u) << trend_table(r);
  const auto& a = r.alarms.front();
  EXPECT_EQ(a.parameter, feedid::Tracked::coulomb);
  EXPECT_EQ(a.direction, -1);
  EXPECT_LE(a.raised_t_s, c.change.time_s + 60.0);
  EXPECT_NEAR(a.change / a.reference, 0.05, 0.01);
  const nlohmann::json j = to_json(r, MonitorOptions{});
  EXPECT_EQ(j["alarms"][0]["parameter"], "fc");
  EXPECT_EQ(j["alarms"][0]["direction"], "neg");
  // Production motion carries Fc in every epoch, vs only in those with a slow jog.
  int with_vs = 0, with_fc = 0;
  for (const auto& ep : j["epochs"]) {
    with_vs += ep["pos"]["identifiable"]["vs"].get<bool>();
    with_fc += ep["pos"]["identifiable"]["fc"].get<bool>();
  }
  EXPECT_EQ(with_fc, 24);
  EXPECT_LT(with_vs, 12);
}

TEST(Monitor, ChangeFreeProductionLogsRaiseNone) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const MonitorResult r = monitor_simulated(production(seed), "feedid_monitor_free.csv");
    ASSERT_TRUE(r.error.empty()) << r.error;
    EXPECT_TRUE(r.alarms.empty()) << "seed " << seed << "\n" << trend_table(r);
  }
}

}  // namespace
}  // namespace feedid::host
