// Trace files of either kind, one or several pooled as runs. Host only.
#include "trace_files.hpp"

#include <algorithm>
#include <cctype>

#include "mat_trace.hpp"

namespace feedid::host {

CsvResult read_trace_file(const std::string& path, const CsvColumns& columns) {
  std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".mat" ? read_trace_mat(path, columns) : read_trace_csv(path, columns);
}

CsvResult read_trace_files(const std::vector<std::string>& paths, const CsvColumns& columns) {
  if (paths.size() == 1) return read_trace_file(paths.front(), columns);
  CsvResult all;
  all.trace.has_position = all.trace.has_velocity = true;
  for (const std::string& path : paths) {
    CsvResult one = read_trace_file(path, columns);
    if (!one.ok) return one;
    Trace& t = all.trace;
    TraceRun run;
    run.source = path;
    run.first = t.samples.size();
    run.samples = one.trace.samples.size();
    run.time_shift_s = t.samples.empty() ? 0.0 : t.samples.back().t_s + Trace::kRunGap_s - one.trace.samples.front().t_s;
    run.rows_skipped = one.trace.rows_skipped;
    run.rows_repeated = one.trace.rows_repeated;
    for (TraceSample s : one.trace.samples) {
      s.t_s += run.time_shift_s;
      t.samples.push_back(s);
    }
    // A column must be in every file for the pooled trace to have it.
    t.has_position = t.has_position && one.trace.has_position;
    t.has_velocity = t.has_velocity && one.trace.has_velocity;
    t.rows_skipped += one.trace.rows_skipped;
    t.rows_repeated += one.trace.rows_repeated;
    for (auto& why : one.trace.skipped_rows)
      if (t.skipped_rows.size() < 5) t.skipped_rows.push_back(why);
    t.source += (t.source.empty() ? "" : " + ") + path;
    t.runs.push_back(run);
  }
  all.ok = true;
  return all;
}

}  // namespace feedid::host
