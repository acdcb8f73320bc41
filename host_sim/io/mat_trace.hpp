// Reading traces from MATLAB .mat files (v4, v5, and v7.3 through HDF5)
// with libmatio. Host only.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "csv_trace.hpp"

namespace feedid::host {

/// A signal's place in a .mat file as the options name it: a variable
/// (`t`), a field of a struct (`rec.act_pos`, nested `a.b.c`), and of a
/// matrix a column (`data(:,2)`, or `data:2`) or a row (`data(2,:)`),
/// counted from 1 as MATLAB does.
struct MatName {
  std::string variable;
  std::vector<std::string> fields;
  std::size_t column = 0, row = 0;  ///< 1-based; 0 and 0: the variable is a vector
};
/// False when `text` is none of the forms above.
bool parse_mat_name(const std::string& text, MatName& out);

/// Reads the variables that CsvColumns names (time, force, and position
/// and/or velocity) from a .mat file. Each must be a real numeric vector,
/// row or column, and all of one length; a row is element k of each. The
/// names may select a struct field or a matrix column (MatName). The
/// scales, bad-row and repeated-row rules are those of the CSV reader
/// (trace_rows.hpp). Errors name the file, the variable and the problem,
/// and list the variables the file has.
CsvResult read_trace_mat(const std::string& path, const CsvColumns& columns);

}  // namespace feedid::host
