// `feedid circle` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "compensate/circle.hpp"

#include "cli_common.hpp"
#include "io/output_file.hpp"

namespace feedid::host::cli {
namespace {

/// Runs the circle test, prints the glitches, writes JSON and plot; the exit code.
int run_circle_report(CircleOptions opt) {
  // Four runs of two turns and a quarter: seconds at the default 2 kHz,
  // minutes at 1 MHz, which ran silent for three.
  Progress p("circle");
  if (samples_per_turn(opt) > 1e5) opt.progress = std::ref(p);
  const CircleResult r = run_circle(opt);
  if (!r.error.empty()) return bad_input(r.error);
  std::printf("circle R %.4g mm at %.4g mm/s, %g Hz; models %s\n", opt.radius_m * 1e3, opt.feed_m_s * 1e3, opt.rate_hz,
              opt.model_paths.empty() ? "identified from the simulated drives" : "from the --model files");
  std::printf("  %-12s %9s %9s %9s %9s %9s\n", "run", "0 deg", "90 deg", "180 deg", "270 deg", "RMS");
  for (const auto& run : r.runs)
    std::printf("  %-12s %9.3g %9.3g %9.3g %9.3g %9.3g   (um)\n", run.name.c_str(), run.glitch_um[0], run.glitch_um[1],
                run.glitch_um[2], run.glitch_um[3], run.rms_um);
  std::printf("largest quadrant glitch %.0f %% lower with the identified compensation\n", 100.0 * r.glitch_reduction);
  std::string err;
  if (!opt.json_path.empty()) {
    err = write_whole_file(opt.json_path, json_as_written(to_json(r, opt)).dump(2) + "\n");
    if (!err.empty()) return output_failed(err);
  }
  if (!opt.plot_path.empty() && !write_circle_plot(r, opt, opt.plot_path, err)) return output_failed(err);
  return 0;
}


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
  int run() override { return run_circle_report(opt); }
};

}  // namespace

std::unique_ptr<Command> make_circle_command() { return std::make_unique<CircleCommand>(); }

}  // namespace feedid::host::cli
