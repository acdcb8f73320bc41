// feedid: simulate a feed drive, identify mass and Stribeck friction from a
// trace, and (with later commands) diagnose the sim-to-real gap.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "bench/bench.hpp"
#include "bench/blind_bench.hpp"
#include "compensate/circle.hpp"
#include "bench/coverage.hpp"
#include "compensate/compensate.hpp"
#include "diagnose/diagnose.hpp"
#include "sim/drive_sim.hpp"
#include "identify/identify.hpp"
#include "identify/identify_stream.hpp"
#include "monitor/monitor.hpp"
#include "report/progress.hpp"
#include "report/report.hpp"
#include "sim_cli.hpp"
#include "io/trace_files.hpp"
#include "validate/validate.hpp"

using namespace feedid::host;

namespace {

void add_sim_options(CLI::App* c, SimConfig& s) {
  auto& d = s.drive;
  c->add_option("--mass", d.mass_kg, "equivalent mass (kg)")->capture_default_str();
  c->add_option("--sigma-pos", d.pos.viscous_Ns_m, "viscous coefficient, positive direction (N s/m)")->capture_default_str();
  c->add_option("--fc-pos", d.pos.coulomb_N, "Coulomb force, positive direction (N)")->capture_default_str();
  c->add_option("--fs-pos", d.pos.breakaway_N, "break-away excess, positive direction (N)")->capture_default_str();
  c->add_option("--vs-pos", d.pos.stribeck_velocity_m_s, "Stribeck velocity, positive direction (m/s)")->capture_default_str();
  c->add_option("--sigma-neg", d.neg.viscous_Ns_m, "viscous coefficient, negative direction (N s/m)")->capture_default_str();
  c->add_option("--fc-neg", d.neg.coulomb_N, "Coulomb force, negative direction (N)")->capture_default_str();
  c->add_option("--fs-neg", d.neg.breakaway_N, "break-away excess, negative direction (N)")->capture_default_str();
  c->add_option("--vs-neg", d.neg.stribeck_velocity_m_s, "Stribeck velocity, negative direction (m/s)")->capture_default_str();
  c->add_option("--rate", s.controller.servo_rate_hz, "servo and sampling rate (Hz)")->capture_default_str();
  c->add_option("--duration", s.motion.duration_s, "trace length (s)")->capture_default_str();
  c->add_option("--slowest-speed", s.motion.slowest_speed_m_s, "lowest stroke peak speed (m/s)")->capture_default_str();
  c->add_option("--fastest-speed", s.motion.fastest_speed_m_s, "highest stroke peak speed (m/s)")->capture_default_str();
  c->add_option_function<std::string>("--program", [&s](const std::string& v) { s.motion.program = parse_program(v); },
                                      "motion: ladder (reciprocating strokes at log-spaced speeds, default), sine (reciprocation whose "
                                      "amplitude and speed change every 2-4 cycles) or production (rapids, feeds, jogs, dwells)")
      ->check(CLI::IsMember({"ladder", "sine", "production"}));
  c->add_option_function<std::string>("--plant", [&s](const std::string& v) { s.plant = parse_plant(v); },
                                      "closed (the drive under its cascaded controller, default) or open (inverse dynamics "
                                      "along the reference: no controller, no stick/slip; docs/diagnosis.md)")
      ->check(CLI::IsMember({"closed", "open"}));
  c->add_option("--levels", s.motion.speed_levels, "number of log-spaced peak speeds")->capture_default_str();
  c->add_option("--accel", s.motion.acceleration_m_s2, "reference acceleration (m/s^2)")->capture_default_str();
  c->add_option("--travel", s.motion.max_travel_m, "maximum stroke (m)")->capture_default_str();
  c->add_option("--encoder", s.sensors.encoder_resolution_m, "encoder resolution (m)")->capture_default_str();
  c->add_option("--force-noise", s.sensors.force_noise_N, "std of recorded force noise (N)")->capture_default_str();
  c->add_option("--process-noise", s.sensors.force_process_noise_N, "std of disturbance force on the plant (N)")->capture_default_str();
  c->add_option("--velocity-bandwidth", s.controller.velocity_bandwidth_hz, "velocity loop bandwidth (Hz)")->capture_default_str();
  c->add_option("--seed", s.seed, "random seed")->capture_default_str();
  LoggingParams& lg = s.logging;
  c->add_option_function<std::string>("--force-log", [&lg](const std::string& v) { lg.force = parse_force_log(v); },
                                      "force logged as held (command over the next period, default), instant (at the tick) or averaged (over the last period)")
      ->check(CLI::IsMember({"held", "instant", "averaged"}));
  c->add_option_function<std::string>("--velocity-log", [&lg](const std::string& v) { lg.velocity = parse_velocity_log(v); },
                                      "velocity logged as backward (position difference, default), average (moving average) or lowpass (first order)")
      ->check(CLI::IsMember({"backward", "average", "lowpass"}));
  c->add_option("--velocity-log-samples", lg.velocity_average_samples, "samples of the logged moving average")->capture_default_str();
  c->add_option("--velocity-log-tau", lg.velocity_time_constant_s, "time constant of the logged low-pass (s)")->capture_default_str();
}

/// --bad-rows, for every command that reads a trace CSV.
void add_bad_row_option(CLI::App* c, CsvColumns& cols) {
  c->add_option_function<std::string>("--bad-rows", [&cols](const std::string& v) { cols.skip_bad_rows = v == "skip"; },
                                      "a non-finite or non-increasing row: skip (default: counted, the first named; more than 1 % "
                                      "is an error) or error")
      ->check(CLI::IsMember({"skip", "error"}));
}

/// The input options beside the columns: axis and force label (units.hpp), and a list of recordings.
struct InputOptions {
  Axis axis = Axis::linear;
  std::string force_label;
  std::string in_list;  ///< --in-list: recordings with their own options (read_input_list)
  Units units() const { return units_for(axis, force_label); }
};

/// Reads the traces (--in, then --in-list); prints the error, or a note of
/// the rows left out.
bool read_trace(const std::vector<std::string>& paths, const InputOptions& in, const CsvColumns& cols, CsvResult& out) {
  std::vector<TraceInput> inputs;
  for (const auto& p : paths) inputs.push_back({p, cols});
  std::string error;
  if (!in.in_list.empty() && !read_input_list(in.in_list, cols, inputs, error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return false;
  }
  if (inputs.empty()) {
    std::fprintf(stderr, "error: no recording: give --in FILE (repeatable) or --in-list FILE\n");
    return false;
  }
  out = read_trace_files(inputs);
  const std::string path = out.trace.source;
  if (!out.ok) {
    std::fprintf(stderr, "error: %s\n", out.error.c_str());
    return false;
  }
  const Trace& t = out.trace;
  if (t.rows_skipped > 0)
    std::fprintf(stderr, "note: %s: skipped %zu bad row%s (--bad-rows error to stop instead); first: %s\n", path.c_str(),
                 t.rows_skipped, t.rows_skipped == 1 ? "" : "s", t.skipped_rows.front().c_str());
  if (t.rows_repeated > 0)
    std::fprintf(stderr, "note: %s: %zu row%s repeated the row before exactly and %s left out\n", path.c_str(),
                 t.rows_repeated, t.rows_repeated == 1 ? "" : "s", t.rows_repeated == 1 ? "was" : "were");
  return true;
}

/// Columns, scales, units and bad rows: the input options of every command
/// that reads a trace CSV.
void add_input_options(CLI::App* c, CsvColumns& cols, InputOptions& u) {
  add_bad_row_option(c, cols);
  c->add_option("--in-list", u.in_list,
                "file listing recordings, one per line: path [time=.. position=.. velocity=.. force=.. position-scale=.. "
                "force-scale=..] to override the options for that file");
  c->add_option("--time", cols.time, "CSV column or .mat variable of time (s)")->capture_default_str();
  c->add_option("--position", cols.position, "CSV column or .mat variable of position (m; rad with --axis rotary)")->capture_default_str();
  c->add_option("--velocity", cols.velocity,
                "CSV column or .mat variable of velocity (m/s; rad/s with --axis rotary); optional where position is logged")->capture_default_str();
  c->add_option("--force", cols.force, "CSV column or .mat variable of drive force (N; N m with --axis rotary)")->capture_default_str();
  c->add_option("--position-scale", cols.position_scale,
                "multiplies position and velocity as they are read, e.g. m (or rad) per encoder count")->capture_default_str();
  c->add_option("--force-scale", cols.force_scale,
                "multiplies force as it is read, e.g. N per A (torque constant x gear ratio x 2 pi / lead), or N m per A")
      ->capture_default_str();
  c->add_option_function<std::string>("--axis", [&u](const std::string& v) { u.axis = v == "rotary" ? Axis::rotary : Axis::linear; },
                                      "linear (m, m/s, N, kg; default) or rotary (rad, rad/s, N m, kg m^2)")
      ->check(CLI::IsMember({"linear", "rotary"}));
  c->add_option("--force-unit", u.force_label,
                "unit label of a force input left unscaled, e.g. V or A; mass and viscous units follow (V s^2/rad, V s/rad)");
}

void add_identify_options(CLI::App* c, CsvColumns& cols, InputOptions& units, IdentifyOptions& o, std::string& method) {
  add_input_options(c, cols, units);
  c->add_option("--method", method, "bands (default) or paper (the seed paper's literal regression)")
      ->check(CLI::IsMember({"bands", "paper"}))->capture_default_str();
  c->add_option("--alignment", o.alignment,
                "force/velocity pairing: auto, held-backward, held-instant, trapezoid (docs/reference.md)")->capture_default_str();
  c->add_option("--force-lag-s", o.force_lag_s,
                "how far the logged force lags the logged velocity (s, negative: leads); overrides --alignment; default: estimated from the data");
  c->add_option("--velocity-lag-s", o.velocity_lag_s,
                "how far the logged velocity lags the motion (s; a position difference is half a period); default: estimated against position");
  c->add_option("--velocity-filter", o.velocity_filter_hz,
                "cut-off of the zero-phase filter on position whose derivative the core takes as velocity (Hz); 0 = the cut-off, 100 Hz to 0.4 of the rate, whose model leaves the least block residual")
      ->capture_default_str();
  c->add_option("--velocity-min", o.velocity_min_m_s, "lowest band edge (m/s, or rad/s); 0 = from the data")->capture_default_str();
  c->add_option("--velocity-resolution", o.velocity_resolution_m_s, "velocity resolution (m/s, or rad/s); 0 = from the data")
      ->capture_default_str();
}

bool write_json(const std::string& path, const nlohmann::json& j) {
  std::ofstream f(path);
  if (!f) { std::fprintf(stderr, "error: %s: cannot write\n", path.c_str()); return false; }
  f << j.dump(2) << "\n";
  return static_cast<bool>(f);
}

Trace run_simulation(const SimConfig& cfg) {
  Progress p("simulate");
  return simulate(cfg, cfg.motion.duration_s > 120 ? std::function<void(double)>(std::ref(p)) : nullptr);
}

int report_identify(const IdentifyResult& r, const std::string& json_path, const DriveParams* truth) {
  if (!json_path.empty()) {
    auto j = to_json(r);
    if (truth) j["truth"] = model_json(*truth);
    if (!write_json(json_path, j)) return 1;
  }
  if (!r.error.empty()) {
    std::fprintf(stderr, "error: %s\n", r.error.c_str());
    return 2;
  }
  std::cout << summary(r, truth);
  return 0;
}

/// Whether identify streams: asked, or one CSV above 512 MB (loading it
/// would take several times its size in memory).
bool streams(const std::vector<std::string>& paths, const InputOptions& in, bool asked) {
  if (paths.size() != 1 || !in.in_list.empty()) return false;
  const std::string& p = paths.front();
  if (is_mat_file(p)) return false;
  std::error_code ec;
  const auto size = std::filesystem::file_size(p, ec);
  return asked || (!ec && size > (512ull << 20));
}

int run_monitor(const std::string& path, const InputOptions& in, const CsvColumns& cols, const std::string& json_path,
                const std::string& plot_path, MonitorOptions opt) {
  if (!in.in_list.empty()) {
    std::fprintf(stderr, "error: monitor reads one log (--in); --in-list is for identify, validate and diagnose\n");
    return 2;
  }
  CsvStream stream(path, cols);
  if (!stream.ok()) {
    std::fprintf(stderr, "error: %s\n", stream.error().c_str());
    return 2;
  }
  opt.identify.units = in.units();
  StreamProgress progress("monitor");
  opt.progress = [&progress](double t) { progress(t); };
  const MonitorResult r = monitor(stream, opt);
  progress.done();
  std::cout << trend_table(r);
  if (!json_path.empty() && !write_json(json_path, to_json(r, opt))) return 1;
  std::string err;
  if (!plot_path.empty() && !write_trend_svg(r, plot_path, err)) {
    std::fprintf(stderr, "error: %s\n", err.c_str());
    return 1;
  }
  if (!r.error.empty()) {
    std::fprintf(stderr, "error: %s\n", r.error.c_str());
    return 2;
  }
  return 0;
}

/// The diagnosis page, if a folder was given; the exit code.
int write_report(const DiagnoseResult& r, const std::string& dir, const std::string& source) {
  if (dir.empty()) return 0;
  std::string err;
  if (!write_diagnosis_report(r, dir, source, err)) { std::fprintf(stderr, "error: %s\n", err.c_str()); return 1; }
  std::printf("report: %s/report.html\n", dir.c_str());
  return 0;
}

/// One subcommand: its options (add) and what it does (run).
struct Command {
  CLI::App* app = nullptr;
  virtual ~Command() = default;
  virtual void add(CLI::App& parent) = 0;
  virtual int run() = 0;
};

struct SimulateCommand : Command {
  SimConfig sim;
  std::string out_path, truth_path;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("simulate", "simulate a closed-loop feed drive and write a trace CSV (t,x,v,u)");
    add_sim_options(app, sim);
    add_effect_options(app, sim.effects);
    add_change_options(app, sim.change);
    app->add_option("--out", out_path, "trace CSV to write")->required();
    app->add_option("--truth", truth_path, "also write the true parameters as JSON");
  }
  int run() override {
    const Trace t = run_simulation(sim);
    std::string err;
    if (!write_trace_csv(out_path, t, err)) { std::fprintf(stderr, "error: %s\n", err.c_str()); return 1; }
    if (!truth_path.empty()) {
      nlohmann::json tj = model_json(sim.drive);
      tj["effects"] = effects_json(sim.effects, sim.drive);
      if (!write_json(truth_path, tj)) return 1;
    }
    std::printf("wrote %s: %zu samples, %.3g s at %.6g Hz\n", out_path.c_str(), t.samples.size(), sim.motion.duration_s,
                sim.controller.servo_rate_hz);
    return 0;
  }
};

struct IdentifyCommand : Command {
  CsvColumns cols;
  InputOptions input;
  IdentifyOptions opt;
  std::vector<std::string> in_path;
  std::string json_path, method = "bands", plot_path;
  bool stream = false;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("identify", "identify the nine parameters from a trace CSV");
    app->add_option("--in", in_path, "trace CSV (header row) or MATLAB .mat (v4, v5, v7.3); repeat to pool several recordings into one model");
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
    StreamProgress progress("identify");
    opt.progress = [&progress](double t) { progress(t); };
    const IdentifyResult r = identify_stream(in, in_path.front(), opt);
    progress.done();
    return report_identify(r, json_path, nullptr);
  }
};

