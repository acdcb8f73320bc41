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
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstdlib>
#endif

// The heap in huge pages (ask_for_huge_pages_in_the_heap): glibc's heap on
// a kernel that has them, and not under a sanitizer's allocator.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define FEEDID_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define FEEDID_SANITIZED 1
#endif
#endif
#if defined(__GLIBC__) && defined(MADV_HUGEPAGE) && !defined(FEEDID_SANITIZED)
#define FEEDID_HUGE_PAGE_HEAP 1
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
/// the peak memory stays the same (918 MB against 921 MB). Every thread
/// allocates from that one heap: diagnose's search threads had arenas of
/// their own, each touched for the first time.
void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  (void)mallopt(M_MMAP_MAX, 0);
  (void)mallopt(M_TRIM_THRESHOLD, INT_MAX);
#if defined(M_ARENA_MAX)
  (void)mallopt(M_ARENA_MAX, 1);
#endif
#endif
}

#if defined(FEEDID_HUGE_PAGE_HEAP)
/// Whether the kernel refuses address space beyond its commit limit
/// (vm.overcommit_memory = 2).
bool strict_overcommit() {
  std::FILE* f = std::fopen("/proc/sys/vm/overcommit_memory", "r");
  if (f == nullptr) return false;
  int mode = 0;
  const bool read = std::fscanf(f, "%d", &mode) == 1;
  std::fclose(f);
  return read && mode == 2;
}
#endif

/// Memory the heap touches for the first time still costs a page fault per
/// 4 KiB: 8700 faults and a fifth of `diagnose --model --controller` on EMPS
/// PULSES (docs/benchmarks.md). So the heap's first stretch (a quarter of
/// the memory, at most 1 GiB) is asked for in transparent huge pages, one
/// fault per 2 MiB. The stretch is address space only: a page is backed once
/// something is written to it, and a machine that refuses the stretch runs
/// as before. Not asked for where the kernel counts address space against
/// a strict limit (overcommit mode 2: each process would hold 1 GiB of the
/// machine's commit charge for its life), nor under a sanitizer, whose
/// allocator would mark the whole stretch in its shadow memory on free.
void ask_for_huge_pages_in_the_heap() {
#if defined(FEEDID_HUGE_PAGE_HEAP)
  if (strict_overcommit()) return;
  constexpr std::size_t kHugePage = std::size_t(1) << 21;
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page <= 0) return;
  const std::size_t stretch =
      std::min(std::size_t(1) << 30, static_cast<std::size_t>(pages) * static_cast<std::size_t>(page) / 4);
  void* block = std::malloc(stretch);  // from the heap itself: M_MMAP_MAX is 0
  if (block == nullptr) return;
  const auto start = reinterpret_cast<std::uintptr_t>(block);
  const std::uintptr_t from = (start + kHugePage - 1) & ~(kHugePage - 1);
  const std::uintptr_t to = (start + stretch) & ~(kHugePage - 1);
  if (to > from) (void)madvise(reinterpret_cast<void*>(from), to - from, MADV_HUGEPAGE);
  std::free(block);  // kept in the heap: M_TRIM_THRESHOLD is above the stretch
#endif
}
}  // namespace

int main(int argc, char** argv) {
  keep_freed_memory_for_reuse();
  ask_for_huge_pages_in_the_heap();
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
