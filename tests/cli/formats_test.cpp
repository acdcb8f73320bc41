// The formats users have, from the command line (issue 31): a `;` log with
// decimal commas and a preamble gives the plain log's model, and says what
// it left out, in every reader (identify, identify --stream, monitor); a
// headerless log is refused with exit 2 naming file:line and --columns,
// and read with --columns.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include <nlohmann/json.hpp>

namespace {

struct Outcome {
  int rc = -1;
  std::string err;
};

Outcome feedid(const std::string& args) {
  const std::string err = ::testing::TempDir() + "feedid_formats.err";
  const int rc = std::system((std::string(FEEDID_BIN_DIR) + "/feedid " + args + " >/dev/null 2>" + err).c_str());
  std::ifstream f(err);
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1,
          std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>())};
}

double mass_of(const std::string& json_path) {
  std::ifstream f(json_path);
  return nlohmann::json::parse(f).at("m").get<double>();
}

/// The lines of `from` after its header, each through `convert`, after `head`.
template <typename F> std::string rewrite(const std::string& from, const std::string& name, const std::string& head, F convert) {
  const std::string path = ::testing::TempDir() + name;
  std::ifstream in(from);
  std::ofstream out(path);
  out << head;
  std::string line;
  std::getline(in, line);  // the header t,x,v,u
  while (std::getline(in, line)) out << convert(line) << "\n";
  return path;
}

TEST(Formats, GermanLogWithPreambleAndHeaderlessLogFromTheCommandLine) {
  const std::string dir = ::testing::TempDir();
  const std::string clean = dir + "feedid_formats_clean.csv";
  ASSERT_EQ(feedid("simulate --duration 30 --out " + clean).rc, 0);
  const std::string german = rewrite(clean, "feedid_formats_de.csv", "# DriveLog 2.1\nAchse: X\nt;x;v;u\n", [](std::string l) {
    for (char& c : l) c = c == ',' ? ';' : c == '.' ? ',' : c;
    return l;
  });
  ASSERT_EQ(feedid("identify --in " + clean + " --json " + dir + "feedid_formats_clean.json").rc, 0);
  const Outcome de = feedid("identify --in " + german + " --json " + dir + "feedid_formats_de.json");
  ASSERT_EQ(de.rc, 0) << de.err;
  EXPECT_EQ(mass_of(dir + "feedid_formats_de.json"), mass_of(dir + "feedid_formats_clean.json"));
  for (const std::string cmd : {"identify --in ", "identify --stream --in ", "monitor --in "})
    EXPECT_NE(feedid(cmd + german).err.find("feedid_formats_de.csv: 2 lines before the header (line 3) left out"),
              std::string::npos)
        << cmd;

  const std::string bare = rewrite(clean, "feedid_formats_bare.csv", "", [](std::string l) { return l; });
  const Outcome refused = feedid("identify --in " + bare);
  EXPECT_EQ(refused.rc, 2);
  EXPECT_NE(refused.err.find("feedid_formats_bare.csv:1: no header row names the columns"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("--columns"), std::string::npos) << refused.err;
  const Outcome named = feedid("identify --columns t,x,v,u --in " + bare + " --json " + dir + "feedid_formats_bare.json");
  ASSERT_EQ(named.rc, 0) << named.err;
  EXPECT_EQ(mass_of(dir + "feedid_formats_bare.json"), mass_of(dir + "feedid_formats_clean.json"));
}

}  // namespace
