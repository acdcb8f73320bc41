// `feedid validate` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "report/report.hpp"
#include "model/model_file.hpp"
#include "validate/validate.hpp"
#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

struct ValidateCommand : Command {
  std::vector<std::string> in_path;
  std::string model_path, json_path, plot_path;
  CsvColumns cols;
  InputOptions input;
  ValidateOptions opt;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("validate", "predict the force of another trace with an identified model; relative error as the EMPS protocol computes it");
    app->add_option("--model", model_path, "model JSON (from identify, or a truth file)")->required();
    app->add_option("--in", in_path, "trace CSV, .mat or .wpilog to predict; repeat for several recordings");
    app->add_option("--json", json_path, "write the result as JSON");
    add_input_options(app, cols, input);
    app->add_option("--filter", opt.filter_hz, "zero-phase Butterworth cut-off on position (Hz)")->capture_default_str();
    app->add_option("--decimate", opt.decimate, "decimation factor of the protocol (1 = none)")->capture_default_str();
    app->add_option("--drop-first", opt.drop_first, "samples dropped at the start")->capture_default_str();
    app->add_option("--plot", plot_path, "write measured against predicted force as SVG");
  }
  int run() override {
    // The one model reader replay and diagnose use.
    const ModelFile file = read_model_file(model_path);
    if (!file.error.empty()) return bad_input(file.error);
    warn(file.warnings);
    if (!file.effects.empty())
      std::fprintf(stderr, "warning: %s: its %zu effect(s) are not in validate's prediction (replay --model simulates "
                   "them)\n", model_path.c_str(), file.effects.size());
    const DriveParams& model = file.drive;
    opt.load = file.load;
    opt.units = input.units();
    if (const std::string why = model_units_mismatch({{"units", file.units}}, opt.units); !why.empty())
      return bad_input(model_path + ": " + why);
    CsvResult csv;
    if (!read_trace(in_path, input, cols, csv)) return 2;
    const ValidateResult r = validate(model, csv.trace, opt);
    if (!r.error.empty()) return bad_input(r.error);
    std::printf("relative force error %.4f %% (decimated by %d, %zu samples; %.4f %% at full rate); RMS %.4g %s\n",
                r.relative_error_pct, opt.decimate, r.samples_used, r.relative_error_full_pct, r.rms_error_N,
                r.units.force.c_str());
    if (r.force_sign.sign < 0 || !r.force_sign.conclusive) std::printf("  force %s\n", r.force_sign.describe().c_str());
    if (r.stretches > 1 || r.stretches_resampled > 0 || r.stretches_on_clock_slots > 0)
      std::printf("  %zu stretches between time gaps (%zu scored), %zu on their clock's slots (jittered stamps), "
                  "%zu read onto a uniform grid (uneven steps)\n",
                  r.stretches, r.stretches_scored, r.stretches_on_clock_slots, r.stretches_resampled);
    if (const std::string n = r.filter_note(); !n.empty()) std::printf("  note: %s\n", n.c_str());
    note_force_outliers(r.force_outliers, r.units);
    if (r.position_wrap.found()) std::printf("  position %s\n", r.position_wrap.describe().c_str());
    if (!json_path.empty() && !write_json(json_path, to_json(r, model, opt))) return 1;
    std::string err;
    if (!plot_path.empty() && !write_force_plot_svg(r, plot_path, "Cross-test: " + csv.trace.source, err))
      return output_failed(err);
    return 0;
  }
};

}  // namespace

std::unique_ptr<Command> make_validate_command() { return std::make_unique<ValidateCommand>(); }

}  // namespace feedid::host::cli
