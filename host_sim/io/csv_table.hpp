// The table inside a trace CSV, written once for the whole-file and the
// streamed reader (csv_trace.cpp), which feed it the same lines and so read
// the same formats: where the table starts (after comment and metadata
// lines), its separator (`,`, `;` or tab; a `,` inside a number of a `;` or
// tab file is its decimal point), its columns (named by the header row, or
// by position with --columns for a file without one), its time (seconds, or
// ISO 8601 stamps), and the reading of one row by the row rules
// (trace_rows.hpp). Host only.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "csv_trace.hpp"
#include "time_stamp.hpp"
#include "trace_rows.hpp"

namespace feedid::host::csv {

/// A line's fields as raw (untrimmed) ranges.
using Fields = std::vector<std::pair<const char*, const char*>>;

/// Splits [b, e) at `sep` into `fields`.
void split(const char* b, const char* e, char sep, Fields& fields);
/// True when [b, e) holds only whitespace other than the separator.
bool is_blank(const char* b, const char* e, char sep);
/// Skips a UTF-8 byte-order mark.
const char* after_bom(const char* b, const char* e);

/// How the file's table is read, from its header (or --columns) and first data row.
struct Layout {
  char sep = ',';
  std::vector<std::string> names;  ///< from the header row, or --columns
  std::vector<unsigned> roles;     ///< per column: which signals it holds (time, position, ...), 0 for none
  bool has_position = false, has_velocity = false;
  /// The optional temperature and load columns (CsvColumns): whether read,
  /// and the last row's values (as logged, no scale).
  std::array<bool, 2> has_covariate{};
  std::array<double, 2> covariate{};
  double time_scale = 1.0;  ///< seconds per unit of the time column (time_scale(columns))
  double rate_hz = 0.0;     ///< > 0: no time column, data row k is at k / rate_hz (CsvColumns::rate_hz)
  bool iso_time = false;    ///< the time column holds ISO 8601 stamps (its first stamp that reads is one)
  bool have_epoch = false;  ///< epoch set: the first stamp read, from which times count
  IsoTime epoch;
  std::string epoch_text;
  /// A numeric time column whose first stamp is large (Unix time, 1.7e9 s;
  /// ms since an epoch, 1.7e12): its stamps are read as the time since the
  /// first one's whole part, digit by digit, as ISO stamps are. A double of
  /// the whole stamp keeps only 2.4e-7 s of 1.7e9, and that rounding moved
  /// identify's choices and diagnose's verdict on EMPS (docs/status.md,
  /// "Time origin"). 0: no origin, the stamps as they are.
  std::int64_t time_origin = 0;
  /// ISO 8601 or a number, and the origin, are decided: at the first stamp
  /// that reads as either (the first data row's, or a later one's where
  /// that row is bad: a comment line after the header).
  bool time_format_decided = false;
  bool time_format_noted = false;  ///< its note (ISO stamps, an origin) is in the trace's notes
  std::size_t table_line = 0;  ///< the header's line, or with --columns the first data row's
  std::size_t lines_before = 0, first_before_line = 0;  ///< lines before the table left out, and the first
  std::string first_before;
};

/// Finds the table, fed the file's lines in order (blank ones need not be):
/// comment lines (`#`, `%`, `//`) and metadata (`key: value`, a title, a
/// line with fewer fields than the table) before it are counted and left
/// out. The header is the first line that, split at `,`, `;` or tab, has
/// every column the options name; the search ends at the first data row
/// (numbers), so that a wrong name is said at once. With --columns the
/// table starts at the first line whose named fields read as values.
class TableSearch {
 public:
  TableSearch(const CsvColumns& columns, const RowRules& rules, std::string source);
  enum class Step {
    more,    ///< a line before the table: feed the next
    header,  ///< this line is the header; rows follow
    data,    ///< this line is the first data row (--columns): read it as a row
    error,   ///< error() says why
  };
  Step feed(const char* b, const char* e, std::size_t line);
  /// At the end of the file before the table: why (no header, no data row).
  std::string end_error() const;
  const std::string& error() const { return error_; }
  Layout& layout() { return layout_; }

 private:
  Step feed_named(const char* b, const char* e, std::size_t line);
  Step no_header_at_data(std::size_t line, std::size_t fields);
  void before_table(const char* b, const char* e, std::size_t line);
  const CsvColumns& columns_;
  const RowRules& rules_;
  std::string source_, error_;
  Layout layout_;
  Fields fields_;
  /// The nearest miss: the line with the most wanted names (else the most
  /// fields), its error and its field count.
  std::size_t best_matched_ = 0, best_fields_ = 0;
  std::string best_error_;
  bool any_candidate_ = false;
};

/// Sets layout.iso_time, or layout.time_origin, from the time field of the
/// first data row [b, e).
void detect_time_format(Layout& lay, const char* b, const char* e);

/// Decides from a time field whether the column holds ISO 8601 stamps, and
/// a numeric column's origin, unless decided already (or no time column);
/// a field that reads as neither leaves it undecided.
void decide_time_format(Layout& lay, std::string_view text);

/// Adds the note that says how the time column is read (ISO 8601 stamps,
/// or a numeric column's origin) to `notes`, once it is decided; the
/// readers call it after the layout and after every row.
void note_time_format(Layout& lay, const CsvColumns& columns, const std::string& source, std::vector<std::string>& notes);

/// The time origin in seconds (Trace::time_origin_s).
inline double time_origin_s(const Layout& lay) { return static_cast<double>(lay.time_origin) * lay.time_scale; }

/// What the reader did with the file's format, one note each (lines left
/// out before the table, ISO 8601 stamps), in words for the user.
std::vector<std::string> layout_notes(const Layout& lay, const CsvColumns& columns, const std::string& source);

enum class RowRead { kept, skipped, stop };

/// One data row [lb, le) (not blank; the buffer NUL-terminated after it)
/// through the row rules: kept, skipped (bad or repeated), or stop (the
/// error, in rules.error()). prev_row: the last kept row's text.
RowRead read_row(const char* lb, const char* le, std::size_t line, std::string_view prev_row, Layout& lay,
                 const CsvColumns& columns, RowRules& rules, Fields& fields, TraceSample& s);

}  // namespace feedid::host::csv
