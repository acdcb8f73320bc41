// Trace files of either kind, one or several pooled as runs. Host only.
#include "trace_files.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "mat_trace.hpp"
#include "message_text.hpp"
#include "trace_rows.hpp"
#include "wpilog_trace.hpp"

namespace feedid::host {

bool is_mat_file(const std::string& path) {
  std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".mat";
}

CsvResult read_trace_file(const std::string& path, const CsvColumns& columns) {
  if (is_wpilog_file(path)) return read_trace_wpilog(path, columns);
  return is_mat_file(path) ? read_trace_mat(path, columns) : read_trace_csv(path, columns);
}

CsvStream open_trace_stream(const std::string& path, const CsvColumns& columns) {
  if (is_mat_file(path) || is_wpilog_file(path)) return CsvStream(read_trace_file(path, columns));
  return CsvStream(path, columns);
}

std::vector<std::string> names_by_position(const std::string& list) {
  std::vector<std::string> names;
  std::size_t from = 0;
  for (;;) {
    const std::size_t comma = list.find(',', from);
    std::string name = list.substr(from, comma == std::string::npos ? std::string::npos : comma - from);
    const auto not_space = [](unsigned char c) { return !std::isspace(c); };
    name.erase(name.begin(), std::find_if(name.begin(), name.end(), not_space));
    name.erase(std::find_if(name.rbegin(), name.rend(), not_space).base(), name.end());
    names.push_back(name);
    if (comma == std::string::npos) return names;
    from = comma + 1;
  }
}

CsvResult read_trace_files(const std::vector<std::string>& paths, const CsvColumns& columns) {
  std::vector<TraceInput> inputs;
  for (const auto& p : paths) inputs.push_back({p, columns});
  return read_trace_files(inputs);
}

bool read_input_list(const std::string& list_path, const CsvColumns& defaults, std::vector<TraceInput>& out,
                     std::string& error) {
  std::ifstream f(list_path);
  if (!f) {
    error = list_path + ": cannot open the list of recordings";
    return false;
  }
  const std::filesystem::path folder = std::filesystem::path(list_path).parent_path();
  std::string line;
  for (std::size_t n = 1; std::getline(f, line); ++n) {
    std::istringstream words(line);
    std::string path, kv;
    if (!(words >> path) || path[0] == '#') continue;
    TraceInput in{std::filesystem::path(path).is_absolute() ? path : (folder / path).string(), defaults};
    const auto where = list_path + ":" + std::to_string(n) + ": ";
    while (words >> kv) {
      const auto eq = kv.find('=');
      const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
      if (eq == std::string::npos || value.empty()) {
        error = where + quoted_text(kv) + " is not key=value";
        return false;
      }
      if (key == "time") in.columns.time = value;
      else if (key == "position") in.columns.position = value;
      else if (key == "velocity") in.columns.velocity = value;
      else if (key == "force") in.columns.force = value;
      else if (key == "columns") in.columns.names_by_position = names_by_position(value);
      else if (key == "position-scale" || key == "force-scale" || key == "time-scale") {
        char* end = nullptr;
        const double x = std::strtod(value.c_str(), &end);
        if (end != value.c_str() + value.size()) {
          error = where + key + " " + quoted_text(value) + " is not a number";
          return false;
        }
        (key == "force-scale" ? in.columns.force_scale : key == "time-scale" ? in.columns.time_scale : in.columns.position_scale) = x;
        if (key == "position-scale") in.columns.position_scale_stated = true;
      } else {
        error = where + "unknown key " + quoted_text(key) + " (time, position, velocity, force, columns, position-scale, force-scale, time-scale)";
        return false;
      }
    }
    // The options' rule for scales, said at the line that broke it.
    const std::string bad_scale = scale_error(in.columns, "");
    if (!bad_scale.empty()) {
      error = where + bad_scale;
      return false;
    }
    out.push_back(in);
  }
  if (out.empty()) error = list_path + ": no recordings listed";
  return !out.empty();
}

CsvResult read_trace_files(const std::vector<TraceInput>& inputs) {
  if (inputs.size() == 1) return read_trace_file(inputs.front().path, inputs.front().columns);
  CsvResult all;
  all.trace.has_position = all.trace.has_velocity = all.trace.time_unit_stated = true;
  for (const TraceInput& input : inputs) {
    const std::string& path = input.path;
    CsvResult one = read_trace_file(path, input.columns);
    if (!one.ok) return one;
    Trace& t = all.trace;
    TraceRun run;
    run.source = path;
    run.first = t.samples.size();
    run.samples = one.trace.samples.size();
    run.time_shift_s = t.samples.empty() ? 0.0 : t.samples.back().t_s + Trace::kRunGap_s - one.trace.samples.front().t_s;
    run.rows_skipped = one.trace.rows_skipped;
    run.rows_repeated = one.trace.rows_repeated;
    run.time_origin_s = one.trace.time_origin_s;
    // One origin for the pool only where every run has it (each run's is in input.runs).
    if (t.runs.empty()) t.time_origin_s = one.trace.time_origin_s;
    else if (t.time_origin_s != one.trace.time_origin_s) t.time_origin_s = std::numeric_limits<double>::quiet_NaN();
    for (TraceSample s : one.trace.samples) {
      s.t_s += run.time_shift_s;
      t.samples.push_back(s);
    }
    // A column must be in every file for the pooled trace to have it.
    t.has_position = t.has_position && one.trace.has_position;
    t.has_velocity = t.has_velocity && one.trace.has_velocity;
    t.time_unit_stated = t.time_unit_stated && one.trace.time_unit_stated;
    t.rows_skipped += one.trace.rows_skipped;
    t.rows_repeated += one.trace.rows_repeated;
    t.notes.insert(t.notes.end(), one.trace.notes.begin(), one.trace.notes.end());
    for (auto& why : one.trace.skipped_rows)
      if (t.skipped_rows.size() < 5) t.skipped_rows.push_back(why);
    t.source += (t.source.empty() ? "" : " + ") + path;
    t.runs.push_back(run);
  }
  all.ok = true;
  return all;
}

}  // namespace feedid::host
