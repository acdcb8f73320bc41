// feedid._feedid: the host's reader, identify(), diagnose(), validate(), replay(),
// monitor(), the compensation table and the fleet page for Python (pybind11).
// The pure-Python package (feedid/__init__.py, feedid/fleet.py) wraps it;
// results cross as the JSON text of each command's to_json, the CLI's --json.
// Nothing here prints: errors go to Python as exceptions with the host's
// message (std::invalid_argument as ValueError, std::runtime_error as
// RuntimeError, pybind11's translation), and the GIL is released while
// the host reads and identifies, so that threads of one process overlap.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <climits>
#include <functional>
#include <optional>
#include <utility>
#include <cmath>
#include <initializer_list>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "compensate/compensate.hpp"
#include "diagnose/diagnose.hpp"
#include "gap/model_gap.hpp"
#include "model/model_file.hpp"
#include "identify/gravity.hpp"
#include "identify/identify.hpp"
#include "io/column_trace.hpp"
#include "io/trace_files.hpp"
#include "io/units.hpp"
#include "model/drive_model.hpp"
#include "monitor/monitor.hpp"
#include "replay/controller.hpp"
#include "replay/replay.hpp"
#include "report/report.hpp"
#include "validate/validate.hpp"

namespace py = pybind11;
using namespace feedid::host;

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// The options of one call, named as the CLI's long options with '_' for '-'
/// (velocity_filter is --velocity-filter), read into the host's structures.
struct CallOptions {
  CsvColumns columns;
  Units units;
  DiagnoseOptions diagnose;  ///< its .identify: identify's options
  ValidateOptions validate;
  MonitorOptions monitor;
  ReplayOptions replay;     ///< replay's (substeps, filter, drop_first); units set with the others
  bool fit_gains = false;   ///< replay --fit-gains
};

/// value as a T, or a TypeError that names the option and the value
/// (pybind11's own says only "Unable to cast Python instance to C++ type").
template <typename T> T cast_option(const py::handle& value, const std::string& key, const char* what) {
  try {
    return py::cast<T>(value);
  } catch (const py::cast_error&) {
    throw py::type_error(key + ": " + std::string(py::repr(value)) + " is not " + what);
  }
}

double number(const py::handle& value, const std::string& key) {
  const double x = cast_option<double>(value, key, "a number");
  if (!std::isfinite(x)) throw py::value_error(key + ": " + std::to_string(x) + " is not a finite number");
  return x;
}

/// A cut-off, band edge or resolution: 0 means "from the data"; negative is an error, not another 0.
double zero_or_positive(const py::handle& value, const std::string& key) {
  const double x = number(value, key);
  if (x < 0) throw py::value_error(key + ": " + std::to_string(x) + " is negative (0: from the data)");
  return x;
}

int whole_in(const py::handle& value, const std::string& key, int least, int most = INT_MAX) {
  const int n = cast_option<int>(value, key, "a whole number in range");
  if (n < least || n > most)
    throw py::value_error(key + ": " + std::to_string(n) + " is outside " + std::to_string(least) + " .. " +
                          (most == INT_MAX ? std::string("") : std::to_string(most)));
  return n;
}

std::string one_of(const py::handle& value, const std::string& key, const std::set<std::string>& allowed) {
  const auto s = cast_option<std::string>(value, key, "a string");
  if (allowed.count(s)) return s;
  std::string names;
  for (const auto& a : allowed) names += (names.empty() ? "" : ", ") + a;
  throw py::value_error(key + ": '" + s + "' is not one of " + names);
}

/// The input options every command takes (columns, scales, units, bad rows); false: not one of them.
bool input_option(const std::string& key, const py::handle& value, CsvColumns& c, Axis& axis, std::string& force_unit) {
  if (key == "axis") axis = one_of(value, key, {"linear", "rotary"}) == "rotary" ? Axis::rotary : Axis::linear;
  else if (key == "force_unit") force_unit = cast_option<std::string>(value, key, "a string");
  else if (key == "position_scale") c.position_scale = number(value, key), c.position_scale_stated = true;
  else if (key == "force_scale") c.force_scale = number(value, key);
  else if (key == "time_scale") c.time_scale = zero_or_positive(value, key);
  else if (key == "bad_rows") c.skip_bad_rows = one_of(value, key, {"skip", "error"}) == "skip";
  else if (key == "time") c.time = cast_option<std::string>(value, key, "a string");
  else if (key == "position") c.position = cast_option<std::string>(value, key, "a string");
  else if (key == "velocity") c.velocity = cast_option<std::string>(value, key, "a string");
  else if (key == "force") c.force = cast_option<std::string>(value, key, "a string");
  else return false;
  return true;
}

