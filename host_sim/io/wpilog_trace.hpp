// Reading traces from WPILib DataLog files (.wpilog, the format SysId and
// DataLogManager record; "WPILib Data Log File Format Specification,
// Version 1.0", wpiutil/doc/datalog.adoc in allwpilib). Host only.
#pragma once
#include <string>

#include "csv_trace.hpp"

namespace feedid::host {

/// Whether the path names a WPILib data log (.wpilog, any case).
bool is_wpilog_file(const std::string& path);

/// Reads the entries CsvColumns names (position, velocity, force: entry
/// names such as /SysId/position) from a .wpilog file. Each must be a
/// `double`, `float` or `int64` entry. A data log has no time column: every
/// record has its own time stamp (integer microseconds), and entries are
/// logged at their own times. The rows are the records of one entry, the
/// time base: the entry `time` names when the file has one, else the
/// force entry. Every other signal is linearly interpolated at those time
/// stamps between its two neighbouring records; time stamps outside a
/// signal's recorded span are left out (never extrapolated) and counted in
/// a note. The scales and row rules are then the CSV reader's
/// (trace_from_columns), time in s from the microseconds. Errors name the
/// file, the byte offset or the entry, and list the numeric entries.
CsvResult read_trace_wpilog(const std::string& path, const CsvColumns& columns);

}  // namespace feedid::host
