// Google Benchmark of the streaming core: the per-sample update (push) and
// solve, in float (the firmware precision) and double (the host's), on the
// same simulated loop `feedid bench --core-only` pushes; plus the whole host
// pipeline (identify) for scale. docs/benchmarks.md has the numbers.
//
//   build/bin/feedid_core_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <memory>

#include "bench/bench.hpp"
#include "identify/identify.hpp"

namespace {

using feedid::host::CoreLoop;

const CoreLoop& loop() {
  static const CoreLoop l = feedid::host::make_core_loop(30.0);
  return l;
}

template <typename T> using Axis = feedid::Estimator<T>;

/// An initialised axis for the loop's configuration, or null (the
/// benchmark then reports why).
template <typename T> std::unique_ptr<Axis<T>> make_axis(const CoreLoop& l, benchmark::State& state) {
  auto axis = std::make_unique<Axis<T>>();
  if (axis->init(feedid::host::config_as<T>(l.config)) != feedid::Status::ok) {
    state.SkipWithError("init failed");
    return nullptr;
  }
  return axis;
}

// One push per iteration, cycling through the loop. s_per_sample is the mean
// over the iterations; state_bytes is sizeof the estimator (all it keeps).
template <typename T> void BM_Push(benchmark::State& state) {
  const CoreLoop& l = loop();
  const auto samples = feedid::host::core_samples<T>(l.signals, l.length);
  auto axis = make_axis<T>(l, state);
  if (!axis) return;
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(axis->push(samples[i]));
    if (++i == samples.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
  // Seconds per sample (printed with an SI prefix, e.g. 35n = 35 ns).
  state.counters["s_per_sample"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["state_bytes"] = static_cast<double>(sizeof(Axis<T>));
}

// solve() on an axis that has seen the whole loop (about 25 s of motion).
template <typename T> void BM_Solve(benchmark::State& state) {
  const CoreLoop& l = loop();
  const auto samples = feedid::host::core_samples<T>(l.signals, l.length);
  auto axis = make_axis<T>(l, state);
  if (!axis) return;
  for (const auto& s : samples) (void)axis->push(s);
  for (auto _ : state) benchmark::DoNotOptimize(axis->solve());
  if (axis->solve() != feedid::Status::ok) state.SkipWithError("solve did not succeed");
}

// The host pipeline on the same 30 s trace: prepare_signals, auto_config,
// push every sample (double core), solve, residual report.
void BM_Identify(benchmark::State& state) {
  const CoreLoop& l = loop();
  feedid::host::Trace tr;
  tr.samples.resize(l.signals.t.size());
  for (std::size_t k = 0; k < tr.samples.size(); ++k)
    tr.samples[k] = {l.signals.t[k], l.signals.x[k], l.signals.v[k], l.signals.u[k]};
  for (auto _ : state) {
    const auto r = feedid::host::identify(tr, feedid::host::IdentifyOptions{});
    benchmark::DoNotOptimize(r.estimate.mass_kg);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(tr.samples.size()));
}

}  // namespace

BENCHMARK_TEMPLATE(BM_Push, float);
BENCHMARK_TEMPLATE(BM_Push, double);
BENCHMARK_TEMPLATE(BM_Solve, float)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Solve, double)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Identify)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
