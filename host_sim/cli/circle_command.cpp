// `feedid circle` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "compensate/circle.hpp"

#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

struct CircleCommand : Command {
  CircleOptions opt;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("circle", "closed-loop circle test on two simulated axes: quadrant glitches without, with the identified, and with +-20 % wrong friction compensation");
    app->add_option("--radius", opt.radius_m, "circle radius (m)")->capture_default_str();
    app->add_option("--feed", opt.feed_m_s, "path speed (m/s)")->capture_default_str();
    app->add_option("--rate", opt.rate_hz, "servo rate of both axes (Hz)")->capture_default_str();
    app->add_option("--wrong", opt.wrong_fraction, "the sensitivity runs scale every friction magnitude by 1 +- this")
        ->capture_default_str();
    app->add_option("--model", opt.model_paths,
                    "compensation model JSON from identify: X, then Y; default: the simulated drives, identified on the spot");
    app->add_option("--json", opt.json_path, "write runs.{none,identified,wrong_plus,wrong_minus}.{glitch_um,rms_um} as JSON");
    app->add_option("--plot", opt.plot_path, "write the polar radial-error plot as SVG");
  }
  int run() override { return run_circle_command(opt); }
};

}  // namespace

std::unique_ptr<Command> make_circle_command() { return std::make_unique<CircleCommand>(); }

}  // namespace feedid::host::cli