/// identify's own options (diagnose takes them too); false: not one of them.
bool identify_option(const std::string& key, const py::handle& value, IdentifyOptions& id) {
  if (key == "method") id.method = one_of(value, key, {"bands", "paper"}) == "paper" ? feedid::Method::paper : feedid::Method::bands;
  else if (key == "alignment") {
    id.alignment = cast_option<std::string>(value, key, "a string");
    id.check_stated_lag = id.check_stated_lag || id.alignment != "auto";  // identify() warns where the data disagree
  }
  else if (key == "force_lag_s") {
    id.force_lag_s = number(value, key);
    id.check_stated_lag = true;  // identify() warns where the data put it elsewhere
  }
  else if (key == "velocity_lag_s") id.velocity_lag_s = number(value, key);
  else if (key == "velocity_filter") id.velocity_filter_hz = zero_or_positive(value, key);
  else if (key == "velocity_min") id.velocity_min_m_s = zero_or_positive(value, key);
  else if (key == "velocity_resolution") id.velocity_resolution_m_s = zero_or_positive(value, key);
  else if (key == "gravity") (void)gravity_from_name(one_of(value, key, {"none", "constant", "angle", "auto"}), id.gravity);
  else return false;
  return true;
}

bool diagnose_option(const std::string& key, const py::handle& value, DiagnoseOptions& d) {
  if (key == "folds") d.folds = whole_in(value, key, 2);
  else if (key == "block") d.block_s = number(value, key);
  else if (key == "threads") d.threads = whole_in(value, key, 0, 256);
  else return identify_option(key, value, d.identify);
  return true;
}

bool validate_option(const std::string& key, const py::handle& value, ValidateOptions& v) {
  if (key == "filter") v.filter_hz = number(value, key);
  else if (key == "decimate") v.decimate = whole_in(value, key, 1);
  else if (key == "drop_first") v.drop_first = whole_in(value, key, 0);
  else return false;
  return true;
}

/// What a call runs; `read` takes the input options alone.
bool monitor_option(const std::string& key, const py::handle& value, MonitorOptions& m) {
  if (key == "epoch_s") {
    m.detector.epoch_s = number(value, key);
    if (!(m.detector.epoch_s > 0)) throw py::value_error(key + ": the epoch must be longer than 0 s");
  } else if (key == "reference_epochs") {
    m.detector.reference_epochs = whole_in(value, key, 3, feedid::ChangeMonitor<double>::kMaxReferenceEpochs);
  } else if (key == "threshold") {
    m.detector.threshold = number(value, key);
  } else if (key == "watch_stribeck") {
    if (!py::isinstance<py::bool_>(value)) throw py::value_error(key + ": True or False");
    m.detector.watch_stribeck = value.cast<bool>();
  } else {
    return false;
  }
  return true;
}

/// replay's own options (`feedid replay --substeps --filter --drop-first --fit-gains`).
bool replay_option(const std::string& key, const py::handle& value, CallOptions& o) {
  if (key == "substeps") o.replay.substeps = whole_in(value, key, 0);
  else if (key == "filter") o.replay.filter_hz = number(value, key);
  else if (key == "drop_first") o.replay.drop_first = whole_in(value, key, 0);
  else if (key == "fit_gains") o.fit_gains = cast_option<bool>(value, key, "True or False");
  else return false;
  return true;
}

enum class Command { identify, diagnose, validate, monitor, replay, read };

