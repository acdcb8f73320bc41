// `feedid identify` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "identify/identify.hpp"
#include "identify/identify_stream.hpp"
#include "io/progress.hpp"
#include "report/report.hpp"
#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

struct IdentifyCommand : Command {
  CsvColumns cols;
  InputOptions input;
  IdentifyOptions opt;
  std::vector<std::string> in_path;
  std::string json_path, method = "bands", plot_path;
  bool stream = false;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("identify", "identify the nine parameters from a trace CSV");
    app->add_option("--in", in_path, "trace CSV (header row), MATLAB .mat (v4, v5, v7.3) or WPILib .wpilog; repeat to pool several recordings into one model");
    app->add_option("--json", json_path, "write the result as JSON");
    app->add_option("--friction-plot", plot_path, "write the friction curve (measured band means and model) as SVG");
    app->add_flag("--stream", stream,
                  "read the CSV row by row in bounded memory (automatic above 512 MB): conventions from its first 60 s, "
                  "jackknife standard errors over 10 s blocks");
    add_identify_options(app, cols, input, opt, method);
  }
  int run() override {
    opt.method = method == "paper" ? feedid::Method::paper : feedid::Method::bands;
    opt.units = input.units();
    if (streams(in_path, input, stream)) return run_streamed();
    CsvResult csv;
    if (!read_trace(in_path, input, cols, csv)) return 2;
    Progress p("identify");
    if (csv.trace.samples.size() > 2000000) opt.progress = std::ref(p);
    const IdentifyResult r = identify(csv.trace, opt);
    const int rc = report_identify(r, json_path, nullptr);
    if (rc == 0 && !plot_path.empty()) {
      std::string err;
      if (!write_friction_curve_svg(r, plot_path, err)) { std::fprintf(stderr, "error: %s\n", err.c_str()); return 1; }
    }
    return rc;
  }
  int run_streamed() {
    CsvStream in(in_path.front(), cols);
    if (!in.ok()) { std::fprintf(stderr, "error: %s\n", in.error().c_str()); return 2; }
    std::fprintf(stderr, "note: %s is read row by row (--stream)\n", in_path.front().c_str());
    note_format(in.notes());
    const std::size_t noted = in.notes().size();
    StreamProgress progress("identify");
    opt.progress = [&progress](double t) { progress(t); };
    const IdentifyResult r = identify_stream(in, in_path.front(), opt);
    progress.done();
    note_format(in.notes(), noted);  // decided at a later row: the time format where the first row's stamp did not read
    note_skipped_rows(in_path.front(), r.rows_skipped, r.rows_repeated, r.skipped_rows);
    return report_identify(r, json_path, nullptr);
  }
};

}  // namespace

std::unique_ptr<Command> make_identify_command() { return std::make_unique<IdentifyCommand>(); }

}  // namespace feedid::host::cli
