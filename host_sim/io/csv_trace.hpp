// Reading and writing traces as CSV. Host only.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "trace.hpp"

namespace feedid::host {

/// Which CSV columns hold which signal (names from the header row).
struct CsvColumns {
  std::string time = "t";
  std::string position = "x";   ///< optional if velocity is present
  std::string velocity = "v";   ///< optional if position is present
  std::string force = "u";
  /// Optional columns only the streamed reader hands on (CsvStream::
  /// temperature(), load(); feedid monitor --temperature, --load): empty,
  /// not read; named, the column must be there and hold a number on every row.
  std::string temperature, load;
  /// --bad-rows: skip a row that is not finite numbers or whose time does not
  /// increase, count it and name the first few; false: the first is an error.
  bool skip_bad_rows = true;
  /// With skipping, more than this share of bad rows is still an error.
  double max_bad_row_share = 0.01;
  /// Applied as each value is read: position and velocity times
  /// position_scale (e.g. encoder counts to m), force times force_scale
  /// (e.g. A to N through torque constant, gear ratio and lead).
  double position_scale = 1.0;
  /// Whether position_scale was given (--position-scale, an --in-list
  /// entry, Python's position_scale): where not, a unit ending the
  /// position column's name scales it (position_scale()).
  bool position_scale_stated = false;
  /// A position or velocity column named other than its default must be
  /// there (named_column_missing); false for a read that names its own
  /// column through a slot and says itself what is missing (replay's
  /// reference and extra command).
  bool named_columns_required = true;
  double force_scale = 1.0;
  /// Seconds per unit of the time column (--time-scale); 0: from a unit
  /// that ends the column's name (t_ms, "time [us]": time_unit_from_name),
  /// else seconds. A time in ms taken as s made the mass 10^6 too large.
  double time_scale = 0.0;
  /// Sample rate (Hz) of a CSV with no time column (--rate): data row k,
  /// counting the rows left out too, is at k / rate_hz. 0: the time column
  /// is required. A log with a time column and a rate is an error (which?).
  double rate_hz = 0.0;
  /// --columns: the names of a file's columns by position, for a file
  /// without a header row (an empty name: a column not read). Empty: the
  /// header row names them.
  std::vector<std::string> names_by_position;
};

/// The position or velocity column a reader found missing, where the user
/// named it (other than its default, "x" or "v", or empty: not read), as an error's words;
/// empty where it is there or was not named. Either may be absent, but a
/// typo in a name given (--position xx) silently integrated the velocity
/// column instead, or left the logged velocity unread.
std::string named_column_missing(const CsvColumns& c, bool has_position, bool has_velocity);

/// Seconds per unit of a time column from the unit that ends its name,
/// after a non-letter or alone: ms 1e-3, us or µs 1e-6, ns 1e-9; 1 when
/// there is none (seconds), so "items" or "t_s" read as seconds.
double time_unit_from_name(std::string_view name);

/// Seconds per unit of the time column as the readers apply it.
inline double time_scale(const CsvColumns& c) { return c.time_scale > 0 ? c.time_scale : time_unit_from_name(c.time); }

/// Metres (or radians) per unit of a position column from the unit that
/// ends its name, as time_unit_from_name: mm 1e-3, cm 1e-2, um or µm 1e-6,
/// nm 1e-9, deg pi/180; 1 for m, rad or none. x_mm taken as m made a
/// 100 kg drive 0.1 kg with status ok.
double position_unit_from_name(std::string_view name);

/// Position (and velocity) units per SI unit as the readers apply them:
/// position_scale where stated, else from the position column's name.
inline double position_scale(const CsvColumns& c) {
  return c.position_scale_stated || c.position_scale != 1.0 ? c.position_scale : position_unit_from_name(c.position);
}

/// Whether the time column's unit is stated: by --time-scale, or by a unit
/// ending its name (s, ms, us, ns after a non-letter: t_s, "time [ms]").
bool time_unit_stated(const CsvColumns& c);

/// Result of reading: ok, or an error message that names file, line and column.
struct CsvResult {
  bool ok = false;
  std::string error;
  Trace trace;  ///< its rows_skipped, rows_repeated and skipped_rows say what was left out
};

/// Reads a CSV with a header row (or, with names_by_position, without
/// one). Columns are looked up by name; time and force
/// are required, and at least one of position and velocity. When a column is
/// missing, has_position / has_velocity say so. Every value must parse as a
/// finite number and time must increase strictly; a row that breaks this is
/// skipped and counted (the first five described as "<file>:<line>: column
/// '<name>': <problem>"), or with skip_bad_rows false is the error. A row
/// that repeats the previous one exactly (a logger writing a sample twice)
/// is counted apart and never kept as a zero-length interval. Bytes that
/// are not printable ASCII are escaped (\xNN) in messages. Blank lines and a
/// trailing newline are allowed. The formats loggers write (csv_table.hpp):
/// separators ',', ';' or tab (a ',' in a number of a ';' or tab file is
/// its decimal point), comment and metadata lines before the header (left
/// out, counted in a note), ISO 8601 time stamps (seconds since the first
/// row's). Trace::notes says what was read other than plain.
CsvResult read_trace_csv(const std::string& path, const CsvColumns& columns);
/// The same for text already in memory; `source` names it in messages.
CsvResult parse_trace_csv(const std::string& text, const std::string& source, const CsvColumns& columns);

/// A CSV read row by row in constant memory (feedid monitor, logs of any
/// length): the same header, row rules and messages as read_trace_csv, but
/// no sample is kept. After construction, ok() or error(); then next()
/// until it returns false, and error() says whether that was the end of
/// the file (empty) or an error (a strict bad row, or more than the allowed
/// share of bad rows).
class CsvStream {
 public:
  CsvStream(const std::string& path, const CsvColumns& columns);
  /// A trace already read whole (a .mat file: libmatio reads whole
  /// variables), handed on row by row: its error, counts and notes as read.
  explicit CsvStream(CsvResult read);
  CsvStream(CsvStream&&) noexcept;
  ~CsvStream();
  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }
  bool has_position() const { return has_position_; }
  bool has_velocity() const { return has_velocity_; }
  bool time_unit_stated() const;  ///< as Trace::time_unit_stated
  /// Whether the temperature / load column (CsvColumns) is read, and its
  /// value on the row next() returned last, as logged.
  bool has_temperature() const;
  bool has_load() const;
  double temperature() const;
  double load() const;
  /// As Trace::notes: lines left out before the table, ISO 8601 stamps.
  const std::vector<std::string>& notes() const;
  /// As Trace::time_origin_s, once the first stamp is read.
  double time_origin_s() const;
  /// The next kept row; false at the end or on an error.
  bool next(TraceSample& s);
  std::size_t rows_skipped() const;
  std::size_t rows_repeated() const;
  const std::vector<std::string>& skipped_rows() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string source_, error_;
  bool ok_ = false, has_position_ = false, has_velocity_ = false;
};

/// A column written after t,x,v,u, as a function of each row's time (a
/// simulated temperature_C).
struct ExtraColumn {
  std::string name;
  std::function<double(double t_s)> of_time;
};

/// Writes t,x,v,u (and `extra` when given) with full precision. Returns
/// false with `error` set on failure.
bool write_trace_csv(const std::string& path, const Trace& trace, std::string& error, const ExtraColumn* extra = nullptr);

}  // namespace feedid::host
