// What the subcommands share: option groups, reading the input, writing
// JSON and reports, and the Command interface each subcommand implements
// (one file per subcommand in this folder; main.cpp lists them).
#pragma once
#include <CLI/CLI.hpp>

#include <memory>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "diagnose/diagnose.hpp"
#include "identify/identify.hpp"
#include "io/csv_trace.hpp"
#include "monitor/monitor.hpp"
#include "sim/drive_sim.hpp"

namespace feedid::host::cli {

/// The CLI's one way to end on an error (io/outcome.hpp): prints "error: "
/// and why on stderr and returns the exit code, 2 for bad input (a file, a
/// column, an option, a trace that cannot be identified)...
int bad_input(const std::string& why);
/// ... and 1 for an output that could not be written.
int output_failed(const std::string& why);
/// The end of a run that printed its own tables (bench, coverage,
/// blind-bench): says what was refused (exit 2) or not written (exit 1);
/// 3 where a bar it checks was missed, else 0.
int end_of_run(const RunEnd& end);
/// Each warning (an unknown key in a file) on stderr.
void warn(const std::vector<std::string>& warnings);

/// The drive, controller, motion and sensor options of simulate and demo.
void add_sim_options(CLI::App* c, SimConfig& s);

/// --bad-rows, for every command that reads a trace CSV.
void add_bad_row_option(CLI::App* c, CsvColumns& cols);

/// The input options beside the columns: axis and force label (units.hpp), and a list of recordings.
struct InputOptions {
  Axis axis = Axis::linear;
  std::string force_label;
  std::string in_list;  ///< --in-list: recordings with their own options (read_input_list)
  Units units() const { return units_for(axis, force_label); }
};

/// Reads the traces (--in, then --in-list); prints the error, or a note of
/// the rows left out.
bool read_trace(const std::vector<std::string>& paths, const InputOptions& in, const CsvColumns& cols, CsvResult& out);

/// Columns, scales, units and bad rows: the input options of every command
/// that reads a trace CSV.
void add_input_options(CLI::App* c, CsvColumns& cols, InputOptions& u);

/// The options of identify and diagnose: input, conventions, method.
void add_identify_options(CLI::App* c, CsvColumns& cols, InputOptions& units, IdentifyOptions& o, std::string& method);

/// Writes j to path; prints the error and returns false when it cannot. A
/// failed run's JSON (a top-level "error") keeps the earlier result it
/// replaces as <stem>.prev<ext> beside it; where that cannot be kept, the
/// report is not written (said on stderr) and true is returned, so that
/// the caller says the run's own error and exits with it.
bool write_json(const std::string& path, const nlohmann::json& j, const std::vector<std::string>& inputs = {});

/// After a failed run (exit `rc`) of the parsed subcommand: where its --json
/// names a file that holds an earlier result and this run wrote none (it
/// failed reading its input, model or controller), the file is replaced
/// by one that says the run failed, the earlier result kept beside it as
/// write_json keeps it: an exit 2 left the last run's "status ok" where a
/// pipeline reads this one's. A JSON this run wrote (its own error) stays.
void say_failure_where_json_was(const CLI::App& sub, int rc, std::filesystem::file_time_type run_start);

/// A number option that must be finite and above 0, its message "<value>
/// <unit>: must be > 0<remedy>" (0 or less was read as "not given").
CLI::Validator positive_number(const std::string& unit, const std::string& remedy);

/// Why the parsed subcommand would write an output over one of its inputs
/// (--json, --jsonl, --out, --plot, --truth, --friction-plot, --markdown or
/// --model-out naming the file of --in, --model, --in-list or --controller;
/// a --report folder holding an input named report.html or *.svg), or two
/// outputs into one file; empty when none. Checked once, in main, before
/// any command runs.
std::string output_over_input(const CLI::App& sub);

/// Why an output of the parsed subcommand cannot be written where it is
/// named: a file output whose folder does not exist or that names a
/// folder, a --report or --plot-dir that is a file; empty when none.
/// Checked in main before the command runs: found after a long run, it
/// left the run's other outputs written and this one not.
std::string output_unwritable(const CLI::App& sub);

/// simulate() with progress on stderr, or why the options cannot be simulated.
Outcome<Trace> run_simulation(const SimConfig& cfg);

/// Prints the identify summary, writes its JSON if asked; the exit code.
int report_identify(const IdentifyResult& r, const std::string& json_path, const DriveParams* truth);
/// A note on stderr of the rows a reader left out: the bad ones counted and
/// the first few named (file:line and why), the repeated ones counted. Every
/// reader's, whole-file or streamed, is said this way (nothing if none).
void note_skipped_rows(const std::string& path, std::size_t skipped, std::size_t repeated,
                       const std::vector<std::string>& first_skipped);
/// A note on stderr of each thing the reader did with a file's format
/// (Trace::notes: lines left out before the header, ISO 8601 stamps).
void note_format(const std::vector<std::string>& notes, std::size_t from = 0);
/// A note on stderr of the force rows left out as outliers, naming the first (nothing if none).
void note_force_outliers(const ForceOutliers& out, const Units& units);

/// Whether identify streams: asked, or one CSV above 512 MB (loading it
/// would take several times its size in memory).
bool streams(const std::vector<std::string>& paths, const InputOptions& in, bool asked);

/// `feedid monitor` on one log, streamed; the exit code.
int run_monitor(const std::string& path, const InputOptions& in, const CsvColumns& cols, const std::string& json_path,
                const std::string& plot_path, const std::string& jsonl_path, MonitorOptions opt);

/// The command line this process was started with, each word quoted for a
/// POSIX shell where it needs it, so that a report's "made by" can be
/// rerun as it stands; `fallback` where the system does not tell it.
std::string command_as_typed(const std::string& fallback);

/// The diagnosis page, if a folder was given; the exit code. `fallback`
/// names the command where command_as_typed cannot.
int write_report(const DiagnoseResult& r, const std::string& dir, const std::string& source,
                 const std::string& fallback);

/// One subcommand: its options (add) and what it does (run).
struct Command {
  CLI::App* app = nullptr;
  virtual ~Command() = default;
  virtual void add(CLI::App& parent) = 0;
  virtual int run() = 0;
};

std::unique_ptr<Command> make_simulate_command();
std::unique_ptr<Command> make_identify_command();
std::unique_ptr<Command> make_validate_command();
std::unique_ptr<Command> make_replay_command();
std::unique_ptr<Command> make_diagnose_command();
std::unique_ptr<Command> make_monitor_command();
std::unique_ptr<Command> make_compensate_command();
std::unique_ptr<Command> make_circle_command();
std::unique_ptr<Command> make_blind_bench_command();
std::unique_ptr<Command> make_coverage_command();
std::unique_ptr<Command> make_bench_command();
std::unique_ptr<Command> make_demo_command();

}  // namespace feedid::host::cli
