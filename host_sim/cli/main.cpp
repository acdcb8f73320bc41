// feedid: simulate a feed drive, identify mass and Stribeck friction from a
// trace, and (with later commands) diagnose the sim-to-real gap.
#include <CLI/CLI.hpp>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <exception>
#include <filesystem>
#include <string>
#include <memory>
#include <vector>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "cli_common.hpp"

using namespace feedid::host::cli;

namespace {
/// A command whose printed result did not reach standard output (a full
/// disk, a closed pipe) has failed, whatever it returned.
int with_stdout_checked(int rc) {
  std::cout.flush();
  errno = 0;
  if (std::fflush(stdout) != 0 || std::ferror(stdout) != 0 || !std::cout) {
    std::fprintf(stderr, "error: standard output: cannot write: %s\n", std::strerror(errno != 0 ? errno : EIO));
    return rc == 0 ? 1 : rc;
  }
  return rc;
}
/// glibc serves every block over 32 MB (one column of a 10-minute 8 kHz log
/// is 38 MB) with fresh pages from mmap and returns them on free: identify
/// derives, copies and frees such columns dozens of times, and the kernel's
/// zeroing of the new pages was a third of its CPU time (sys 2.2 of 7.3 s,
/// issue 29). From the heap, and kept there, a freed column is reused;
/// the peak memory stays the same (918 MB against 921 MB).
void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  (void)mallopt(M_MMAP_MAX, 0);
  (void)mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}
}  // namespace

int main(int argc, char** argv) {
  keep_freed_memory_for_reuse();
  CLI::App app{"feedid: identify a feed drive's mass and Stribeck friction from a trace, and diagnose the sim-to-real gap"};
  app.require_subcommand(1);
  std::vector<std::unique_ptr<Command>> commands;
  commands.push_back(make_simulate_command());
  commands.push_back(make_identify_command());
  commands.push_back(make_demo_command());
  commands.push_back(make_validate_command());
  commands.push_back(make_replay_command());
  commands.push_back(make_diagnose_command());
  commands.push_back(make_monitor_command());
  commands.push_back(make_compensate_command());
  commands.push_back(make_circle_command());
  commands.push_back(make_blind_bench_command());
  commands.push_back(make_coverage_command());
  commands.push_back(make_bench_command());
  for (auto& c : commands) c->add(app);
  app.set_version_flag("--version", std::string("feedid ") + FEEDID_VERSION);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every usage error 2, as the README says.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    for (auto& c : commands) {
      if (!*c->app) continue;
      std::string clash = output_over_input(*c->app);
      if (clash.empty()) clash = output_unwritable(*c->app);
      if (!clash.empty()) {
        std::fprintf(stderr, "error: %s\n", clash.c_str());
        return 2;
      }
      const auto run_start = std::filesystem::file_time_type::clock::now();
      const int rc = c->run();
      say_failure_where_json_was(*c->app, rc, run_start);
      return with_stdout_checked(rc);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  return 0;
}
