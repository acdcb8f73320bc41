// `feedid diagnose` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "diagnose/diagnose.hpp"
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
  std::string json_path, report_dir, method = "bands";
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("diagnose", "where the identified model misses a trace, which unmodelled effect causes it, and how far adding it shrinks the held-out gap");
    app->add_option("--in", in_path, "trace CSV or .mat; repeat to pool several recordings (folds stay within each)");
    app->add_option("--json", json_path, "write the diagnosis as JSON");
    app->add_option("--report", report_dir, "write pictures and a report page to this folder");
    add_identify_options(app, cols, input, opt.identify, method);
    app->add_option("--folds", opt.folds, "time folds; odd ones are held out")->capture_default_str();
    app->add_option("--block", opt.block_s, "residual block length (s)")->capture_default_str();
  }
  int run() override {
    if (method != "bands") {
      std::fprintf(stderr, "error: diagnose --method %s: the diagnosis refits the bands model's terms and has no "
                           "other method; use identify --method %s for that estimate\n", method.c_str(), method.c_str());
      return 2;
    }
    CsvResult csv;
    if (!read_trace(in_path, input, cols, csv)) return 2;
    Progress p("diagnose");
    if (csv.trace.samples.size() > 500000) opt.progress = std::ref(p);
    opt.identify.units = input.units();
    const DiagnoseResult r = diagnose(csv.trace, opt);
    if (!json_path.empty() && !write_json(json_path, to_json(r))) return 1;
    if (!r.error.empty()) { std::fprintf(stderr, "error: %s\n", r.error.c_str()); return 2; }
    note_force_outliers(r.force_outliers, opt.identify.units);
    std::cout << summary(r);
    return write_report(r, report_dir, csv.trace.source);
  }
};

}  // namespace

std::unique_ptr<Command> make_diagnose_command() { return std::make_unique<DiagnoseCommand>(); }

}  // namespace feedid::host::cli
