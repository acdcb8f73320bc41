// `feedid coverage` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "bench/coverage.hpp"
#include "io/progress.hpp"

#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

struct CoverageCommand : Command {
  CoverageOptions opt;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("coverage", "Monte Carlo over drives, force logs and velocity filters: do estimate +- 1.96 se hold the truth 95 % of the time? RMSE against batch LM (docs/coverage.md)");
    app->add_option("--seeds", opt.seeds, "traces per drive and force convention")->capture_default_str();
    app->add_option("--first-seed", opt.first_seed, "seed of the first trace")->capture_default_str();
    app->add_option("--duration", opt.duration_s, "length of each trace (s)")->capture_default_str();
    app->add_option("--lm-every", opt.lm_every, "run batch LM on every n-th seed (0 = never)")->capture_default_str();
    app->add_option("--threads", opt.threads, "worker threads")->capture_default_str();
    app->add_option("--json", opt.json_path, "write every trace's errors and standard errors as JSON");
    app->add_option("--markdown", opt.markdown_path, "write the tables as Markdown");
  }
  int run() override {
    Progress p("coverage");
    opt.progress = std::ref(p);
    return end_of_run(run_coverage(opt));
  }
};

}  // namespace

std::unique_ptr<Command> make_coverage_command() { return std::make_unique<CoverageCommand>(); }

}  // namespace feedid::host::cli
