// A recording whose signals are already vectors in memory (a .mat file's
// variables, numpy arrays from Python) as a trace, through the same row
// rules as the CSV reader (trace_rows.hpp). Host only.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "csv_trace.hpp"

namespace feedid::host {

/// One recording's signals as read, before scales; an empty position or
/// velocity vector means the signal was not logged (at least one must be).
struct TraceColumns {
  std::vector<double> t, x, v, u;
};

/// Element k of each vector is row k. The scales of `columns` are applied
/// (its time scale, 0: from the time name), a row with a NaN/Inf is
/// skipped and counted (or is the error with skip_bad_rows false), a row
/// that repeats the one before exactly is counted and left out, and time
/// must increase. Messages read "<source>: element <k>: ..." with k
/// counted from first_index (1 for MATLAB, 0 for numpy); vectors of
/// different lengths are an error naming both lengths.
CsvResult trace_from_columns(const TraceColumns& c, const CsvColumns& columns, const std::string& source,
                             std::size_t first_index);

}  // namespace feedid::host
