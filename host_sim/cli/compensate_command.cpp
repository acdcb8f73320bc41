// `feedid compensate` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "compensate/compensate.hpp"
#include "io/output_file.hpp"
#include "model/drive_model.hpp"

#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

/// Reads the model JSON, refuses one that cannot be compensated with,
/// writes the table; the exit code.
int run_compensate(const std::string& model_path, const std::string& out_path, const std::string& format,
                   CompensateOptions opt) {
  const Outcome<nlohmann::json> read = read_json_file(model_path);
  if (!read.ok()) return bad_input(read.error);
  const nlohmann::json& mj = read.value;
  const ModelCompensation c = compensate_model(mj, opt, model_path);
  if (!c.error.empty()) return bad_input(c.error);
  warn(c.warnings);
  const CompensationTable& t = c.table;
  if (c.force_negated)
    std::fprintf(stderr, "note: %s was identified with the logged force negated (input.force_sign -1: it opposed the "
                 "motion as logged); the table is friction along the logged position, so in the drive's own force "
                 "sign the feedforward is minus these values\n", model_path.c_str());
  const std::string text = format == "csv" ? to_csv(t, opt, c.units) : json_as_written(c.json).dump(2) + "\n";
  if (out_path.empty()) {
    std::cout << text;
  } else {
    const std::string err = write_whole_file(out_path, text, {model_path});
    if (!err.empty()) return output_failed(err);
    // In the model's own units (identify states them: rad/s and V for a SysId log).
    const nlohmann::json units = mj.value("units", nlohmann::json::object());
    std::printf("%zu points per direction up to %.4g %s; largest interpolation error %.3g %s; wrote %s\n",
                t.dir[0].size(), t.max_speed_m_s, units.value("velocity", std::string("m/s")).c_str(),
                t.max_interpolation_error_N, units.value("force", std::string("N")).c_str(), out_path.c_str());
  }
  return 0;
}


struct CompensateCommand : Command {
  CompensateOptions opt;
  std::string model_path, out_path, format = "json";
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("compensate", "friction compensation a drive can load: a speed -> friction table per direction and the Coulomb + viscous form, from an identified model");
    app->add_option("--model", model_path, "model JSON from identify")->required();
    app->add_option("--points", opt.points, "breakpoints per direction, speed 0 included (CNCs take about 20)")
        ->capture_default_str()->check(CLI::Range(2, kMaxTablePoints));
    app->add_option("--format", format, "json or csv")->check(CLI::IsMember({"json", "csv"}))->capture_default_str();
    app->add_option("--out", out_path, "file to write (default: standard output)");
    app->add_option("--max-speed", opt.max_speed_m_s, "top of the table (m/s); default: the model's velocity_max_m_s")
        ->check(positive_number("m/s", " (leave it out for the model's velocity_max_m_s)"));  // 0 is not "the default"
    app->add_option("--force-scale", opt.force_scale,
                    "N per drive unit, as identify's --force-scale (e.g. N per A); the table is also given in that unit")
        ->capture_default_str();
    app->add_option("--force-unit", opt.force_unit, "label of the drive unit, e.g. A or %");
  }
  int run() override { return run_compensate(model_path, out_path, format, opt); }
};

}  // namespace

std::unique_ptr<Command> make_compensate_command() { return std::make_unique<CompensateCommand>(); }

}  // namespace feedid::host::cli
