// `feedid compensate` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "compensate/compensate.hpp"

#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

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
    app->add_option("--max-speed", opt.max_speed_m_s, "top of the table (m/s); default: the model's velocity_max_m_s");
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
