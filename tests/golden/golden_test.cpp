// Pinned outputs (issue 12): the JSON of identify, validate and diagnose on
// fixed simulated traces, compared with the files in tests/golden/ number by
// number (relative 1e-6, absolute 1e-9) and string by string. A change that
// moves a result shows here; if the move is intended, regenerate with
//   FEEDID_UPDATE_GOLDEN=1 build/bin/feedid_tests --gtest_filter='Golden*'
// and commit the diff with the reason.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "diagnose/diagnose.hpp"
#include "identify/identify.hpp"
#include "test_support.hpp"
#include "validate/validate.hpp"

#ifndef FEEDID_SOURCE_DIR
#define FEEDID_SOURCE_DIR "."
#endif

namespace feedid::test {
namespace {

const std::string kGoldenDir = std::string(FEEDID_SOURCE_DIR) + "/tests/golden/";

/// Walks `want` and `got` together; adds a line per difference to `diff`.
void compare(const nlohmann::json& want, const nlohmann::json& got, const std::string& path, std::string& diff) {
  if (want.is_number() && got.is_number()) {
    const double a = want.get<double>(), b = got.get<double>();
    if (!(std::fabs(a - b) <= 1e-9 + 1e-6 * std::fabs(a))) diff += path + ": " + want.dump() + " -> " + got.dump() + "\n";
    return;
  }
  if (want.type() != got.type()) {
    diff += path + ": " + want.dump() + " -> " + got.dump() + "\n";
    return;
  }
  if (want.is_object()) {
    for (auto it = want.begin(); it != want.end(); ++it) {
      if (!got.contains(it.key())) diff += path + "/" + it.key() + ": missing\n";
      else compare(it.value(), got[it.key()], path + "/" + it.key(), diff);
    }
    for (auto it = got.begin(); it != got.end(); ++it)
      if (!want.contains(it.key())) diff += path + "/" + it.key() + ": new\n";
  } else if (want.is_array()) {
    if (want.size() != got.size()) diff += path + ": " + std::to_string(want.size()) + " -> " + std::to_string(got.size()) + " entries\n";
    for (std::size_t i = 0; i < want.size() && i < got.size(); ++i) compare(want[i], got[i], path + "/" + std::to_string(i), diff);
  } else if (want != got) {
    diff += path + ": " + want.dump() + " -> " + got.dump() + "\n";
  }
}

void expect_golden(const std::string& name, const nlohmann::json& got) {
  const std::string file = kGoldenDir + name + ".json";
  if (std::getenv("FEEDID_UPDATE_GOLDEN")) {
    std::ofstream(file) << got.dump(1) << "\n";
    GTEST_SKIP() << "wrote " << file;
  }
  std::ifstream in(file);
  ASSERT_TRUE(in) << file << " is missing; FEEDID_UPDATE_GOLDEN=1 writes it";
  const nlohmann::json want = nlohmann::json::parse(in);
  std::string diff;
  compare(want, got, name, diff);
  EXPECT_TRUE(diff.empty()) << "differences from " << file << ":\n" << diff.substr(0, 4000);
}

host::Trace golden_trace(bool ripple) {
  SimSpec spec;
  spec.duration_s = 30.0;
  spec.seed = 17;
  host::SimConfig c = sim_config(spec);
  if (ripple) c.effects.ripple_amplitude_N = 4.0;
  host::Trace t = host::simulate(c);
  t.source = ripple ? "golden_ripple" : "golden";
  return t;
}

TEST(Golden, IdentifyJson) {
  expect_golden("identify", host::to_json(host::identify(golden_trace(false), host::IdentifyOptions{})));
}

TEST(Golden, ValidateJson) {
  const host::IdentifyResult id = host::identify(golden_trace(false), host::IdentifyOptions{});
  const host::DriveParams model = host::to_drive_params(id.estimate);
  const host::ValidateOptions opt{};
  nlohmann::json j = host::to_json(host::validate(model, golden_trace(true), opt), model, opt);
  expect_golden("validate", j);
}

TEST(Golden, DiagnoseJson) {
  expect_golden("diagnose", host::to_json(host::diagnose(golden_trace(true), host::DiagnoseOptions{})));
}

}  // namespace
}  // namespace feedid::test