struct ValidateCommand : Command {
  std::vector<std::string> in_path;
  std::string model_path, json_path, plot_path;
  CsvColumns cols;
  InputOptions input;
  ValidateOptions opt;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("validate", "predict the force of another trace with an identified model; relative error as the EMPS protocol computes it");
    app->add_option("--model", model_path, "model JSON (from identify, or a truth file)")->required();
    app->add_option("--in", in_path, "trace CSV or .mat to predict; repeat for several recordings");
    app->add_option("--json", json_path, "write the result as JSON");
    add_input_options(app, cols, input);
    app->add_option("--filter", opt.filter_hz, "zero-phase Butterworth cut-off on position (Hz)")->capture_default_str();
    app->add_option("--decimate", opt.decimate, "decimation factor of the protocol (1 = none)")->capture_default_str();
    app->add_option("--drop-first", opt.drop_first, "samples dropped at the start")->capture_default_str();
    app->add_option("--plot", plot_path, "write measured against predicted force as SVG");
  }
  int run() override {
    const DriveParams model = model_from_json(read_json_file(model_path));  // errors reach main's handler
    CsvResult csv;
    if (!read_trace(in_path, input, cols, csv)) return 2;
    opt.units = input.units();
    const ValidateResult r = validate(model, csv.trace, opt);
    std::printf("relative force error %.4f %% (decimated by %d, %zu samples; %.4f %% at full rate); RMS %.4g %s\n",
                r.relative_error_pct, opt.decimate, r.samples_used, r.relative_error_full_pct, r.rms_error_N,
                r.units.force.c_str());
    if (!json_path.empty() && !write_json(json_path, to_json(r, model, opt))) return 1;
    std::string err;
    if (!plot_path.empty() && !write_force_plot_svg(r, plot_path, "Cross-test: " + csv.trace.source, err)) {
      std::fprintf(stderr, "error: %s\n", err.c_str());
      return 1;
    }
    return 0;
  }
};

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
    std::cout << summary(r);
    return write_report(r, report_dir, csv.trace.source);
  }
};

