// What the subcommands share (cli_common.hpp).
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <memory>

#include "identify/gravity.hpp"
#include "io/progress.hpp"
#include "io/output_file.hpp"
#include "report/report.hpp"
#include "io/trace_files.hpp"
#include "signals/filters.hpp"

#include "cli_common.hpp"

#include "identify/gravity.hpp"

namespace feedid::host::cli {

int bad_input(const std::string& why) {
  std::fprintf(stderr, "error: %s\n", why.c_str());
  return 2;
}

int output_failed(const std::string& why) {
  std::fprintf(stderr, "error: %s\n", why.c_str());
  return 1;
}

int end_of_run(const RunEnd& end) {
  if (!end.bad_input.empty()) return bad_input(end.bad_input);
  for (const std::string& e : end.not_written) output_failed(e);
  if (!end.not_written.empty()) return 1;
  return end.bar_missed ? 3 : 0;
}

void warn(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
}

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
  c->add_option_function<std::string>("--program", [&s](const std::string& v) { s.motion.program = parse_program(v).value; },
                                      "motion: ladder (reciprocating strokes at log-spaced speeds, default), sine (reciprocation whose "
                                      "amplitude and speed change every 2-4 cycles) or production (rapids, feeds, jogs, dwells)")
      ->check(CLI::IsMember({"ladder", "sine", "production"}));
  c->add_option_function<std::string>("--plant", [&s](const std::string& v) { s.plant = parse_plant(v).value; },
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
  c->add_option_function<std::string>("--force-log", [&lg](const std::string& v) { lg.force = parse_force_log(v).value; },
                                      "force logged as held (command over the next period, default), instant (at the tick) or averaged (over the last period)")
      ->check(CLI::IsMember({"held", "instant", "averaged"}));
  c->add_option_function<std::string>("--velocity-log", [&lg](const std::string& v) { lg.velocity = parse_velocity_log(v).value; },
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

namespace {
/// A note of each time column read in another unit than s from its name
/// (a log too slow for its unstated seconds is refused in condition()).
void note_time_unit(const std::vector<TraceInput>& inputs) {
  for (const TraceInput& in : inputs)
    if (in.columns.time_scale == 0.0 && time_unit_from_name(in.columns.time) != 1.0)
      std::fprintf(stderr, "note: %s: time column '%s' read as %g s per unit, from its name (--time-scale to override)\n",
                   in.path.c_str(), in.columns.time.c_str(), time_unit_from_name(in.columns.time));
  for (const TraceInput& in : inputs)
    if (position_scale(in.columns) != in.columns.position_scale)
      std::fprintf(stderr, "note: %s: position column '%s' read as %g m (or rad) per unit, and the velocity alike, from "
                   "its name (--position-scale to override)\n", in.path.c_str(), in.columns.position.c_str(),
                   position_scale(in.columns));
}
}  // namespace

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
  // Pooling a recording with itself is allowed (it is how a held-out check
  // is made), but never silently: its samples count twice.
  for (std::size_t i = 0; i < inputs.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (same_file(inputs[i].path, inputs[j].path))
        std::fprintf(stderr, "warning: %s is given twice (also as %s): its samples are pooled twice\n",
                     inputs[i].path.c_str(), inputs[j].path.c_str());
  out = read_trace_files(inputs);
  const std::string path = out.trace.source;
  if (!out.ok) {
    std::fprintf(stderr, "error: %s\n", out.error.c_str());
    return false;
  }
  const Trace& t = out.trace;
  note_time_unit(inputs);
  note_format(t.notes);
  note_skipped_rows(path, t.rows_skipped, t.rows_repeated, t.skipped_rows);
  return true;
}

void note_format(const std::vector<std::string>& notes, std::size_t from) {
  for (std::size_t i = from; i < notes.size(); ++i) std::fprintf(stderr, "note: %s\n", notes[i].c_str());
}

void note_skipped_rows(const std::string& path, std::size_t skipped, std::size_t repeated,
                       const std::vector<std::string>& first_skipped) {
  if (skipped > 0) {
    std::string named;
    for (const std::string& why : first_skipped) named += (named.empty() ? "" : "; ") + why;
    std::fprintf(stderr, "note: %s: skipped %zu bad row%s (--bad-rows error to stop instead); %s: %s\n", path.c_str(),
                 skipped, skipped == 1 ? "" : "s", first_skipped.size() == 1 ? "it" : "the first", named.c_str());
  }
  if (repeated > 0)
    std::fprintf(stderr, "note: %s: %zu row%s repeated the row before exactly and %s left out\n", path.c_str(),
                 repeated, repeated == 1 ? "" : "s", repeated == 1 ? "was" : "were");
}

namespace {
/// An option's text as a finite number, the whole of it; false otherwise.
bool finite_value(const std::string& v, double& x) {
  char* end = nullptr;
  x = std::strtod(v.c_str(), &end);
  return end != v.c_str() && *end == '\0' && std::isfinite(x);
}

/// A number option that must be finite: "nan" or "inf" were taken as
/// "from the data" (a NaN lag is the unset value), silently.
CLI::Validator finite_number() {
  return CLI::Validator(
      [](std::string& v) {
        double x = 0.0;
        return finite_value(v, x) ? std::string() : v + " is not a finite number";
      },
      "FINITE");
}
/// A cut-off, band edge or resolution: 0 means "from the data", a
/// negative value is an error rather than another way of saying 0.
CLI::Validator zero_or_positive() { return finite_number() & CLI::NonNegativeNumber; }
/// A scale that multiplies a column: finite and not zero.
CLI::Validator nonzero_scale() {
  return finite_number() & CLI::Validator(
                               [](std::string& v) { return std::strtod(v.c_str(), nullptr) != 0.0 ? std::string() : "a scale of 0"; },
                               "NONZERO");
}
}  // namespace

CLI::Validator positive_number(const std::string& unit, const std::string& remedy) {
  return CLI::Validator(
      [unit, remedy](std::string& v) {
        double x = 0.0;
        return finite_value(v, x) && x > 0.0 ? std::string() : v + " " + unit + ": must be > 0" + remedy;
      },
      "> 0");
}


namespace {
/// The options added to `c` since it had `from` of them go under `group` in --help.
void group_since(CLI::App* c, std::size_t from, const std::string& group) {
  const std::vector<CLI::Option*> all = c->get_options();
  for (std::size_t i = from; i < all.size(); ++i) all[i]->group(group);
}
}  // namespace

/// Columns, scales, units and bad rows: the input options of every command
/// that reads a trace CSV, in two help groups.
void add_input_options(CLI::App* c, CsvColumns& cols, InputOptions& u) {
  const std::size_t before_input = c->get_options().size();
  add_bad_row_option(c, cols);
  c->add_option("--in-list", u.in_list,
                "file listing recordings, one per line: path [time=.. position=.. velocity=.. force=.. columns=.. position-scale=.. "
                "force-scale=..] to override the options for that file");
  c->add_option_function<std::string>("--columns", [&cols](const std::string& v) { cols.names_by_position = names_by_position(v); },
                                      "names of the columns by position, for a CSV without a header row, e.g. t,x,u "
                                      "(an empty name: a column not read, t,,x,u)");
  c->add_option("--time", cols.time, "CSV column or .mat variable of time (s, or ISO 8601 stamps); in a .wpilog the entry whose records give the rows (where it has no such entry: the force entry)")->capture_default_str();
  c->add_option("--rate", cols.rate_hz, "sample rate (Hz) of a CSV without a time column: data row k is at k / rate")
      ->check(positive_number("Hz", ""));
  c->add_option("--position", cols.position,
                "CSV column, .mat variable or .wpilog entry of position (m; rad with --axis rotary); in a .mat also a struct field "
                "(rec.act_pos) or a matrix column (data(:,2) or data:2)")->capture_default_str();
  c->add_option("--velocity", cols.velocity,
                "CSV column, .mat variable or .wpilog entry of velocity (m/s; rad/s with --axis rotary); optional where position is logged")->capture_default_str();
  c->add_option("--force", cols.force, "CSV column, .mat variable or .wpilog entry of drive force (N; N m with --axis rotary)")->capture_default_str();
  group_since(c, before_input, "Input: files and columns");
  const std::size_t before_units = c->get_options().size();
  c->add_option("--position-scale", cols.position_scale,
                "multiplies position and velocity as they are read, e.g. m (or rad) per encoder count; default: from a "
                "unit ending the position column's name (x_mm, \"pos [um]\"), else 1")
      ->check(nonzero_scale())->capture_default_str()
      ->each([&cols](const std::string&) { cols.position_scale_stated = true; });
  c->add_option("--time-scale", cols.time_scale,
                "seconds per unit of the time column, e.g. 0.001 for ms; 0 (default): from a unit ending the column's "
                "name (t_ms, \"time [us]\"), else s")->check(zero_or_positive())->capture_default_str();
  c->add_option("--force-scale", cols.force_scale,
                "multiplies force as it is read, e.g. N per A (torque constant x gear ratio x 2 pi / lead), or N m per A")
      ->check(nonzero_scale())->capture_default_str();
  c->add_option_function<std::string>("--axis", [&u](const std::string& v) { u.axis = v == "rotary" ? Axis::rotary : Axis::linear; },
                                      "linear (m, m/s, N, kg; default) or rotary (rad, rad/s, N m, kg m^2)")
      ->check(CLI::IsMember({"linear", "rotary"}));
  c->add_option("--force-unit", u.force_label,
                "unit label of a force input left unscaled, e.g. V or A; mass and viscous units follow (V s^2/rad, V s/rad)");
  group_since(c, before_units, "Units and scales");
}

void add_identify_options(CLI::App* c, CsvColumns& cols, InputOptions& units, IdentifyOptions& o, std::string& method) {
  add_input_options(c, cols, units);
  c->add_option_function<std::string>(
       "--gravity",
       [&o](const std::string& v) { (void)gravity_from_name(v, o.gravity); },
       "a load that does not reverse with the motion, fitted and taken off the force first: auto (default: angle "
       "where the axis is rotary and the data show it, else none); none; constant (a vertical axis: G, with Coulomb "
       "friction the same both ways); angle (a rotary arm: G cos(q - q0), q in rad)")
      ->check(CLI::IsMember({"none", "constant", "angle", "auto"}));
  const std::size_t before_advanced = c->get_options().size();
  c->add_option("--method", method, "bands (default) or paper (the seed paper's literal regression)")
      ->check(CLI::IsMember({"bands", "paper"}))->capture_default_str();
  c->add_option("--alignment", o.alignment,
                "force/velocity pairing: auto, held-backward, held-instant, trapezoid (docs/reference.md; identify warns where the data put the lag elsewhere)")
      ->capture_default_str()
      ->each([&o](const std::string& v) { o.check_stated_lag = o.check_stated_lag || v != "auto"; });
  c->add_option("--force-lag-s", o.force_lag_s,
                "how far the logged force lags the logged velocity (s, negative: leads); overrides --alignment; default: estimated from the data (identify warns where the data put it elsewhere)")
      ->check(finite_number())
      ->each([&o](const std::string&) { o.check_stated_lag = true; });
  c->add_option("--velocity-lag-s", o.velocity_lag_s,
                "how far the logged velocity lags the motion (s; a position difference is half a period); default: estimated against position")
      ->check(finite_number());
  c->add_option("--velocity-filter", o.velocity_filter_hz,
                "cut-off of the zero-phase filter on position whose derivative the core takes as velocity (Hz); 0 = chosen from the data: of the cut-offs from 100 Hz (0.1 of the rate the position is updated at, if less) to 0.4 of the rate, the smoothest whose model's block residual is within a standard error of the least")
      ->check(zero_or_positive())->capture_default_str();
  c->add_option("--velocity-min", o.velocity_min_m_s, "lowest band edge (m/s, or rad/s); 0 = from the data")
      ->check(zero_or_positive())->capture_default_str();
  c->add_option("--velocity-resolution", o.velocity_resolution_m_s, "velocity resolution (m/s, or rad/s); 0 = from the data")
      ->check(zero_or_positive())->capture_default_str();
  group_since(c, before_advanced, "Advanced: method and signal timing (default: from the data)");
}

namespace {
/// Where a failed run keeps the result it would replace: axis.json -> axis.prev.json.
std::string previous_result_path(const std::string& path) {
  std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + ".prev" + p.extension().string())).string();
}

/// A failed run's JSON (a top-level "error") says why at `path`, so that
/// nothing reads an earlier "ok" there as this run's answer; but the earlier
/// result it replaces is no output to lose: it is kept, whole, beside it
/// first. Only a regular file is kept (through a link, beside its target;
/// not a stream such as /dev/stdout). False (with the reason printed)
/// where the keeping failed: then nothing is replaced.
bool keep_result_replaced_by_error(const std::string& path, const nlohmann::json& j,
                                   const std::vector<std::string>& inputs) {
  std::error_code ec;
  const std::string file = replaced_file(path);
  if (!j.is_object() || !j.contains("error") || file.empty() || !std::filesystem::is_regular_file(file, ec)) return true;
  std::ifstream in(file, std::ios::binary);
  const std::string earlier((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const nlohmann::json was = nlohmann::json::parse(earlier, nullptr, false);
  if (!was.is_object() || was.contains("error")) return true;  // an earlier failure, or no result of ours
  const std::string kept = previous_result_path(file);
  const std::string err = write_whole_file(kept, earlier, inputs);
  if (!err.empty()) {
    std::fprintf(stderr,
                 "error: %s, so %s is left as it was: it holds an EARLIER result, not this failed run's (its error "
                 "follows)\n",
                 err.c_str(), path.c_str());
    return false;
  }
  std::fprintf(stderr, "note: this run failed; the earlier result in %s is kept as %s\n", path.c_str(), kept.c_str());
  return true;
}
}  // namespace

bool write_json(const std::string& path, const nlohmann::json& j, const std::vector<std::string>& inputs) {
  // Where the earlier result could not be kept the report is not written;
  // the caller goes on to say the run's own error and exit with it.
  if (!keep_result_replaced_by_error(path, j, inputs)) return true;
  const std::string err = write_whole_file(path, json_as_written(j).dump(2) + "\n", inputs);
  if (!err.empty()) std::fprintf(stderr, "error: %s\n", err.c_str());
  return err.empty();
}

void say_failure_where_json_was(const CLI::App& sub, int rc, std::filesystem::file_time_type run_start) {
  const CLI::Option* opt = sub.get_option_no_throw("--json");
  if (rc == 0 || !opt || opt->count() == 0) return;
  const std::string path = opt->as<std::string>();
  std::error_code ec;
  if (path.empty() || path == "-" || !std::filesystem::is_regular_file(path, ec)) return;
  const auto written = std::filesystem::last_write_time(path, ec);
  if (ec || written >= run_start) return;  // this run's own report (its error), or unreadable
  const std::string kept = previous_result_path(path);
  if (std::filesystem::exists(kept, ec) && !std::filesystem::is_regular_file(kept, ec)) return;  // the run said it cannot keep it
  const nlohmann::json failed = {
      {"error", "this run failed (exit " + std::to_string(rc) + ") before it had a result; its error is on standard error"}};
  (void)write_json(path, failed);
}

std::string output_over_input(const CLI::App& sub) {
  auto values = [&sub](std::initializer_list<const char*> names) {
    std::vector<std::string> v;
    for (const char* n : names)
      if (const CLI::Option* o = sub.get_option_no_throw(n))
        for (const std::string& r : o->results()) v.push_back(r);
    return v;
  };
  namespace fs = std::filesystem;
  auto where = [](const fs::path& p) {
    std::error_code ec;
    const fs::path w = fs::weakly_canonical(p.empty() ? fs::path(".") : p, ec);
    return ec ? p : w;
  };
  const auto inputs = values({"--in", "--model", "--in-list", "--controller"});
  const auto outputs =
      values({"--json", "--jsonl", "--out", "--plot", "--truth", "--friction-plot", "--markdown", "--model-out"});
  for (const std::string& out : outputs)
    for (const std::string& in : inputs)
      if (same_file(out, in)) return out + ": refusing to write an output over the input " + in;
  // Where a failed run would keep the earlier --json result (write_json):
  // neither an input nor another output.
  std::vector<std::string> kept;
  for (const std::string& json : values({"--json"}))
    if (json != "-") kept.push_back(previous_result_path(json));
  for (const std::string& k : kept) {
    for (const std::string& in : inputs)
      if (same_file(k, in) || where(k) == where(in))
        return k + ": a failed run would keep the earlier --json result there, over the input " + in;
    for (const std::string& out : outputs)
      if (out != "-" && where(k) == where(out))
        return out + ": a failed run would keep the earlier --json result in this file; name another output";
  }
  // A report folder's own files (report.html and its SVG figures) over an input kept in it.
  for (const std::string& dir : values({"--report"}))
    for (const std::string& in : inputs) {
      const fs::path p(in);
      if ((p.filename() == "report.html" || p.extension() == ".svg") && where(p.parent_path()) == where(dir))
        return dir + ": refusing to write the report over the input " + in;
    }
  // Two outputs to one file: the second would replace the first.
  for (std::size_t i = 0; i < outputs.size(); ++i)
    for (std::size_t j = i + 1; j < outputs.size(); ++j)
      if (outputs[i] != "-" && where(outputs[i]) == where(outputs[j]))
        return outputs[j] + ": another output is written to this file too";
  return "";
}

std::string output_unwritable(const CLI::App& sub) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const char* name : {"--json", "--jsonl", "--out", "--plot", "--truth", "--friction-plot", "--markdown", "--model-out"}) {
    const CLI::Option* o = sub.get_option_no_throw(name);
    if (!o) continue;
    for (const std::string& out : o->results()) {
      if (out.empty() || out == "-") continue;
      const fs::path p(out), dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
      if (fs::is_directory(p, ec)) return std::string(name) + " " + out + ": is a folder; name a file";
      if (!fs::is_directory(dir, ec))
        return std::string(name) + " " + out + ": the folder " + dir.string() + " does not exist (nothing was run)";
    }
  }
  for (const char* name : {"--report", "--plot-dir"}) {
    const CLI::Option* o = sub.get_option_no_throw(name);
    if (!o) continue;
    for (const std::string& dir : o->results())
      if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
        return std::string(name) + " " + dir + ": is a file, not a folder (nothing was run)";
  }
  return "";
}

Outcome<Trace> run_simulation(const SimConfig& cfg) {
  if (std::string why = sim_config_error(cfg); !why.empty()) return refused<Trace>(std::move(why));
  Progress p("simulate");
  return {simulate(cfg, cfg.motion.duration_s > 120 ? std::function<void(double)>(std::ref(p)) : nullptr), ""};
}

void note_force_outliers(const ForceOutliers& out, const Units& units) {
  if (out.saturation.found()) std::fprintf(stderr, "note: force %s\n", out.saturation.describe(units.force).c_str());
  if (out.position_spikes.rows > 0)
    std::fprintf(stderr, "note: %s\n", out.position_spikes.describe(units.position).c_str());
  if (out.rows > 0)
    std::fprintf(stderr, "note: %s; first: %s\n", out.describe(units.force).c_str(), out.first.front().c_str());
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
  note_force_outliers(r.force_outliers, r.units);
  if (r.diagnostics.rejected_out_of_range > 0)
    std::fprintf(stderr, "note: the core rejected %llu sample%s out of range (speed beyond %g %s or force beyond %g %s; "
                 "counts.first_rejections names the first)\n",
                 static_cast<unsigned long long>(r.diagnostics.rejected_out_of_range),
                 r.diagnostics.rejected_out_of_range == 1 ? "" : "s", r.config.max_speed_m_s,
                 r.units.velocity().c_str(), r.config.max_force_N, r.units.force.c_str());
  std::cout << summary(r, truth);
  const std::string unphysical = not_physical(r);
  if (!unphysical.empty()) {
    std::fprintf(stderr, "error: the identified model is not physical: %s. Such a model pushes with the motion, and so "
                 "would a compensation from it. Likeliest cause: %s\n", unphysical.c_str(), not_physical_cause(r).c_str());
    return 2;
  }
  return 0;
}

/// Whether identify streams: asked, or one CSV above 512 MB (loading it
/// would take several times its size in memory).
bool streams(const std::vector<std::string>& paths, const InputOptions& in, bool asked) {
  // Said where --stream was asked for and cannot be had: the run reads the
  // input whole instead (a .mat run did so without a word).
  const auto read_whole = [asked](const std::string& why) {
    if (asked) std::fprintf(stderr, "note: --stream is not used: %s; the input is read whole\n", why.c_str());
    return false;
  };
  if (paths.size() != 1 || !in.in_list.empty()) return read_whole("it reads one CSV file row by row, and this run pools several inputs");
  const std::string& p = paths.front();
  if (is_mat_file(p)) return read_whole("it reads one CSV file row by row, and " + p + " is a .mat file");
  std::error_code ec;
  const auto size = std::filesystem::file_size(p, ec);
  return asked || (!ec && size > (512ull << 20));
}

int run_monitor(const std::string& path, const InputOptions& in, const CsvColumns& cols, const std::string& json_path,
                const std::string& plot_path, const std::string& jsonl_path, MonitorOptions opt) {
  if (!in.in_list.empty()) {
    std::fprintf(stderr, "error: monitor reads one log (--in); --in-list is for identify, validate and diagnose\n");
    return 2;
  }
  if ((!cols.temperature.empty() || !cols.load.empty()) && is_mat_file(path)) {
    std::fprintf(stderr, "error: %s: --temperature and --load are read from a CSV log only\n", path.c_str());
    return 2;
  }
  CsvStream stream = open_trace_stream(path, cols);
  if (!stream.ok()) {
    std::fprintf(stderr, "error: %s\n", stream.error().c_str());
    return 2;
  }
  note_format(stream.notes());
  const std::size_t noted = stream.notes().size();
  opt.identify.units = in.units();
  StreamProgress progress("monitor");
  opt.progress = [&progress](double t) { progress(t); };
  const MonitorResult r = monitor(stream, opt);
  progress.done();
  note_format(stream.notes(), noted);  // decided at a later row: the time format where the first row's stamp did not read
  note_skipped_rows(path, r.rows_skipped, r.rows_repeated, r.skipped_rows);
  // Refused before an epoch was read (a time column in ms read as s): no
  // table or file would say more than the reason.
  if (r.epochs.empty() && !r.error.empty()) return bad_input(r.error);
  if (jsonl_path != "-") std::cout << trend_table(r);  // stdout is the time series then
  if (!json_path.empty() && !write_json(json_path, to_json(r, opt))) return 1;
  std::string err;
  if (jsonl_path == "-") std::cout << jsonl_lines(r, path);
  else if (!jsonl_path.empty()) err = write_whole_file(jsonl_path, jsonl_lines(r, path), {path});
  if (!err.empty()) {
    std::fprintf(stderr, "error: %s\n", err.c_str());
    return 1;
  }
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

namespace {
/// One word for a POSIX shell: as it is where every character is safe,
/// else in single quotes (a quote inside as '\'').
std::string shell_word(const std::string& w) {
  const bool safe = !w.empty() && w.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                                                      "0123456789_./=:,+-@%") == std::string::npos;
  if (safe) return w;
  std::string q = "'";
  for (const char c : w) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}
}  // namespace

std::string command_as_typed(const std::string& fallback) {
  std::ifstream f("/proc/self/cmdline", std::ios::binary);
  const std::string all((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (all.empty()) return fallback;
  std::string line;
  for (std::size_t at = 0; at < all.size();) {
    const std::size_t end = std::min(all.find('\0', at), all.size());
    line += (line.empty() ? "" : " ") + shell_word(all.substr(at, end - at));
    at = end + 1;
  }
  return line;
}

/// The diagnosis page, if a folder was given; the exit code.
int write_report(const DiagnoseResult& r, const std::string& dir, const std::string& source,
                 const std::string& fallback) {
  if (dir.empty()) return 0;
  std::string err;
  if (!write_diagnosis_report(r, dir, source, command_as_typed(fallback), err)) {
    std::fprintf(stderr, "error: %s\n", err.c_str());
    return 1;
  }
  std::printf("report: %s/report.html\n", dir.c_str());
  return 0;
}

}  // namespace feedid::host::cli
