// `feedid diagnose` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <future>
#include <memory>
#include <optional>

#include "diagnose/diagnose.hpp"
#include "gap/model_gap.hpp"
#include "io/progress.hpp"
#include "report/report.hpp"
#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

struct DiagnoseCommand : Command {
  CsvColumns cols;
  InputOptions input;
  DiagnoseOptions opt;
  std::vector<std::string> in_path;
  std::string json_path, report_dir, method = "bands", model_path, controller_path, model_out_path;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("diagnose", "where the identified model misses a trace, which unmodelled effect causes it, and how far adding it shrinks the held-out gap");
    app->add_option("--in", in_path, "trace CSV, .mat or .wpilog; repeat to pool several recordings (folds stay within each)");
    app->add_option("--json", json_path, "write the diagnosis as JSON");
    app->add_option("--report", report_dir, "write pictures and a report page to this folder");
    add_identify_options(app, cols, input, opt.identify, method);
    app->add_option("--folds", opt.folds, "time folds; odd ones are held out")->capture_default_str();
    app->add_option("--block", opt.block_s, "residual block length (s)")->capture_default_str();
    app->add_option("--threads", opt.threads, "effect families searched at once (0: the machine's hardware "
                                              "threads; unless 1, one more finds where the gap lies beside them, "
                                              "and with --controller others read the run's reference and replay "
                                              "the model before and after the causes beside the diagnosis); "
                                              "the result is the same on any number")
        ->capture_default_str()
        ->check(CLI::Range(0, 256));
    app->add_option("--model", model_path, "diagnose this model as given (identify --json, or hand-written: m, pos, neg, "
                                           "offset_N): the base model is not refitted");
    app->add_option("--controller", controller_path, "with --model: replay the model in this drive loop (replay's "
                                                     "controller JSON) on held-out time, before and after the causes");
    app->add_option("--model-out", model_out_path, "write the base model with the named effects as a model file: "
                                                   "replay --model simulates them");
  }
  std::vector<std::string> with_inputs(std::vector<std::string> more) const {
    more.insert(more.end(), in_path.begin(), in_path.end());
    return more;
  }
  /// --controller's file, read before the trace so that the reference
  /// and extra command are read beside it (replay.hpp,
  /// start_reference_and_extra); an error names what is wrong.
  std::string read_controller(std::optional<Controller>& controller) const {
    if (controller_path.empty()) return "";
    if (model_path.empty()) return "--controller needs --model (the model to replay)";
    if (in_path.size() != 1 || !input.in_list.empty()) return "--controller: a replay takes one continuous recording (one --in)";
    controller = read_controller_file(controller_path);
    if (!controller->error.empty()) return controller->error;
    warn(controller->warnings);
    return "";
  }
  /// diagnose --model [--controller]: the given model's gap (gap/model_gap.hpp).
  /// --model's file into opt.model, its warnings said; an error names what is wrong.
  std::string read_model() {
    if (model_path.empty()) return "";
    opt.model = read_model_file(model_path);
    if (!opt.model->error.empty()) return opt.model->error;
    warn(opt.model->warnings);
    if (!opt.model->effects.empty())
      std::fprintf(stderr, "note: %s: its %zu effect(s) are not the diagnosis's base (its mass, friction and load are): "
                   "the effects are named anew\n", model_path.c_str(), opt.model->effects.size());
    if (const std::string why = model_units_mismatch({{"units", opt.model->units}}, opt.identify.units); !why.empty())
      return model_path + ": " + why;
    return "";
  }
  int run_given_model(const CsvResult& csv, const std::optional<Controller>& controller, std::future<CsvResult> both) {
    std::optional<LoggedRun> run;
    ReplayOptions ropt;
    ropt.units = opt.identify.units;
    if (controller) {
      run = read_logged_run(in_path.front(), cols, *controller, csv, both.get());
      if (!run->error.empty()) return bad_input(run->error);
      for (const auto& n : run->notes) std::fprintf(stderr, "note: %s\n", n.c_str());
    }
    const ModelGap g = model_gap(csv.trace, opt, controller ? &*controller : nullptr, run ? &*run : nullptr, ropt);
    if (!json_path.empty() && !write_json(json_path, to_json(g), with_inputs({model_path, controller_path}))) return 1;
    if (!model_out_path.empty() && g.error.empty() &&
        !write_json(model_out_path, model_with_effects(g.diagnosis, read_json_file(model_path).value),
                    with_inputs({model_path, controller_path})))
      return 1;
    if (!g.error.empty()) return bad_input(g.error);
    note_force_outliers(g.diagnosis.force_outliers, opt.identify.units);
    std::cout << summary(g);
    if (report_dir.empty()) return 0;
    std::string command = "feedid diagnose --model " + model_path;
    if (!controller_path.empty()) command += " --controller " + controller_path;
    for (const auto& in : in_path) command += " --in " + in;
    std::string err;
    if (!write_model_gap_report(g, report_dir, csv.trace.source, command_as_typed(command + " --report " + report_dir), err))
      return output_failed(err);
    std::printf("report: %s/report.html\n", report_dir.c_str());
    return 0;
  }
  int run() override {
    if (method != "bands") {
      return bad_input("diagnose --method " + method + ": the diagnosis refits the bands model's terms and has no "
                       "other method; use identify --method " + method + " for that estimate");
    }
    opt.identify.units = input.units();
    if (const std::string why = read_model(); !why.empty()) return bad_input(why);
    std::optional<Controller> controller;
    if (const std::string why = read_controller(controller); !why.empty()) return bad_input(why);
    std::future<CsvResult> both;
    if (controller) both = start_reference_and_extra(in_path.front(), cols, *controller, opt.threads != 1);
    CsvResult csv;
    if (!read_trace(in_path, input, cols, csv)) return 2;
    Progress p("diagnose");
    if (csv.trace.samples.size() > 500000) opt.progress = std::ref(p);
    if (!model_path.empty()) return run_given_model(csv, controller, std::move(both));
    const DiagnoseResult r = diagnose(csv.trace, opt);
    if (!json_path.empty() && !write_json(json_path, to_json(r))) return 1;
    if (!model_out_path.empty() && r.error.empty() &&
        !write_json(model_out_path, model_with_effects(r, nlohmann::json()), with_inputs({})))
      return 1;
    if (!r.error.empty()) return bad_input(r.error);
    note_force_outliers(r.force_outliers, opt.identify.units);
    std::cout << summary(r);
    return write_report(r, report_dir, csv.trace.source,
                        "feedid diagnose --in " + csv.trace.source + " --report " + report_dir);
  }
};

}  // namespace

std::unique_ptr<Command> make_diagnose_command() { return std::make_unique<DiagnoseCommand>(); }

}  // namespace feedid::host::cli