/// Options as keyword arguments, those of `command` and the input's; any
/// other name is a TypeError naming it (an option silently ignored, or
/// misspelt, would give another answer).
CallOptions call_options(const py::dict& kw, Command command) {
  CallOptions o;
  Axis axis = Axis::linear;
  std::string force_unit;
  for (const auto& [k, value] : kw) {
    const auto key = py::cast<std::string>(k);
    if (value.is_none()) continue;  // None: the default, as an option not given
    const bool known = input_option(key, value, o.columns, axis, force_unit) ||
                       (command == Command::identify && identify_option(key, value, o.diagnose.identify)) ||
                       (command == Command::diagnose && diagnose_option(key, value, o.diagnose)) ||
                       (command == Command::validate && validate_option(key, value, o.validate)) ||
                       (command == Command::monitor && monitor_option(key, value, o.monitor)) ||
                       (command == Command::replay && replay_option(key, value, o));
    if (!known) throw py::type_error("unknown option '" + key + "'");
  }
  o.units = o.diagnose.identify.units = o.validate.units = o.monitor.identify.units = o.replay.units = units_for(axis, force_unit);
  return o;
}

Command command_named(const std::string& name) {
  if (name == "identify") return Command::identify;
  if (name == "diagnose") return Command::diagnose;
  if (name == "validate") return Command::validate;
  throw py::value_error("no command '" + name + "' (identify, diagnose, validate)");
}

/// A signal as doubles. An array of complex, boolean or text values is
/// refused (they were cast: a complex signal lost its imaginary part with
/// only numpy's warning, a text array was parsed); one of floats narrower
/// than double is warned of: float32 time stamps 25 s into a log resolve
/// 2 us, a fiftieth of a 1 kHz period, and moved EMPS's m by 0.4 of its
/// standard error.
std::vector<double> to_vector(const py::object& a, const char* name) {
  if (a.is_none()) return {};
  if (py::isinstance<py::array>(a)) {
    const py::dtype dt = py::reinterpret_borrow<py::array>(a).dtype();
    const char kind = dt.kind();
    if (kind == 'c' || kind == 'b' || kind == 'U' || kind == 'S')
      throw py::type_error(std::string(name) + ": an array of " + dt.attr("name").cast<std::string>() +
                           " values; a signal is real numbers (float or int)");
    if (kind == 'f' && dt.itemsize() < 8) {
      const std::string w = std::string(name) + " is " + dt.attr("name").cast<std::string>() +
                            ": its values carry about " + (dt.itemsize() == 4 ? "7" : "3") +
                            " significant digits, which can move the result (give float64)";
      if (PyErr_WarnEx(PyExc_UserWarning, w.c_str(), 2) < 0) throw py::error_already_set();
    }
  }
  const Array arr = Array::ensure(a);
  if (!arr || arr.ndim() != 1) throw py::value_error("a signal must be a one-dimensional array of numbers");
  return std::vector<double>(arr.data(), arr.data() + arr.size());
}

/// A result's error (io/outcome.hpp) as Python's ValueError, as the CLI's exit 2.
void raise_if(const std::string& error) {
  if (!error.empty()) throw std::invalid_argument(error);
}

/// A command's JSON text and the warnings and notes the CLI prints on stderr.
using JsonAndWarnings = std::pair<std::string, std::vector<std::string>>;

/// The command on a trace read without the GIL; the JSON text of its --json,
/// and what the CLI prints beside it (identify: its warnings; validate: the
/// model reader's warnings, a filter beyond the rate's reach).
/// model_text: validate's model (identify's JSON), in the log's units.
JsonAndWarnings run(Command command, const CsvResult& read, const CallOptions& o, const std::string& model_text) {
  if (!read.ok) throw std::invalid_argument(read.error);
  switch (command) {
    case Command::identify: {  // the warnings the CLI's summary prints (identify_warnings)
      const IdentifyResult r = identify(read.trace, o.diagnose.identify);
      return {json_as_written(to_json(r)).dump(), identify_warnings(r)};
    }
    case Command::diagnose: return {json_as_written(to_json(diagnose(read.trace, o.diagnose))).dump(), {}};
    case Command::validate: break;
    case Command::monitor:
    case Command::replay:
    case Command::read: throw std::logic_error("monitor, replay and read are not commands on a whole trace");
  }
  const nlohmann::json model_json = nlohmann::json::parse(model_text);
  if (const std::string why = model_units_mismatch(model_json, o.units); !why.empty())
    throw std::invalid_argument("model: " + why);
  const ModelFile file = model_file_from_json(model_json, "model");
  raise_if(file.error);
  CallOptions with_offset = o;
  with_offset.validate.load = file.load;
  const ValidateResult r = validate(file.drive, read.trace, with_offset.validate);
  raise_if(r.error);
  std::vector<std::string> notes = file.warnings;
  if (const std::string n = r.filter_note(); !n.empty()) notes.push_back(n);
  return {json_as_written(to_json(r, file.drive, with_offset.validate)).dump(), notes};
}

