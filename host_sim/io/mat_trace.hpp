// Reading traces from MATLAB .mat files (v4, v5, and v7.3 through HDF5)
// with libmatio. Host only.
#pragma once
#include <string>

#include "csv_trace.hpp"

namespace feedid::host {

/// Reads the variables that CsvColumns names (time, force, and position
/// and/or velocity) from a .mat file. Each must be a real numeric vector,
/// row or column, and all of one length; a row is element k of each. The
/// scales, bad-row and repeated-row rules are those of the CSV reader
/// (trace_rows.hpp). Errors name the file, the variable and the problem,
/// and list the variables the file has.
CsvResult read_trace_mat(const std::string& path, const CsvColumns& columns);

}  // namespace feedid::host
