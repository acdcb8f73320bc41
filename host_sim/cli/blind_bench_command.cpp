// `feedid blind-bench` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "bench/blind_bench.hpp"
#include "io/progress.hpp"
#include "sim_cli.hpp"
#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

struct BlindBenchCommand : Command {
  BlindOptions opt;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("blind-bench", "diagnose many simulated traces whose effect is withheld, and score the verdicts");
    add_blind_bench_options(app, opt);
  }
  int run() override {
    Progress p("blind-bench");
    if (opt.quiet) opt.progress = std::ref(p);
    return end_of_run(run_blind_bench(opt));
  }
};

}  // namespace

std::unique_ptr<Command> make_blind_bench_command() { return std::make_unique<BlindBenchCommand>(); }

}  // namespace feedid::host::cli
