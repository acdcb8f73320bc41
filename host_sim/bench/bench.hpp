// `feedid bench`: the streaming core side by side with batch nonlinear least
// squares, differential evolution and recursive least squares on the same
// simulated traces (docs/benchmarks.md). Host only; plain functions so the
// library does not depend on the CLI parser.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "io/csv_trace.hpp"
#include "io/outcome.hpp"

#include "feedid/feedid.hpp"
#include "identify/identify.hpp"

namespace feedid::host {

struct BenchOptions {
  /// Write the results as JSON here (empty: no JSON).
  std::string json_path;
  /// Write SVG figures into this folder (empty: none). Default mode writes
  /// bench_time_vs_error.svg; --scaling writes bench_scaling_time.svg and
  /// bench_scaling_memory.svg.
  std::string plot_dir;

  /// --core-only: push `samples` simulated samples through the core and
  /// solve; no file I/O besides the optional JSON. For instruction counts
  /// under valgrind and timing from outside.
  bool core_only = false;
  long samples = 1000000;
  std::string precision = "float";  ///< core-only: "float" or "double"

  /// --quick: two short traces and a small GA budget (a smoke run, ~10 s).
  bool quick = false;
  /// --scaling: time and memory of every method against trace length,
  /// 1e4 .. max_samples samples of one drive, instead of the default set.
  bool scaling = false;
  long max_samples = 10000000;
  /// --scaling: the GA runs only up to this trace length (its time grows as
  /// budget x samples); longer ones are extrapolated from its measured cost
  /// per row and evaluation, and marked so.
  long ga_max_samples = 1000000;

  /// --diagnose-cost: time and peak memory of `diagnose` against `identify`
  /// on one simulated trace (a 3 N ripple), each reading the CSV as the CLI
  /// does, and their ratios (issue 10's bar: <= 3x time, <= 2x memory).
  bool diagnose_cost = false;
  double cost_rate_hz = 8000.0;
  double cost_duration_s = 600.0;
  /// A recorded trace (CSV, SI units) to measure on instead of the
  /// simulated one, and its columns.
  std::string cost_csv;
  CsvColumns cost_columns;

  /// Comma-separated subset of streaming,batch_lm,ga,rls (empty: all).
  std::string methods;
  /// Each fast method is timed as the minimum over this many runs (the GA
  /// runs once). Memory is measured on the first run.
  int repeats = 3;
  /// GA (differential evolution) budget: population x (generations + 1) evaluations.
  int ga_population = 36;
  int ga_generations = 150;
  /// batch_lm and ga: zero-phase Butterworth cut-off on velocity and force
  /// before differencing (Hz); 0 = none (BaselineOptions::filter_hz).
  double filter_hz = 0.0;
  /// --stated-conventions: every method is given the force pairing and the
  /// velocity cut-off instead of searching them (bench_identify_options):
  /// what the conditioning's searches cost. Not the bar's figure.
  bool stated_conventions = false;
  /// batch_lm from the textbook start (Fs = 0.2 Fc, vs = median speed)
  /// instead of the residual-based one.
  bool lm_naive_start = false;
};

/// The simulated stretch that `bench --core-only` and the Google Benchmark
/// target push cyclically: the default drive (100 kg, 2 kHz), `seconds`
/// long, cut in its last dwell so the wrap to the first sample is a
/// continuous stream at rest; with the configuration identify() would pick.
struct CoreLoop {
  Signals signals;
  feedid::Config<double> config{};
  std::size_t length = 0;  ///< samples of the loop (a prefix of signals)
};
CoreLoop make_core_loop(double seconds = 30.0);

/// The same configuration in precision T (identify.hpp).
template <typename T> feedid::Config<T> config_as(const feedid::Config<double>& c) {
  return feedid::host::config_as<T, double>(c);
}

/// Samples [0, n) of the signals as the core takes them (dt from consecutive
/// times; the first gets the nominal period so a loop can wrap onto it).
template <typename T> std::vector<feedid::Sample<T>> core_samples(const Signals& s, std::size_t n) {
  std::vector<feedid::Sample<T>> out(n < s.t.size() ? n : s.t.size());
  const double dt0 = s.sample_rate_hz > 0 ? 1.0 / s.sample_rate_hz : 1e-3;
  for (std::size_t k = 0; k < out.size(); ++k) {
    out[k].dt_s = T(k == 0 ? dt0 : s.t[k] - s.t[k - 1]);
    out[k].position_m = T(s.x[k]);
    out[k].velocity_m_s = T(s.v[k]);
    out[k].force_N = T(s.u[k]);
  }
  return out;
}

/// Runs the benchmark; prints progress on stderr and tables on stdout. The
/// options it refuses and the outputs it could not write are in the RunEnd
/// (io/outcome.hpp), for the CLI to say.
RunEnd run_bench(const BenchOptions& opt);

}  // namespace feedid::host