struct MonitorCommand : Command {
  MonitorOptions opt;
  CsvColumns cols;
  InputOptions input;
  std::string in_path, json_path, plot_path;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("monitor", "friction health: parameter trends per epoch and change alarms, streaming a log of any length in constant memory");
    app->add_option("--in", in_path, "log CSV, read row by row")->required();
    app->add_option("--json", json_path, "write epochs and alarms as JSON");
    app->add_option("--plot", plot_path, "write each parameter's trend with +-2 se bands and the alarms as SVG");
    app->add_option("--epoch-s", opt.detector.epoch_s, "epoch length (s)")->capture_default_str()->check(CLI::PositiveNumber);
    app->add_option("--reference-epochs", opt.detector.reference_epochs, "epochs pooled into each parameter's reference")
        ->capture_default_str()->check(CLI::Range(3, 16));
    app->add_option("--threshold", opt.detector.threshold, "CUSUM threshold h (docs/monitor.md: its false-alarm rate)")
        ->capture_default_str();
    add_input_options(app, cols, input);
  }
  int run() override { return run_monitor(in_path, input, cols, json_path, plot_path, opt); }
};

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

struct BlindBenchCommand : Command {
  BlindOptions opt;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("blind-bench", "diagnose many simulated traces whose effect is withheld, and score the verdicts");
    add_blind_bench_options(app, opt);
  }
  int run() override {
    Progress p("blind-bench");
    if (opt.quiet) opt.progress = std::ref(p);
    return run_blind_bench(opt);
  }
};