/// Refuses a call whose required signals have no samples, naming each
/// (two empty arrays were refused as "t and u are required").
void require_samples(std::initializer_list<std::pair<const char*, const std::vector<double>*>> required) {
  std::string empty;
  int n = 0;
  for (const auto& [name, column] : required)
    if (column->empty()) empty += std::string(n++ ? ", " : "") + name;
  if (n > 0)
    throw py::value_error(empty + (n == 1 ? " has" : " have") + " no samples (None or empty): t is the time (s), x the "
                          "position, u the force, one value per row");
}

JsonAndWarnings run_arrays(const std::string& name, const py::object& t, const py::object& x, const py::object& v,
                           const py::object& u, const py::dict& kw, const std::string& model_text) {
  const Command command = command_named(name);
  const CallOptions o = call_options(kw, command);
  TraceColumns c{to_vector(t, "t"), to_vector(x, "x"), to_vector(v, "v"), to_vector(u, "u")};
  require_samples({{"t", &c.t}, {"u", &c.u}});
  py::gil_scoped_release release;
  return run(command, trace_from_columns(c, o.columns, "arrays", 0), o, model_text);
}

JsonAndWarnings run_files(const std::string& name, const std::vector<std::string>& paths, const py::dict& kw,
                          const std::string& model_text) {
  const Command command = command_named(name);
  const CallOptions o = call_options(kw, command);
  if (paths.empty()) throw py::value_error("no recording: give one path or several to pool");
  py::gil_scoped_release release;
  return run(command, read_trace_files(paths, o.columns), o, model_text);
}

/// diagnose's given model and controller (`diagnose --model M [--controller
/// C]`): each the JSON text of the CLI's file and the name its messages use.
struct GivenFiles {
  std::string model_text, model_source, controller_text, controller_source;
};


/// `diagnose --model [--controller]` (gap/model_gap.hpp) on a read trace;
/// `logged` gives the run the replay reads for the controller. The JSON text
/// of its --json, and the warnings and notes the CLI prints on stderr.
JsonAndWarnings run_model_gap(const CsvResult& read, const CallOptions& o, const GivenFiles& g,
                              const std::function<LoggedRun(const Controller&)>& logged) {
  if (!read.ok) throw std::invalid_argument(read.error);
  DiagnoseOptions opt = o.diagnose;
  const nlohmann::json model_json = nlohmann::json::parse(g.model_text);
  if (const std::string why = model_units_mismatch(model_json, o.units); !why.empty())
    throw std::invalid_argument(g.model_source + ": " + why);
  opt.model = model_file_from_json(model_json, g.model_source);
  raise_if(opt.model->error);
  std::vector<std::string> notes = opt.model->warnings;
  std::optional<Controller> c;
  std::optional<LoggedRun> run;
  ReplayOptions ropt;
  ropt.units = o.units;
  if (!g.controller_text.empty()) {
    c = controller_from_json(nlohmann::json::parse(g.controller_text), g.controller_source);
    raise_if(c->error);
    notes.insert(notes.end(), c->warnings.begin(), c->warnings.end());
    run = logged(*c);
    raise_if(run->error);
    notes.insert(notes.end(), run->notes.begin(), run->notes.end());
  }
  const ModelGap gap = model_gap(read.trace, opt, c ? &*c : nullptr, run ? &*run : nullptr, ropt);
  // The diagnosis's own error is in its JSON, as the CLI writes it; a replay's is raised.
  if (gap.diagnosis.error.empty()) raise_if(gap.error);
  return {json_as_written(to_json(gap)).dump(), notes};
}

