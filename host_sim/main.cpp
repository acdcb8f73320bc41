// feedid: simulate a feed drive, identify mass and Stribeck friction from a
// trace, and (with later commands) diagnose the sim-to-real gap.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "bench.hpp"
#include "blind_bench.hpp"
#include "circle.hpp"
#include "coverage.hpp"
#include "compensate.hpp"
#include "diagnose.hpp"
#include "drive_sim.hpp"
#include "identify.hpp"
#include "identify_stream.hpp"
#include "monitor.hpp"
#include "progress.hpp"
#include "report.hpp"
#include "sim_cli.hpp"
#include "trace_files.hpp"
#include "validate.hpp"

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
  if (p.size() >= 4 && (p.substr(p.size() - 4) == ".mat" || p.substr(p.size() - 4) == ".MAT")) return false;
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
  opt.progress = [](double t) { std::fprintf(stderr, "\rmonitor: %.0f s read", t); };
  const MonitorResult r = monitor(stream, opt);
  std::fprintf(stderr, "\n");
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"feedid: identify a feed drive's mass and Stribeck friction from a trace, and diagnose the sim-to-real gap"};
  app.require_subcommand(1);

  SimConfig sim;
  std::string out_path, truth_path;
  auto* c_sim = app.add_subcommand("simulate", "simulate a closed-loop feed drive and write a trace CSV (t,x,v,u)");
  add_sim_options(c_sim, sim);
  add_effect_options(c_sim, sim.effects);
  add_change_options(c_sim, sim.change);
  c_sim->add_option("--out", out_path, "trace CSV to write")->required();
  c_sim->add_option("--truth", truth_path, "also write the true parameters as JSON");

  CsvColumns cols;
  InputOptions id_units;
  IdentifyOptions idopt;
  std::vector<std::string> in_path;
  std::string json_path, method = "bands";
  auto* c_id = app.add_subcommand("identify", "identify the nine parameters from a trace CSV");
  c_id->add_option("--in", in_path, "trace CSV (header row) or MATLAB .mat (v4, v5, v7.3); repeat to pool several recordings into one model");
  c_id->add_option("--json", json_path, "write the result as JSON");
  std::string id_plot;
  c_id->add_option("--friction-plot", id_plot, "write the friction curve (measured band means and model) as SVG");
  bool id_stream = false;
  c_id->add_flag("--stream", id_stream,
                 "read the CSV row by row in bounded memory (automatic above 512 MB): conventions from its first 60 s, "
                 "the core's own standard errors");
  add_identify_options(c_id, cols, id_units, idopt, method);

  SimConfig demo_sim;
  // The built-in default has a 3 N screw-pitch ripple of 5 mm that the
  // model does not know, so the diagnosis has something to find.
  demo_sim.effects.ripple_amplitude_N = 3.0;
  demo_sim.effects.ripple_period_m = 0.005;
  std::string demo_json, demo_report;
  auto* c_demo = app.add_subcommand("demo", "built-in default: simulate a drive (with a 3 N, 5 mm position ripple), identify it, diagnose it, compare with the truth");
  add_sim_options(c_demo, demo_sim);
  add_effect_options(c_demo, demo_sim.effects);
  c_demo->add_option("--json", demo_json, "write the identification result as JSON");
  c_demo->add_option("--report", demo_report, "write the diagnosis pictures and page to this folder");

  std::vector<std::string> val_in;
  std::string model_path, val_json;
  CsvColumns val_cols;
  ValidateOptions valopt;
  auto* c_val = app.add_subcommand("validate", "predict the force of another trace with an identified model; relative error as the EMPS protocol computes it");
  c_val->add_option("--model", model_path, "model JSON (from identify, or a truth file)")->required();
  c_val->add_option("--in", val_in, "trace CSV or .mat to predict; repeat for several recordings");
  c_val->add_option("--json", val_json, "write the result as JSON");
  InputOptions val_units;
  add_input_options(c_val, val_cols, val_units);
  c_val->add_option("--filter", valopt.filter_hz, "zero-phase Butterworth cut-off on position (Hz)")->capture_default_str();
  c_val->add_option("--decimate", valopt.decimate, "decimation factor of the protocol (1 = none)")->capture_default_str();
  c_val->add_option("--drop-first", valopt.drop_first, "samples dropped at the start")->capture_default_str();
  std::string val_plot;
  c_val->add_option("--plot", val_plot, "write measured against predicted force as SVG");

  CsvColumns dg_cols;
  InputOptions dg_units;
  DiagnoseOptions dgopt;
  std::vector<std::string> dg_in;
  std::string dg_json, dg_report, dg_method = "bands";
  auto* c_dg = app.add_subcommand("diagnose", "where the identified model misses a trace, which unmodelled effect causes it, and how far adding it shrinks the held-out gap");
  c_dg->add_option("--in", dg_in, "trace CSV or .mat; repeat to pool several recordings (folds stay within each)");
  c_dg->add_option("--json", dg_json, "write the diagnosis as JSON");
  c_dg->add_option("--report", dg_report, "write pictures and a report page to this folder");
  add_identify_options(c_dg, dg_cols, dg_units, dgopt.identify, dg_method);
  c_dg->add_option("--folds", dgopt.folds, "time folds; odd ones are held out")->capture_default_str();
  c_dg->add_option("--block", dgopt.block_s, "residual block length (s)")->capture_default_str();

  MonitorOptions mon;
  CsvColumns mon_cols;
  InputOptions mon_units;
  std::string mon_in, mon_json, mon_plot;
  auto* c_mon = app.add_subcommand("monitor", "friction health: parameter trends per epoch and change alarms, streaming a log of any length in constant memory");
  c_mon->add_option("--in", mon_in, "log CSV, read row by row")->required();
  c_mon->add_option("--json", mon_json, "write epochs and alarms as JSON");
  c_mon->add_option("--plot", mon_plot, "write each parameter's trend with +-2 se bands and the alarms as SVG");
  c_mon->add_option("--epoch-s", mon.epoch_s, "epoch length (s)")->capture_default_str()->check(CLI::PositiveNumber);
  c_mon->add_option("--reference-epochs", mon.detector.reference_epochs, "epochs pooled into each parameter's reference")
      ->capture_default_str()->check(CLI::Range(3, 16));
  c_mon->add_option("--threshold", mon.detector.threshold, "CUSUM threshold h (docs/monitor.md: its false-alarm rate)")
      ->capture_default_str();
  add_input_options(c_mon, mon_cols, mon_units);

  CompensateOptions comp;
  std::string comp_model, comp_out, comp_format = "json";
  auto* c_comp = app.add_subcommand("compensate", "friction compensation a drive can load: a speed -> friction table per direction and the Coulomb + viscous form, from an identified model");
  c_comp->add_option("--model", comp_model, "model JSON from identify")->required();
  c_comp->add_option("--points", comp.points, "breakpoints per direction, speed 0 included (CNCs take about 20)")
      ->capture_default_str()->check(CLI::Range(2, 1000));
  c_comp->add_option("--format", comp_format, "json or csv")->check(CLI::IsMember({"json", "csv"}))->capture_default_str();
  c_comp->add_option("--out", comp_out, "file to write (default: standard output)");
  c_comp->add_option("--max-speed", comp.max_speed_m_s, "top of the table (m/s); default: the model's velocity_max_m_s");
  c_comp->add_option("--force-scale", comp.force_scale,
                     "N per drive unit, as identify's --force-scale (e.g. N per A); the table is also given in that unit")
      ->capture_default_str();
  c_comp->add_option("--force-unit", comp.force_unit, "label of the drive unit, e.g. A or %");

  CircleOptions circle;
  auto* c_circle = app.add_subcommand("circle", "closed-loop circle test on two simulated axes: quadrant glitches without, with the identified, and with +-20 % wrong friction compensation");
  c_circle->add_option("--radius", circle.radius_m, "circle radius (m)")->capture_default_str();
  c_circle->add_option("--feed", circle.feed_m_s, "path speed (m/s)")->capture_default_str();
  c_circle->add_option("--rate", circle.rate_hz, "servo rate of both axes (Hz)")->capture_default_str();
  c_circle->add_option("--wrong", circle.wrong_fraction, "the sensitivity runs scale every friction magnitude by 1 +- this")
      ->capture_default_str();
  c_circle->add_option("--model", circle.model_paths,
                       "compensation model JSON from identify: X, then Y; default: the simulated drives, identified on the spot");
  c_circle->add_option("--json", circle.json_path, "write runs.{none,identified,wrong_plus,wrong_minus}.{glitch_um,rms_um} as JSON");
  c_circle->add_option("--plot", circle.plot_path, "write the polar radial-error plot as SVG");

  BlindOptions blind;
  auto* c_blind = app.add_subcommand("blind-bench", "diagnose many simulated traces whose effect is withheld, and score the verdicts");
  add_blind_bench_options(c_blind, blind);

  CoverageOptions cov;
  auto* c_cov = app.add_subcommand("coverage", "Monte Carlo over drives, force logs and velocity filters: do estimate +- 1.96 se hold the truth 95 % of the time? RMSE against batch LM (docs/coverage.md)");
  c_cov->add_option("--seeds", cov.seeds, "traces per drive and force convention")->capture_default_str();
  c_cov->add_option("--first-seed", cov.first_seed, "seed of the first trace")->capture_default_str();
  c_cov->add_option("--duration", cov.duration_s, "length of each trace (s)")->capture_default_str();
  c_cov->add_option("--lm-every", cov.lm_every, "run batch LM on every n-th seed (0 = never)")->capture_default_str();
  c_cov->add_option("--threads", cov.threads, "worker threads")->capture_default_str();
  c_cov->add_option("--json", cov.json_path, "write every trace's errors and standard errors as JSON");
  c_cov->add_option("--markdown", cov.markdown_path, "write the tables as Markdown");

  BenchOptions bo;
  auto* c_bench = app.add_subcommand("bench", "streaming core against batch LM, a genetic algorithm and RLS on the same traces (docs/benchmarks.md)");
  c_bench->add_option("--json", bo.json_path, "write the results as JSON");
  c_bench->add_option("--plot-dir", bo.plot_dir, "write SVG figures into this folder");
  c_bench->add_flag("--core-only", bo.core_only, "push --samples simulated samples through the core and solve (no file I/O)");
  c_bench->add_option("--samples", bo.samples, "core-only: samples to push")->capture_default_str();
  c_bench->add_option("--precision", bo.precision, "core-only: float or double")->capture_default_str();
  c_bench->add_flag("--quick", bo.quick, "two short traces, small GA budget");
  c_bench->add_flag("--diagnose-cost", bo.diagnose_cost, "time and peak memory of diagnose against identify on one trace, as ratios");
  c_bench->add_option("--cost-rate", bo.cost_rate_hz, "diagnose-cost: sample rate (Hz)")->capture_default_str();
  c_bench->add_option("--cost-duration", bo.cost_duration_s, "diagnose-cost: trace length (s)")->capture_default_str();
  c_bench->add_flag("--scaling", bo.scaling, "time and memory against trace length instead of the default set");
  c_bench->add_option("--max-samples", bo.max_samples, "scaling: longest trace (samples)")->capture_default_str();
  c_bench->add_option("--ga-max-samples", bo.ga_max_samples, "scaling: longest trace the GA runs on")->capture_default_str();
  c_bench->add_option("--methods", bo.methods, "comma-separated subset of streaming,batch_lm,ga,rls");
  c_bench->add_option("--repeats", bo.repeats, "timing: fastest of this many runs")->capture_default_str();
  c_bench->add_option("--ga-population", bo.ga_population, "GA population")->capture_default_str();
  c_bench->add_option("--ga-generations", bo.ga_generations, "GA generations")->capture_default_str();
  c_bench->add_option("--filter-hz", bo.filter_hz, "batch_lm, ga: zero-phase Butterworth cut-off before differencing (Hz); 0 = none")->capture_default_str();
  c_bench->add_flag("--lm-naive-start", bo.lm_naive_start, "batch_lm: textbook start (Fs = 0.2 Fc, vs = median speed)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    if (*c_sim) {
      const Trace t = run_simulation(sim);
      std::string err;
      if (!write_trace_csv(out_path, t, err)) { std::fprintf(stderr, "error: %s\n", err.c_str()); return 1; }
      if (!truth_path.empty()) {
        nlohmann::json tj = model_json(sim.drive);
        tj["effects"] = effects_json(sim.effects, sim.drive);
        if (!write_json(truth_path, tj)) return 1;
      }
      std::printf("wrote %s: %zu samples, %.3g s at %.6g Hz\n", out_path.c_str(), t.samples.size(),
                  sim.motion.duration_s, sim.controller.servo_rate_hz);
      return 0;
    }
    if (*c_id) {
      idopt.method = method == "paper" ? feedid::Method::paper : feedid::Method::bands;
      idopt.units = id_units.units();
      if (streams(in_path, id_units, id_stream)) {
        CsvStream stream(in_path.front(), cols);
        if (!stream.ok()) { std::fprintf(stderr, "error: %s\n", stream.error().c_str()); return 2; }
        std::fprintf(stderr, "note: %s is read row by row (--stream)\n", in_path.front().c_str());
        idopt.progress = [](double t) { std::fprintf(stderr, "\ridentify: %.0f s read", t); };
        const IdentifyResult r = identify_stream(stream, in_path.front(), idopt);
        std::fprintf(stderr, "\n");
        return report_identify(r, json_path, nullptr);
      }
      CsvResult csv;
      if (!read_trace(in_path, id_units, cols, csv)) return 2;
      Progress p("identify");
      if (csv.trace.samples.size() > 2000000) idopt.progress = std::ref(p);
      const IdentifyResult r = identify(csv.trace, idopt);
      const int rc = report_identify(r, json_path, nullptr);
      if (rc == 0 && !id_plot.empty()) {
        std::string err;
        if (!write_friction_curve_svg(r, id_plot, err)) { std::fprintf(stderr, "error: %s\n", err.c_str()); return 1; }
      }
      return rc;
    }
    if (*c_val) {
      std::ifstream mf(model_path);
      if (!mf) { std::fprintf(stderr, "error: %s: cannot open\n", model_path.c_str()); return 2; }
      nlohmann::json mj;
      try { mf >> mj; } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s: not valid JSON: %s\n", model_path.c_str(), e.what());
        return 2;
      }
      const DriveParams model = model_from_json(mj);
      CsvResult csv;
      if (!read_trace(val_in, val_units, val_cols, csv)) return 2;
      valopt.units = val_units.units();
      const ValidateResult r = validate(model, csv.trace, valopt);
      std::printf("relative force error %.4f %% (decimated by %d, %zu samples; %.4f %% at full rate); RMS %.4g %s\n",
                  r.relative_error_pct, valopt.decimate, r.samples_used, r.relative_error_full_pct, r.rms_error_N,
                  r.units.force.c_str());
      if (!val_json.empty() && !write_json(val_json, to_json(r, model, valopt))) return 1;
      if (!val_plot.empty()) {
        std::string err;
        if (!write_force_plot_svg(r, val_plot, "Cross-test: " + csv.trace.source, err)) { std::fprintf(stderr, "error: %s\n", err.c_str()); return 1; }
      }
      return 0;
    }
    if (*c_dg) {
      if (dg_method != "bands") {
        std::fprintf(stderr, "error: diagnose --method %s: the diagnosis refits the bands model's terms and has no "
                             "other method; use identify --method %s for that estimate\n", dg_method.c_str(), dg_method.c_str());
        return 2;
      }
      CsvResult csv;
      if (!read_trace(dg_in, dg_units, dg_cols, csv)) return 2;
      Progress p("diagnose");
      if (csv.trace.samples.size() > 500000) dgopt.progress = std::ref(p);
      dgopt.identify.units = dg_units.units();
      const DiagnoseResult r = diagnose(csv.trace, dgopt);
      if (!dg_json.empty() && !write_json(dg_json, to_json(r))) return 1;
      if (!r.error.empty()) { std::fprintf(stderr, "error: %s\n", r.error.c_str()); return 2; }
      std::cout << summary(r);
      if (!dg_report.empty()) {
        std::string err;
        if (!write_diagnosis_report(r, dg_report, csv.trace.source, err)) { std::fprintf(stderr, "error: %s\n", err.c_str()); return 1; }
        std::printf("report: %s/report.html\n", dg_report.c_str());
      }
      return 0;
    }
    if (*c_mon) return run_monitor(mon_in, mon_units, mon_cols, mon_json, mon_plot, mon);
    if (*c_comp) return run_compensate(comp_model, comp_out, comp_format, comp);
    if (*c_circle) return run_circle_command(circle);
    if (*c_bench) return run_bench(bo);
    if (*c_cov) {
      Progress p("coverage");
      cov.progress = std::ref(p);
      return run_coverage(cov);
    }
    if (*c_blind) {
      Progress p("blind-bench");
      if (blind.quiet) blind.progress = std::ref(p);
      return run_blind_bench(blind);
    }
    if (*c_demo) {
      std::printf("== simulate: %.3g kg drive, %.6g Hz, %.3g s, encoder %.3g m, force noise %.3g N (seed %llu)\n",
                  demo_sim.drive.mass_kg, demo_sim.controller.servo_rate_hz, demo_sim.motion.duration_s,
                  demo_sim.sensors.encoder_resolution_m, demo_sim.sensors.force_noise_N,
                  static_cast<unsigned long long>(demo_sim.seed));
      const std::vector<std::string> fx = active_effects(demo_sim.effects);
      std::printf("   unmodelled effects in the simulated drive (hidden from identify/diagnose): ");
      for (const auto& e : fx) std::printf("%s ", e.c_str());
      std::printf("%s\n   truth: %s\n", fx.empty() ? "none" : "", effects_json(demo_sim.effects, demo_sim.drive).dump().c_str());
      const Trace t = run_simulation(demo_sim);
      std::printf("== identify (streaming core, double; the unmodelled effect biases some parameters):\n");
      const int rc = report_identify(identify(t, idopt), demo_json, &demo_sim.drive);
      if (rc != 0) return rc;
      std::printf("== diagnose (base model on even time folds, judged on the odd ones):\n");
      const DiagnoseResult d = diagnose(t, DiagnoseOptions{});
      if (!d.error.empty()) { std::fprintf(stderr, "error: %s\n", d.error.c_str()); return 2; }
      std::cout << summary(d);
      if (d.has_augmented_model) {
        const DriveParams& a = d.augmented_model;
        const DriveParams& t = demo_sim.drive;
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
      if (!demo_report.empty()) {
        std::string err;
        if (!write_diagnosis_report(d, demo_report, "feedid demo", err)) { std::fprintf(stderr, "error: %s\n", err.c_str()); return 1; }
        std::printf("report: %s/report.html\n", demo_report.c_str());
      }
      return 0;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  return 0;
}