struct CoverageCommand : Command {
  CoverageOptions opt;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("coverage", "Monte Carlo over drives, force logs and velocity filters: do estimate +- 1.96 se hold the truth 95 % of the time? RMSE against batch LM (docs/coverage.md)");
    app->add_option("--seeds", opt.seeds, "traces per drive and force convention")->capture_default_str();
    app->add_option("--first-seed", opt.first_seed, "seed of the first trace")->capture_default_str();
    app->add_option("--duration", opt.duration_s, "length of each trace (s)")->capture_default_str();
    app->add_option("--lm-every", opt.lm_every, "run batch LM on every n-th seed (0 = never)")->capture_default_str();
    app->add_option("--threads", opt.threads, "worker threads")->capture_default_str();
    app->add_option("--json", opt.json_path, "write every trace's errors and standard errors as JSON");
    app->add_option("--markdown", opt.markdown_path, "write the tables as Markdown");
  }
  int run() override {
    Progress p("coverage");
    opt.progress = std::ref(p);
    return run_coverage(opt);
  }
};

struct BenchCommand : Command {
  BenchOptions bo;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("bench", "streaming core against batch LM, a genetic algorithm and RLS on the same traces (docs/benchmarks.md)");
    CLI::App* c = app;
    c->add_option("--json", bo.json_path, "write the results as JSON");
    c->add_option("--plot-dir", bo.plot_dir, "write SVG figures into this folder");
    c->add_flag("--core-only", bo.core_only, "push --samples simulated samples through the core and solve (no file I/O)");
    c->add_option("--samples", bo.samples, "core-only: samples to push")->capture_default_str();
    c->add_option("--precision", bo.precision, "core-only: float or double")->capture_default_str();
    c->add_flag("--quick", bo.quick, "two short traces, small GA budget");
    c->add_flag("--diagnose-cost", bo.diagnose_cost, "time and peak memory of diagnose against identify on one trace, as ratios");
    c->add_option("--cost-rate", bo.cost_rate_hz, "diagnose-cost: sample rate (Hz)")->capture_default_str();
    c->add_option("--cost-duration", bo.cost_duration_s, "diagnose-cost: trace length (s)")->capture_default_str();
    c->add_flag("--scaling", bo.scaling, "time and memory against trace length instead of the default set");
    c->add_option("--max-samples", bo.max_samples, "scaling: longest trace (samples)")->capture_default_str();
    c->add_option("--ga-max-samples", bo.ga_max_samples, "scaling: longest trace the GA runs on")->capture_default_str();
    c->add_option("--methods", bo.methods, "comma-separated subset of streaming,batch_lm,ga,rls");
    c->add_option("--repeats", bo.repeats, "timing: fastest of this many runs")->capture_default_str();
    c->add_option("--ga-population", bo.ga_population, "GA population")->capture_default_str();
    c->add_option("--ga-generations", bo.ga_generations, "GA generations")->capture_default_str();
    c->add_option("--filter-hz", bo.filter_hz, "batch_lm, ga: zero-phase Butterworth cut-off before differencing (Hz); 0 = none")->capture_default_str();
    c->add_flag("--lm-naive-start", bo.lm_naive_start, "batch_lm: textbook start (Fs = 0.2 Fc, vs = median speed)");
  }
  int run() override { return run_bench(bo); }
};

