// Trace files of either kind (CSV, MATLAB .mat), one or several pooled as
// runs. Host only.
#pragma once
#include <string>
#include <vector>

#include "csv_trace.hpp"

namespace feedid::host {

/// Whether the path names a MATLAB file (.mat, any case).
bool is_mat_file(const std::string& path);
/// A .mat file (by its extension, any case) through read_trace_mat, a
/// .wpilog through read_trace_wpilog, any other through read_trace_csv; the same columns, scales and row rules.
CsvResult read_trace_file(const std::string& path, const CsvColumns& columns);

/// A log read row by row (feedid monitor, identify --stream): a CSV
/// streamed in constant memory, a .mat or .wpilog read whole by read_trace_mat and
/// handed on; the same formats, columns, scales and row rules as
/// read_trace_file.
CsvStream open_trace_stream(const std::string& path, const CsvColumns& columns);

/// The names of --columns ("t,x,,u": a column not read between x and u),
/// split at commas and trimmed.
std::vector<std::string> names_by_position(const std::string& list);

/// One recording and how to read it.
struct TraceInput {
  std::string path;
  CsvColumns columns;
};

/// Several recordings as one trace of consecutive runs (Trace::runs): each
/// file is read as above with its own columns and scales; run i's times are
/// shifted to start kRunGap_s after run i-1 ends. An error in any file is
/// the error. One input: as read_trace_file.
CsvResult read_trace_files(const std::vector<TraceInput>& inputs);
/// The same columns and scales for every file.
CsvResult read_trace_files(const std::vector<std::string>& paths, const CsvColumns& columns);

/// A list of recordings (--in-list): one per line, `path [key=value ...]`,
/// where a key overrides one input option for that file: time, position,
/// velocity, force (column or variable names), columns (as --columns),
/// position-scale, force-scale, time-scale.
/// Blank lines and lines starting with # are skipped; a relative path is
/// taken from the list file's folder. False with `error` naming the line.
bool read_input_list(const std::string& list_path, const CsvColumns& defaults, std::vector<TraceInput>& out,
                     std::string& error);

}  // namespace feedid::host
