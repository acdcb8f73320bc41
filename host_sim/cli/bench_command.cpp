// `feedid bench` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "bench/bench.hpp"

#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

struct BenchCommand : Command {
  BenchOptions bo;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("bench", "streaming core against batch LM, a genetic algorithm and RLS on the same traces (docs/benchmarks.md)");
    CLI::App* c = app;
    c->add_option("--json", bo.json_path, "write the results as JSON");
    c->add_option("--plot-dir", bo.plot_dir, "write SVG figures into this folder");
    c->add_flag("--core-only", bo.core_only, "push --samples simulated samples through the core and solve (no file I/O)");
    c->add_option("--samples", bo.samples, "core-only: samples to push")->capture_default_str();
    c->add_option("--precision", bo.precision, "core-only: float or double")->capture_default_str();
    c->add_flag("--quick", bo.quick, "two short traces, small GA budget");
    c->add_flag("--diagnose-cost", bo.diagnose_cost, "time and peak memory of diagnose against identify on one trace, as ratios, and of identify against reading the trace alone");
    c->add_option("--cost-rate", bo.cost_rate_hz, "diagnose-cost: sample rate (Hz)")->capture_default_str();
    c->add_option("--cost-duration", bo.cost_duration_s, "diagnose-cost: trace length (s)")->capture_default_str();
    c->add_option("--cost-in", bo.cost_csv, "diagnose-cost: a recorded trace (CSV, SI units) instead of a simulated one (--cost-rate and --cost-duration then do not apply)")
        ->check(CLI::ExistingFile);
    c->add_option("--time", bo.cost_columns.time, "diagnose-cost --cost-in: time column (s)")->capture_default_str();
    c->add_option("--position", bo.cost_columns.position, "diagnose-cost --cost-in: position column (m)")->capture_default_str();
    c->add_option("--velocity", bo.cost_columns.velocity, "diagnose-cost --cost-in: velocity column (m/s)")->capture_default_str();
    c->add_option("--force", bo.cost_columns.force, "diagnose-cost --cost-in: force column (N)")->capture_default_str();
    c->add_flag("--scaling", bo.scaling, "time and memory against trace length instead of the default set");
    c->add_option("--max-samples", bo.max_samples, "scaling: longest trace (samples)")->capture_default_str();
    c->add_option("--ga-max-samples", bo.ga_max_samples, "scaling: longest trace the GA runs on")->capture_default_str();
    c->add_option("--methods", bo.methods, "comma-separated subset of streaming,batch_lm,ga,rls");
    c->add_option("--repeats", bo.repeats, "timing: fastest of this many runs")->capture_default_str();
    c->add_option("--ga-population", bo.ga_population, "GA population")->capture_default_str();
    c->add_option("--ga-generations", bo.ga_generations, "GA generations")->capture_default_str();
    c->add_option("--filter-hz", bo.filter_hz, "batch_lm, ga: zero-phase Butterworth cut-off before differencing (Hz); 0 = none")->capture_default_str();
    c->add_flag("--stated-conventions", bo.stated_conventions,
                "every method is given the force pairing (held-backward) and a velocity cut-off of 0.4/sqrt(2) of the rate instead of searching them: what the searches cost (not the bar's figure)");
    c->add_flag("--lm-naive-start", bo.lm_naive_start, "batch_lm: textbook start (Fs = 0.2 Fc, vs = median speed)");
  }
  int run() override { return end_of_run(run_bench(bo)); }
};

}  // namespace

std::unique_ptr<Command> make_bench_command() { return std::make_unique<BenchCommand>(); }

}  // namespace feedid::host::cli
