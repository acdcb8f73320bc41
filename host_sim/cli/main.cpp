// feedid: simulate a feed drive, identify mass and Stribeck friction from a
// trace, and (with later commands) diagnose the sim-to-real gap.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <memory>
#include <vector>

#include "cli_common.hpp"

using namespace feedid::host::cli;

int main(int argc, char** argv) {
  CLI::App app{"feedid: identify a feed drive's mass and Stribeck friction from a trace, and diagnose the sim-to-real gap"};
  app.require_subcommand(1);
  std::vector<std::unique_ptr<Command>> commands;
  commands.push_back(make_simulate_command());
  commands.push_back(make_identify_command());
  commands.push_back(make_demo_command());
  commands.push_back(make_validate_command());
  commands.push_back(make_diagnose_command());
  commands.push_back(make_monitor_command());
  commands.push_back(make_compensate_command());
  commands.push_back(make_circle_command());
  commands.push_back(make_blind_bench_command());
  commands.push_back(make_coverage_command());
  commands.push_back(make_bench_command());
  for (auto& c : commands) c->add(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    for (auto& c : commands)
      if (*c->app) return c->run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  return 0;
}