/// The run a replay reads from arrays: the trace's own rows (none may be
/// skipped: the reference pairs with them by index) and the reference and
/// extra command the controller names, from `columns` (name -> array; the
/// reference scaled like the position, as the file reader does).
LoggedRun run_from_arrays(const Trace& trace, std::size_t rows, const std::map<std::string, std::vector<double>>& columns,
                          const CsvColumns& cols, const Controller& c) {
  if (trace.samples.size() != rows)
    throw std::invalid_argument("arrays: a replay pairs the reference with every row, and " +
                                std::to_string(rows - trace.samples.size()) + " rows were left out (bad or repeated)");
  LoggedRun run;
  run.source = "arrays";
  for (const TraceSample& s : trace.samples) {
    run.t.push_back(s.t_s);
    run.x.push_back(s.x_m);
    run.u.push_back(s.u_N);
  }
  const auto column = [&](const std::string& name, const char* what) -> const std::vector<double>* {
    const auto it = columns.find(name);
    if (it == columns.end()) return nullptr;
    if (it->second.size() != rows)
      throw std::invalid_argument(std::string("arrays: the ") + what + " '" + name + "' has " +
                                  std::to_string(it->second.size()) + " values for " + std::to_string(rows) + " rows");
    return &it->second;
  };
  const std::vector<double>* r = column(c.reference, "reference");
  if (!r) throw std::invalid_argument("arrays: no reference column '" + c.reference + "' (the controller's reference; give it in columns)");
  for (double q : *r) run.reference.push_back(q * position_scale(cols));
  if (c.extra_command.empty()) return run;
  if (const std::vector<double>* e = column(c.extra_command, "extra command")) run.extra = *e;
  else run.notes.push_back("arrays have no extra command column '" + c.extra_command + "': none is added");
  return run;
}

JsonAndWarnings model_gap_arrays(const py::object& t, const py::object& x, const py::object& v, const py::object& u,
                                 const py::dict& kw, const GivenFiles& g, const py::dict& columns) {
  const CallOptions o = call_options(kw, Command::diagnose);
  TraceColumns c{to_vector(t, "t"), to_vector(x, "x"), to_vector(v, "v"), to_vector(u, "u")};
  require_samples({{"t", &c.t}, {"u", &c.u}});
  std::map<std::string, std::vector<double>> named;
  for (const auto& [k, a] : columns) named[py::cast<std::string>(k)] = to_vector(py::reinterpret_borrow<py::object>(a), "a column");
  py::gil_scoped_release release;
  const CsvResult read = trace_from_columns(c, o.columns, "arrays", 0);
  return run_model_gap(read, o, g, [&](const Controller& ctl) { return run_from_arrays(read.trace, c.t.size(), named, o.columns, ctl); });
}

JsonAndWarnings model_gap_files(const std::vector<std::string>& paths, const py::dict& kw, const GivenFiles& g) {
  const CallOptions o = call_options(kw, Command::diagnose);
  if (paths.empty()) throw py::value_error("no recording: give one path or several to pool");
  if (!g.controller_text.empty() && paths.size() != 1)
    throw py::value_error("controller: a replay takes one continuous recording (one path)");
  py::gil_scoped_release release;
  return run_model_gap(read_trace_files(paths, o.columns), o, g,
                       [&](const Controller& ctl) { return read_logged_run(paths.front(), o.columns, ctl, o.diagnose.threads != 1); });
}

