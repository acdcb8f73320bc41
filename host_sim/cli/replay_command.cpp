// `feedid replay` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "io/number_format.hpp"
#include "replay/replay.hpp"
#include "report/report.hpp"
#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

void print_figures(const char* label, const ReplayFigures& f) {
  std::printf("  %-44s %10.4g %10.4g %12.4g %8.4g\n", label, f.position, f.velocity, f.acceleration, f.force);
}

/// How the substeps were chosen, for the header line: " (automatic: the
/// plant's shortest time scale 0.47 s)", or nothing when given.
std::string time_scale_said(const ReplayResult& r, const ReplayOptions& opt) {
  if (opt.substeps > 0) return "";
  if (!std::isfinite(r.shortest_time_scale_s)) return " (automatic: the plant sets no time scale)";
  char buf[96];
  std::snprintf(buf, sizeof buf, " (automatic: the plant's shortest time scale %.3g s)", r.shortest_time_scale_s);
  return buf;
}

void print_gain_fit(const GainFit& f, ControlLaw law) {
  if (!f.done) return;
  const Rounded kp = round_to_se(f.value.kp, f.se.kp), kv = round_to_se(f.value.kv, f.se.kv);
  std::printf("  gains from the logged command (%zu unsaturated samples, command %s, residual %.3g of RMS %.3g):\n"
              "    kp %s +- %s 1/s, kv %s +- %s command/(m/s)",
              f.samples, f.lag_samples == 0 ? "as computed" : "as applied", f.rms_residual, f.rms_command,
              kp.value.c_str(), kp.se.c_str(), kv.value.c_str(), kv.se.c_str());
  if (law == ControlLaw::p_pi) {
    const Rounded ki = round_to_se(f.value.ki, f.se.ki);
    std::printf(", ki %s +- %s command/m", ki.value.c_str(), ki.se.c_str());
  }
  if (std::isfinite(f.extra_gain)) {
    const Rounded g = round_to_se(f.extra_gain, f.extra_gain_se);
    std::printf(", extra command x %s +- %s", g.value.c_str(), g.se.c_str());
  }
  std::printf("\n");
}

struct ReplayCommand : Command {
  std::string in_path, model_path, controller_path, json_path, plot_path, report_dir;
  CsvColumns cols;
  InputOptions input;
  ReplayOptions opt;
  bool fit_gains_always = false;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("replay", "simulate a model inside the drive's own loop, driven by the logged reference, "
                                          "and compare with the run (relative errors as the EMPS package computes them)");
    app->add_option("--model", model_path, "model JSON (from identify --json, or hand-written: m, pos, neg, offset_N)")->required();
    app->add_option("--controller", controller_path, "controller JSON (docs/reference.md, \"replay\")")->required();
    app->add_option("--in", in_path, "the logged run (CSV, .mat or .wpilog), one continuous recording")->required();
    add_input_options(app, cols, input);
    app->get_option("--in-list")->group("");  // one recording only: refused with the reason, not offered in --help
    app->add_option("--json", json_path, "write the result as JSON");
    app->add_option("--plot", plot_path, "write measured against simulated force over time as SVG");
    app->add_option("--report", report_dir, "write report.html with every signal's overlay and residual into this folder");
    app->add_option("--substeps", opt.substeps, "plant integration steps per sample (0: the fewest that resolve the "
                                                "plant's shortest time scale " +
                                                    std::to_string(static_cast<int>(kStepsPerTimeScale)) + " times)")
        ->capture_default_str();
    app->add_option("--filter", opt.filter_hz, "zero-phase Butterworth cut-off on the measured position (Hz)")->capture_default_str();
    app->add_option("--drop-first", opt.drop_first, "samples left out at the start")->capture_default_str();
    app->add_flag("--fit-gains", fit_gains_always, "identify the gains from the logged command even when the file gives them (a check)");
  }
  int run() override {
    if (!input.in_list.empty()) return bad_input("--in-list: replay takes one continuous recording (--in)");
    const ModelFile model = read_model_file(model_path);
    if (!model.error.empty()) return bad_input(model.error);
    const Controller controller = read_controller_file(controller_path);
    if (!controller.error.empty()) return bad_input(controller.error);
    warn(model.warnings);
    warn(controller.warnings);
    opt.units = input.units();
    if (const std::string why = model_units_mismatch({{"units", model.units}}, opt.units); !why.empty())
      return bad_input(model_path + ": " + why);
    const LoggedRun run = read_logged_run(in_path, cols, controller);
    const ReplayResult r = replay(model, controller, run, opt, fit_gains_always);
    if (!r.error.empty()) return bad_input(r.error);
    std::printf("replay of %s in the loop of %s: %zu samples at %.6g s, %d plant substeps%s; %zu compared (first %d left out)\n",
                in_path.c_str(), controller_path.c_str(), r.samples, r.dt_s, r.substeps,
                time_scale_said(r, opt).c_str(), r.samples_compared, opt.drop_first);
    for (const auto& n : r.notes) std::printf("  note: %s\n", n.c_str());
    print_gain_fit(r.gain_fit, controller.law);
    std::printf("  relative error (%%)                           %10s %10s %12s %8s\n", "position", "velocity", "acceleration",
                "force");
    print_figures("measured processed, simulated from states", r.error_pct);
    print_figures("both sides processed alike", r.same_processing_pct);
    print_figures("the processing alone", r.processing_pct);
    if (r.saturated_samples > 0) std::printf("  the simulated command is at its limit on %zu samples\n", r.saturated_samples);
    if (!json_path.empty() && !write_json(json_path, to_json(r, model, controller, opt), {in_path, model_path, controller_path}))
      return 1;
    std::string err;
    if (!plot_path.empty() && !write_svg(plot_path, replay_plot(r, "force", "Replay: " + in_path), err))
      return output_failed(err);
    const std::string command = "feedid replay --model " + model_path + " --controller " + controller_path + " --in " + in_path;
    if (!report_dir.empty() && !write_replay_report(r, report_dir, in_path, command_as_typed(command + " --report " + report_dir), err))
      return output_failed(err);
    return 0;
  }
};

}  // namespace

std::unique_ptr<Command> make_replay_command() { return std::make_unique<ReplayCommand>(); }

}  // namespace feedid::host::cli
