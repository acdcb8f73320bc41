// Trace files of either kind (CSV, MATLAB .mat), one or several pooled as
// runs. Host only.
#pragma once
#include <string>
#include <vector>

#include "csv_trace.hpp"

namespace feedid::host {

/// A .mat file (by its extension, any case) through read_trace_mat, any
/// other through read_trace_csv; the same columns, scales and row rules.
CsvResult read_trace_file(const std::string& path, const CsvColumns& columns);

/// Several recordings as one trace of consecutive runs (Trace::runs): each
/// file is read as above; run i's times are shifted to start kRunGap_s after
/// run i-1 ends. An error in any file is the error. One path: as read_trace_file.
CsvResult read_trace_files(const std::vector<std::string>& paths, const CsvColumns& columns);

}  // namespace feedid::host
