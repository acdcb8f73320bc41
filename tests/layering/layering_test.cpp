// Dependencies point down (README "Layout"): a host stage includes only
// stages below it, the core only itself and the port headers, and nothing
// outside port/cortex_m includes the target's code. Read from the sources,
// so that an upward include fails here before it grows roots.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

/// The host stages from the bottom up; a stage may include its own folder
/// and any stage of a lower rank. Stages of one rank do not include each other.
const std::map<std::string, int>& stage_rank() {
  static const std::map<std::string, int> r = {
      {"io", 0},        {"model", 1},       {"sim", 2},      {"signals", 3},
      {"identify", 4},  {"validate", 5},    {"diagnose", 5}, {"monitor", 5},
      {"compensate", 5}, {"replay", 5},    {"gap", 6},      {"report", 7},   {"bench", 7},
      {"cli", 8},       {"python", 8},
      {"firmware_traces", 8},
  };
  return r;
}

struct Include {
  std::string file, target;
  int line;
};

/// Every `#include "<folder>/..."` under root/dir.
std::vector<Include> includes_under(const fs::path& root, const std::string& dir) {
  static const std::regex inc(R"re(^\s*#\s*include\s+"([A-Za-z_]+)/)re");
  std::vector<Include> out;
  for (const auto& e : fs::recursive_directory_iterator(root / dir)) {
    const std::string ext = e.path().extension().string();
    if (ext != ".cpp" && ext != ".hpp" && ext != ".h") continue;
    std::ifstream f(e.path());
    std::string line;
    for (int n = 1; std::getline(f, line); ++n) {
      std::smatch m;
      if (std::regex_search(line, m, inc)) out.push_back({fs::relative(e.path(), root).string(), m[1], n});
    }
  }
  return out;
}

const fs::path kRoot = FEEDID_SOURCE_DIR;

TEST(Layering, HostStagesIncludeOnlyStagesBelowThem) {
  const auto& rank = stage_rank();
  for (const auto& [stage, r] : rank) {
    if (!fs::exists(kRoot / "host_sim" / stage)) continue;
    for (const Include& i : includes_under(kRoot / "host_sim", stage)) {
      if (i.target == stage || i.target == "feedid" || i.target == "feedid_port") continue;
      const auto it = rank.find(i.target);
      ASSERT_NE(it, rank.end()) << "host_sim/" << i.file << ":" << i.line << " includes an unknown folder " << i.target;
      EXPECT_LT(it->second, r) << "host_sim/" << i.file << ":" << i.line << " (" << stage << ") includes " << i.target
                               << ", which is not below it";
    }
  }
}

TEST(Layering, TheCoreIncludesOnlyItselfAndThePort) {
  for (const Include& i : includes_under(kRoot, "core"))
    EXPECT_TRUE(i.target == "feedid" || i.target == "feedid_port") << i.file << ":" << i.line << " includes " << i.target;
}

TEST(Layering, NoHostFileIncludesTargetCode) {
  for (const Include& i : includes_under(kRoot, "host_sim"))
    EXPECT_NE(i.target, "cortex_m") << i.file << ":" << i.line;
}

TEST(Layering, OnlyTheCommandLinePrints) {
  // Results carry their errors; host_sim/cli prints them and chooses the
  // exit code. The bench apparatus runs its own reports, the firmware trace
  // generator is its own program, and io/progress.hpp is the progress line
  // the command line hands down.
  static const std::regex prints(R"re(std::cout|std::cerr|(^|[^n])printf\(|\bputs\(|fputs\()re");
  for (const auto& e : fs::recursive_directory_iterator(kRoot / "host_sim")) {
    const std::string rel = fs::relative(e.path(), kRoot / "host_sim").string();
    if (rel.rfind("cli/", 0) == 0 || rel.rfind("bench/", 0) == 0 || rel.rfind("firmware_traces/", 0) == 0 ||
        rel == "io/progress.hpp" || !e.is_regular_file())
      continue;
    std::ifstream f(e.path());
    std::string line;
    for (int n = 1; std::getline(f, line); ++n) {
      const auto code = line.substr(0, line.find("//"));
      EXPECT_FALSE(std::regex_search(code, prints)) << "host_sim/" << rel << ":" << n << " prints: " << line;
    }
  }
}

TEST(Layering, OnlyTheCommandLineEndsTheProcessOrSaysError) {
  // No stage below host_sim/cli ends the process or words an error line of
  // its own: they return the error (Outcome, RunEnd, an error field) and the
  // command line prints it and picks the exit code. The firmware trace
  // generators are programs of their own.
  static const std::regex ends(R"re(\b(std::)?(exit|_Exit|quick_exit|abort)\(|"error: )re");
  for (const auto& e : fs::recursive_directory_iterator(kRoot / "host_sim")) {
    const std::string rel = fs::relative(e.path(), kRoot / "host_sim").string();
    if (rel.rfind("cli/", 0) == 0 || rel.rfind("firmware_traces/", 0) == 0 || !e.is_regular_file()) continue;
    std::ifstream f(e.path());
    std::string line;
    for (int n = 1; std::getline(f, line); ++n) {
      const auto code = line.substr(0, line.find("//"));
      EXPECT_FALSE(std::regex_search(code, ends)) << "host_sim/" << rel << ":" << n << ": " << line;
    }
  }
}

}  // namespace
