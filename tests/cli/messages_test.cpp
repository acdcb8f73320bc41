// What the command line says about its input (issue 30): every reader,
// whole-file or streamed, names the rows it skipped; messages are printable
// and bounded whatever the input holds.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

namespace {

struct Outcome {
  int rc = -1;
  std::string err;
};

/// feedid with `args`, its stderr kept.
Outcome feedid(const std::string& args) {
  const std::string err = ::testing::TempDir() + "feedid_messages.err";
  const int rc = std::system((std::string(FEEDID_BIN_DIR) + "/feedid " + args + " >/dev/null 2>" + err).c_str());
  std::ifstream f(err);
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1,
          std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>())};
}

/// A simulated 30 s log with lines 501 and 901 (1-based, the header is 1) made unreadable.
std::string log_with_two_bad_rows() {
  const std::string clean = ::testing::TempDir() + "feedid_messages_clean.csv";
  const std::string bad = ::testing::TempDir() + "feedid_messages_bad.csv";
  EXPECT_EQ(feedid("simulate --duration 30 --out " + clean).rc, 0);
  std::ifstream in(clean);
  std::ofstream out(bad);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) out << (n == 501 || n == 901 ? "0.25,abc,0,1" : line) << "\n";
  return bad;
}

// GIVEN a log with two unreadable rows, THEN identify (whole and streamed)
// and monitor each count them and name them by line.
TEST(Messages, EveryReaderNamesTheRowsItSkipped) {
  const std::string in = log_with_two_bad_rows();
  for (const std::string cmd : {"identify --in ", "identify --stream --in ", "monitor --in "}) {
    const Outcome r = feedid(cmd + in);
    EXPECT_NE(r.err.find("skipped 2 bad rows"), std::string::npos) << cmd << r.err;
    EXPECT_NE(r.err.find("feedid_messages_bad.csv:501: "), std::string::npos) << cmd << r.err;
    EXPECT_NE(r.err.find("feedid_messages_bad.csv:901: "), std::string::npos) << cmd << r.err;
  }
}

}  // namespace