/// `feedid replay`: the given model in the given controller's loop over the
/// run `logged` reads for that controller; the JSON text of `replay --json`
/// and the warnings the CLI prints on stderr (the model's, the controller's).
JsonAndWarnings run_replay(const CallOptions& o, const GivenFiles& g,
                           const std::function<LoggedRun(const Controller&)>& logged) {
  const ModelFile model = model_file_from_json(nlohmann::json::parse(g.model_text), g.model_source);
  raise_if(model.error);
  if (const std::string why = model_units_mismatch({{"units", model.units}}, o.units); !why.empty())
    throw std::invalid_argument(g.model_source + ": " + why);
  const Controller c = controller_from_json(nlohmann::json::parse(g.controller_text), g.controller_source);
  raise_if(c.error);
  std::vector<std::string> notes = model.warnings;
  notes.insert(notes.end(), c.warnings.begin(), c.warnings.end());
  const ReplayResult r = replay(model, c, logged(c), o.replay, o.fit_gains);
  raise_if(r.error);
  // The run's notes too, as the CLI prints them: an extra command the
  // arrays or the file lack (the test pulses dropped: force error 37 %
  // against 8 %) went by without a word.
  notes.insert(notes.end(), r.notes.begin(), r.notes.end());
  return {json_as_written(to_json(r, model, c, o.replay)).dump(), notes};
}

JsonAndWarnings replay_arrays(const py::object& t, const py::object& x, const py::object& u, const py::dict& kw,
                              const GivenFiles& g, const py::dict& columns) {
  const CallOptions o = call_options(kw, Command::replay);
  TraceColumns c{to_vector(t, "t"), to_vector(x, "x"), {}, to_vector(u, "u")};
  require_samples({{"t", &c.t}, {"x", &c.x}, {"u", &c.u}});
  std::map<std::string, std::vector<double>> named;
  for (const auto& [k, a] : columns) named[py::cast<std::string>(k)] = to_vector(py::reinterpret_borrow<py::object>(a), "a column");
  py::gil_scoped_release release;
  const CsvResult read = trace_from_columns(c, o.columns, "arrays", 0);
  if (!read.ok) throw std::invalid_argument(read.error);
  return run_replay(o, g, [&](const Controller& ctl) { return run_from_arrays(read.trace, c.t.size(), named, o.columns, ctl); });
}

JsonAndWarnings replay_file(const std::string& path, const py::dict& kw, const GivenFiles& g) {
  const CallOptions o = call_options(kw, Command::replay);
  py::gil_scoped_release release;
  return run_replay(o, g, [&](const Controller& ctl) { return read_logged_run(path, o.columns, ctl); });
}

/// `feedid monitor` on one log (a CSV read row by row in constant memory); the
/// JSON text of its --json (its error, where reading stopped, inside).
std::string monitor_file(const std::string& path, const py::dict& kw) {
  const CallOptions o = call_options(kw, Command::monitor);
  py::gil_scoped_release release;
  CsvStream in = open_trace_stream(path, o.columns);  // CSV streamed; .mat and .wpilog read whole, as the CLI
  if (!in.ok()) throw std::invalid_argument(in.error());
  return json_as_written(to_json(monitor(in, o.monitor), o.monitor)).dump();
}

/// `feedid compensate`: the friction table a drive can load, from a model
/// JSON (identify's); the JSON text of the table, or its CSV with format
/// "csv", and the warnings the CLI prints (a flagged model, the table's range).
std::pair<std::string, std::vector<std::string>> compensate_model_text(const std::string& model_text, const py::dict& kw) {
  CompensateOptions opt;
  std::string format = "json";
  for (const auto& [k, value] : kw) {
    const auto key = py::cast<std::string>(k);
    if (value.is_none()) continue;
    if (key == "points") opt.points = whole_in(value, key, 2, kMaxTablePoints);
    else if (key == "max_speed") opt.max_speed_m_s = zero_or_positive(value, key);
    else if (key == "force_scale") opt.force_scale = number(value, key);
    else if (key == "force_unit") opt.force_unit = cast_option<std::string>(value, key, "a string");
    else if (key == "format") format = one_of(value, key, {"json", "csv"});
    else throw py::type_error("unknown option '" + key + "'");
  }
  const ModelCompensation c = compensate_model(nlohmann::json::parse(model_text), opt, "model");
  raise_if(c.error);
  return {format == "csv" ? to_csv(c.table, opt, c.units) : json_as_written(c.json).dump(), c.warnings};
}