struct DemoCommand : Command {
  SimConfig sim;
  std::string json_path, report_dir;
  DemoCommand() {
    // The built-in default has a 3 N screw-pitch ripple of 5 mm that the
    // model does not know, so the diagnosis has something to find.
    sim.effects.ripple_amplitude_N = 3.0;
    sim.effects.ripple_period_m = 0.005;
  }
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("demo", "built-in default: simulate a drive (with a 3 N, 5 mm position ripple), identify it, diagnose it, compare with the truth");
    add_sim_options(app, sim);
    add_effect_options(app, sim.effects);
    app->add_option("--json", json_path, "write the identification result as JSON");
    app->add_option("--report", report_dir, "write the diagnosis pictures and page to this folder");
  }
  int run() override {
    std::printf("== simulate: %.3g kg drive, %.6g Hz, %.3g s, encoder %.3g m, force noise %.3g N (seed %llu)\n",
                sim.drive.mass_kg, sim.controller.servo_rate_hz, sim.motion.duration_s, sim.sensors.encoder_resolution_m,
                sim.sensors.force_noise_N, static_cast<unsigned long long>(sim.seed));
    const std::vector<std::string> fx = active_effects(sim.effects);
    std::printf("   unmodelled effects in the simulated drive (hidden from identify/diagnose): ");
    for (const auto& e : fx) std::printf("%s ", e.c_str());
    std::printf("%s\n   truth: %s\n", fx.empty() ? "none" : "", effects_json(sim.effects, sim.drive).dump().c_str());
    const Trace t = run_simulation(sim);
    std::printf("== identify (streaming core, double; the unmodelled effect biases some parameters):\n");
    const int rc = report_identify(identify(t, IdentifyOptions{}), json_path, &sim.drive);
    if (rc != 0) return rc;
    std::printf("== diagnose (base model on even time folds, judged on the odd ones):\n");
    const DiagnoseResult d = diagnose(t, DiagnoseOptions{});
    if (!d.error.empty()) { std::fprintf(stderr, "error: %s\n", d.error.c_str()); return 2; }
    std::cout << summary(d);
    if (d.has_augmented_model) print_against_truth(d, sim.drive);
    return write_report(d, report_dir, "feedid demo");
  }
  static void print_against_truth(const DiagnoseResult& d, const DriveParams& t) {
    const DriveParams& a = d.augmented_model;
    std::printf("== the model with %s added (joint fit on the identification folds), against the truth:\n", d.effect.c_str());
    auto row = [](const char* n, const char* unit, double v, double tv) {
      std::printf("  %-22s %12.6g %-6s truth %-11.6g err %+7.3f %%\n", n, v, unit, tv, 100.0 * (v / tv - 1.0));
    };
    row("mass m", "kg", a.mass_kg, t.mass_kg);
    for (int dir = 0; dir < 2; ++dir) {
      const DirectionFriction& x = dir == 0 ? a.pos : a.neg;
      const DirectionFriction& y = dir == 0 ? t.pos : t.neg;
      const std::string sg = dir == 0 ? "+" : "-";
      row(("viscous sigma" + sg).c_str(), "N s/m", x.viscous_Ns_m, y.viscous_Ns_m);
      row(("Coulomb Fc" + sg).c_str(), "N", x.coulomb_N, y.coulomb_N);
      row(("break-away Fs" + sg).c_str(), "N", x.breakaway_N, y.breakaway_N);
      row(("Stribeck vel. vs" + sg).c_str(), "m/s", x.stribeck_velocity_m_s, y.stribeck_velocity_m_s);
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"feedid: identify a feed drive's mass and Stribeck friction from a trace, and diagnose the sim-to-real gap"};
  app.require_subcommand(1);
  std::vector<std::unique_ptr<Command>> commands;
  commands.push_back(std::make_unique<SimulateCommand>());
  commands.push_back(std::make_unique<IdentifyCommand>());
  commands.push_back(std::make_unique<DemoCommand>());
  commands.push_back(std::make_unique<ValidateCommand>());
  commands.push_back(std::make_unique<DiagnoseCommand>());
  commands.push_back(std::make_unique<MonitorCommand>());
  commands.push_back(std::make_unique<CompensateCommand>());
  commands.push_back(std::make_unique<CircleCommand>());
  commands.push_back(std::make_unique<BlindBenchCommand>());
  commands.push_back(std::make_unique<CoverageCommand>());
  commands.push_back(std::make_unique<BenchCommand>());
  for (auto& c : commands) c->add(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    for (auto& c : commands)
      if (*c->app) return c->run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  return 0;
}
