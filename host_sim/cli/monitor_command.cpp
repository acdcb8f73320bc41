// `feedid monitor` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "monitor/monitor.hpp"
#include "cli_common.hpp"


namespace feedid::host::cli {
namespace {

struct MonitorCommand : Command {
  MonitorOptions opt;
  CsvColumns cols;
  InputOptions input;
  std::string in_path, json_path, plot_path, jsonl_path;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("monitor", "friction health: parameter trends per epoch and change alarms, streaming a log of any length in constant memory");
    app->add_option("--in", in_path, "log: a CSV, read row by row, or a .mat or .wpilog, read whole")->required();
    app->add_option("--json", json_path, "write epochs and alarms as JSON");
    app->add_option("--jsonl", jsonl_path,
                    "write one JSON line per epoch and per alarm, a time series for a database (docs/monitor.md); - for stdout");
    app->add_option("--plot", plot_path, "write each parameter's trend with +-2 se bands and the alarms as SVG");
    app->add_option("--epoch-s", opt.detector.epoch_s, "epoch length (s)")->capture_default_str()->check(positive_number("s", ""));
    app->add_option("--reference-epochs", opt.detector.reference_epochs, "epochs pooled into each parameter's reference")
        ->capture_default_str()->check(CLI::Range(3, 16));
    app->add_option("--threshold", opt.detector.threshold, "CUSUM threshold h (docs/monitor.md: its false-alarm rate)")
        ->capture_default_str()->check(positive_number("(threshold)", ""));
    app->add_flag("--watch-stribeck", opt.detector.watch_stribeck,
                  "alarm on the break-away force and Stribeck velocity too (off: their epochs scatter beyond their "
                  "standard errors, docs/monitor.md)");
    app->add_option("--temperature", cols.temperature,
                    "column of the axis temperature: each reference is modelled against its epoch mean, so a warm-up "
                    "does not alarm (docs/monitor.md)");
    app->add_option("--load", cols.load,
                    "column of the load (payload, process force): each reference is modelled against its epoch mean");
    add_input_options(app, cols, input);
    app->get_option("--in-list")->group("");  // one log only: refused with the reason, not offered in --help
  }
  int run() override { return run_monitor(in_path, input, cols, json_path, plot_path, jsonl_path, opt); }
};

}  // namespace

std::unique_ptr<Command> make_monitor_command() { return std::make_unique<MonitorCommand>(); }

}  // namespace feedid::host::cli