/// The fleet page (report/report.hpp) from feedid.fleet's rows as JSON text;
/// an error writing it is an OSError-like RuntimeError naming the file.
void fleet_report(const std::string& rows_text, const std::string& dir, const std::string& command) {
  const nlohmann::json rows = nlohmann::json::parse(rows_text);
  std::string error;
  bool ok = false;
  {
    py::gil_scoped_release release;
    ok = write_fleet_report(rows, dir, command, error);
  }
  if (!ok) throw std::runtime_error(error);
}

Array column(const std::vector<TraceSample>& s, double TraceSample::*field) {
  Array out(static_cast<py::ssize_t>(s.size()));
  double* p = out.mutable_data();
  for (const TraceSample& x : s) *p++ = x.*field;
  return out;
}

/// A trace file through the host reader: its signals in SI units (after the
/// scales) as arrays, None for a signal not logged, and what was left out.
py::dict read_signals(const std::string& path, const py::dict& kw) {
  const CallOptions o = call_options(kw, Command::read);
  CsvResult r;
  {
    py::gil_scoped_release release;
    r = read_trace_file(path, o.columns);
  }
  if (!r.ok) throw std::invalid_argument(r.error);
  const auto& s = r.trace.samples;
  py::dict d;
  d["t"] = column(s, &TraceSample::t_s);
  d["x"] = r.trace.has_position ? py::object(column(s, &TraceSample::x_m)) : py::object(py::none());
  d["v"] = r.trace.has_velocity ? py::object(column(s, &TraceSample::v_m_s)) : py::object(py::none());
  d["u"] = column(s, &TraceSample::u_N);
  d["rows_skipped"] = r.trace.rows_skipped;
  d["rows_repeated"] = r.trace.rows_repeated;
  d["skipped_rows"] = r.trace.skipped_rows;
  d["time_origin_s"] = r.trace.time_origin_s;  // t counts from it (a Unix-time column: its first stamp's whole part)
  d["notes"] = r.trace.notes;
  return d;
}

}  // namespace

PYBIND11_MODULE(_feedid, m) {
  m.doc() = "feedid's host reader and identification (the package feedid wraps it)";
  m.def("run_arrays", &run_arrays, py::arg("command"), py::arg("t"), py::arg("x"), py::arg("v"), py::arg("u"),
        py::arg("options"), py::arg("model") = "",
        "identify, diagnose or validate on signals in memory: (the JSON text of the CLI's --json, warnings)");
  m.def("run_files", &run_files, py::arg("command"), py::arg("paths"), py::arg("options"), py::arg("model") = "",
        "the same on one trace file, or several pooled as runs");
  py::class_<GivenFiles>(m, "GivenFiles")
      .def(py::init<std::string, std::string, std::string, std::string>(), py::arg("model_text"), py::arg("model_source"),
           py::arg("controller_text"), py::arg("controller_source"));
  m.def("model_gap_arrays", &model_gap_arrays, py::arg("t"), py::arg("x"), py::arg("v"), py::arg("u"), py::arg("options"),
        py::arg("given"), py::arg("columns"),
        "diagnose --model [--controller] on signals in memory; (JSON text of --json, warnings)");
  m.def("model_gap_files", &model_gap_files, py::arg("paths"), py::arg("options"), py::arg("given"),
        "the same on trace files (one with a controller)");
  m.def("replay_arrays", &replay_arrays, py::arg("t"), py::arg("x"), py::arg("u"), py::arg("options"), py::arg("given"),
        py::arg("columns"), "replay --json on arrays: (JSON text, warnings)");
  m.def("replay_file", &replay_file, py::arg("path"), py::arg("options"), py::arg("given"),
        "replay --json on one trace file: (JSON text, warnings)");
  m.def("monitor_file", &monitor_file, py::arg("path"), py::arg("options"),
        "friction health of one log, streamed; the JSON text of monitor --json");
  m.def("compensate", &compensate_model_text, py::arg("model"), py::arg("options"),
        "the friction table of a model JSON text: (its JSON text or CSV, warnings)");
  m.def("fleet_report", &fleet_report, py::arg("rows"), py::arg("dir"), py::arg("command"),
        "report.html of a fleet's rows (JSON text) into dir");
  m.def("read", &read_signals, py::arg("path"), py::arg("options"), "a trace file's signals as arrays, through the host reader");
}
