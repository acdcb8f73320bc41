// libFuzzer target: the firmware's per-axis friction health and its
// feed-forward (core/feedid/health_tracker.hpp, feedforward.hpp), in float
// and double, with arbitrary configurations, sample streams and references.
// Invariants checked on every input, besides ASan/UBSan:
//   - every call returns a Status the enum names;
//   - within 1e30 s, the tracker's clock stays finite, and once the time pushed since the
//     last close (each finite positive step, capped at max_gap_s and
//     epoch_s) reaches
//     epoch_s, the epoch is complete: corrupt time steps never stop it
//     closing epochs;
//   - feedforward() is finite for any reference, from the last epoch's
//     estimate, an arbitrary estimate or an arbitrary table, whether or not
//     the configuration was checked.
// Build: cmake -DFEEDID_FUZZ=ON with clang (docs/reference.md, "Fuzzing").
#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstdint>
#include <memory>

#include "feedid/feedid.hpp"
#include "fuzz_inputs.hpp"

namespace {

template <typename T> feedid::MonitorConfig<T> monitor_config(FuzzedDataProvider& in) {
  feedid::MonitorConfig<T> c;
  c.epoch_s = near<T>(in, 0.05);  // short epochs, so that inputs close several
  c.watch_stribeck = in.ConsumeBool();  // the Stribeck tracks too
  if (!in.ConsumeBool()) return c;
  c.reference_epochs = in.ConsumeIntegralInRange<int>(0, 20);
  c.allowance = near<T>(in, 1.0);
  c.threshold = near<T>(in, 6.0);
  c.relative_floor = near<T>(in, 0.01);
  return c;
}

/// feedforward() of every kind of friction at one arbitrary reference.
template <typename T> void check_feedforward_finite(FuzzedDataProvider& in, const feedid::Estimate<T>& last) {
  const feedid::FeedforwardConfig<T> ff{near<T>(in, 0.002), near<T>(in, 100.0)};
  const T v = near<T>(in, 0.05), a = near<T>(in, 1.0);
  require(std::isfinite(feedid::feedforward(feedid::EstimateFriction<T>{last}, ff, v, a)));
  feedid::Estimate<T> e = last;
  for (auto* d : {&e.pos, &e.neg}) {
    d->coulomb_N = near<T>(in, 25.0);
    d->viscous_Ns_m = near<T>(in, 700.0);
    d->breakaway_N = near<T>(in, 8.0);
    d->stribeck_velocity_m_s = near<T>(in, 0.002);
  }
  require(std::isfinite(feedid::feedforward(feedid::EstimateFriction<T>{e}, ff, v, a)));
  feedid::FrictionTable<T, 4> table;
  for (int d = 0; d < 2; ++d) {
    table.count[d] = in.ConsumeIntegralInRange<int>(2, 4);
    for (int k = 0; k < 4; ++k) {
      table.speed_m_s[d][k] = in.ConsumeBool() ? T(0.01 * k) : any<T>(in);
      table.force_N[d][k] = near<T>(in, 30.0);
    }
  }
  require(named(feedid::check_table(table)));
  require(std::isfinite(feedid::feedforward(table, ff, v, a)));
}

template <typename T> void run(FuzzedDataProvider& in) {
  auto health = std::make_unique<feedid::HealthTracker<T>>();
  const feedid::Config<T> axis = config<T>(in);
  const feedid::MonitorConfig<T> mon = monitor_config<T>(in);
  const feedid::Status s0 = health->init(axis, mon);
  require(named(s0));
  if (s0 != feedid::Status::ok) {
    require(health->push(feedid::Sample<T>{}) == feedid::Status::not_initialized);
    return;
  }
  double pushed_s = 0.0, total_s = 0.0;  // the epoch's time and all of it, by the rule, in double
  T x = T(0);
  while (in.remaining_bytes() > 0) {
    const feedid::Sample<T> smp = sample(in, x);
    require(named(health->push(smp)));
    if (std::isfinite(smp.dt_s) && smp.dt_s > T(0)) {
      const double step = std::fmin(double(smp.dt_s), std::fmin(double(axis.max_gap_s), double(mon.epoch_s)));
      pushed_s += step;
      total_s += step;
    }
    // Within 1e30 s of clock (beyond, an epoch_s near the largest double
    // overflows any sum); a percent of margin for the float clock's rounding.
    if (total_s < 1e30) {
      require(std::isfinite(health->time_s()));
      if (pushed_s >= 1.01 * double(mon.epoch_s)) require(health->epoch_complete());
    }
    if (health->epoch_complete()) {
      int fresh = 0;
      require(named(health->close_epoch(fresh)));
      require(fresh >= 0 && fresh <= health->monitor().alarm_count());
      pushed_s = 0.0;
    }
    if (in.ConsumeIntegralInRange<int>(0, 63) == 0) check_feedforward_finite(in, health->last_epoch());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  if (in.ConsumeBool()) run<float>(in);
  else run<double>(in);
  return 0;
}
