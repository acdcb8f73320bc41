// The diagnosis report as a person opens it (issue 10). GIVEN a trace with a
// ripple, WHEN diagnose writes --report, THEN report.html is one
// self-contained page (inline SVG, no external resources, no sentinel or
// non-finite numbers), and headless Chromium (Debian's chromium, installed
// by .ci/setup) loads it, builds every figure into its DOM and renders it.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "diagnose/diagnose.hpp"
#include "report/report.hpp"
#include "test_support.hpp"

namespace feedid::test {
namespace {

std::string read_all(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

class DiagnosisReport : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SimSpec spec;
    spec.duration_s = 30.0;
    host::SimConfig c = sim_config(spec);
    c.effects.ripple_amplitude_N = 4.0;
    const host::DiagnoseResult r = host::diagnose(host::simulate(c), host::DiagnoseOptions{});
    ASSERT_TRUE(r.error.empty()) << r.error;
    ASSERT_EQ(r.effect, "position_ripple");
    // One folder per process: ctest runs each test in its own process, in parallel.
    dir_ = ::testing::TempDir() + "feedid_report_" + std::to_string(::getpid());
    std::string error;
    ASSERT_TRUE(host::write_diagnosis_report(r, dir_, "ripple.csv", "feedid diagnose --in ripple.csv --report " + dir_,
                                             error))
        << error;
  }
  static std::string dir_;
};
std::string DiagnosisReport::dir_;

TEST_F(DiagnosisReport, IsOneSelfContainedPageWithEveryFigureInline) {
  const std::string page = read_all(dir_ + "/report.html");
  ASSERT_FALSE(page.empty());
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  // Friction curve, base + with-effect panels over velocity, position,
  // time, and the compensation's circle test.
  EXPECT_EQ(count(page, "<svg "), 9u);
  EXPECT_NE(page.find("Friction compensation"), std::string::npos);
  EXPECT_NE(page.find("largest quadrant glitch"), std::string::npos);
  EXPECT_EQ(count(page, "src=\""), 0u) << "no external resources";
  EXPECT_EQ(count(page, "href=\""), 0u);
  for (const char* bad : {"nan", "inf ", "1e+09", "1e+12", "e+3"}) EXPECT_EQ(count(page, bad), 0u) << bad;
  EXPECT_NE(page.find("&plusmn;"), std::string::npos) << "the base model carries its standard errors";
}

TEST_F(DiagnosisReport, ChromiumLoadsAndRendersIt) {
  if (std::system("command -v chromium >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "chromium is not installed (.ci/setup installs it)";
  const std::string page = std::filesystem::absolute(dir_ + "/report.html").string();
  const std::string flags = "--headless --no-sandbox --disable-gpu --hide-scrollbars --user-data-dir=" + dir_ +
                            "/profile --window-size=1100,4200";
  const std::string dom = dir_ + "/dom.html", png = dir_ + "/report.png";
  ASSERT_EQ(std::system(("timeout 120 chromium " + flags + " --dump-dom file://" + page + " > " + dom + " 2>/dev/null").c_str()), 0);
  const std::string rendered = read_all(dom);
  EXPECT_NE(rendered.find("Sim-to-real gap diagnosis"), std::string::npos);
  EXPECT_EQ(count(rendered, "<svg "), 9u) << "every figure reached the DOM";
  ASSERT_EQ(std::system(("timeout 120 chromium " + flags + " --screenshot=" + png + " file://" + page + " >/dev/null 2>&1").c_str()), 0);
  ASSERT_TRUE(std::filesystem::exists(png));
  EXPECT_GT(std::filesystem::file_size(png), 50000u) << "a blank page compresses to a few kB";
}

}  // namespace
}  // namespace feedid::test
