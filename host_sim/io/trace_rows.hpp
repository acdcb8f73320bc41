// The rules every trace reader applies to its rows, written once for the
// CSV and the MATLAB readers: a row that cannot be read, or whose time does
// not increase, is skipped and counted with where and why (or, strict, is
// the error); a row that repeats the one before exactly is counted and left
// out, never kept as a zero-length interval; more than a set share of bad
// rows is an error. A row is held until the next one confirms its time, so
// that a lone row stamped ahead of its neighbours is the one skipped, not
// every row after it, and two rows out of order with each other are both
// left out. Host only.
#pragma once
#include <cmath>
#include <string>
#include <string_view>
#include <utility>

#include "csv_trace.hpp"
#include "message_text.hpp"
#include "trace.hpp"

namespace feedid::host {

/// "" or why the scales cannot be applied (zero or not finite; a negative
/// time scale would reverse time). `prefix` starts each scale's name: "--"
/// for the options, "" for the keys of an --in-list line.
inline std::string scale_error(const CsvColumns& c, const char* prefix = "--") {
  if (!std::isfinite(c.rate_hz) || c.rate_hz < 0.0)
    return prefix + std::string("rate ") + std::to_string(c.rate_hz) + ": must be a positive sample rate in Hz";
  if (!std::isfinite(c.time_scale) || c.time_scale < 0.0)
    return prefix + std::string("time-scale ") + std::to_string(c.time_scale) +
           ": must be positive (0: from the time column's name)";
  for (const auto& [name, scale] : {std::pair<const char*, double>{"position-scale", c.position_scale},
                                    {"force-scale", c.force_scale}})
    if (!std::isfinite(scale) || scale == 0.0)
      return prefix + std::string(name) + " " + std::to_string(scale) + ": a scale must be finite and non-zero";
  return "";
}

class RowRules {
 public:
  /// where_prefix starts every message ("file.csv:"); row_word names a row
  /// in them ("line" for a text file, "row" for a matrix).
  RowRules(const CsvColumns& columns, Trace& trace, std::string where_prefix, const char* row_word)
      : columns_(columns), trace_(trace), where_prefix_(std::move(where_prefix)), row_word_(row_word) {}

  /// "file.csv:12: ", the start of a message about row `row`.
  std::string at(std::size_t row) const { return where_prefix_ + std::to_string(row) + ": "; }

  /// Every row offered, read or not (the share of bad rows is of these).
  void count_row() { ++rows_; }
  std::size_t rows() const { return rows_; }

  /// A row that could not be read; `why` names file, row and column.
  /// False: stop reading, error() says why (--bad-rows error).
  bool bad(std::string why) {
    if (!columns_.skip_bad_rows) {
      error_ = std::move(why);
      trace_.samples.clear();
      return false;
    }
    ++trace_.rows_skipped;
    if (trace_.skipped_rows.size() < 5) trace_.skipped_rows.push_back(std::move(why));
    return true;
  }

  /// A row the logger wrote twice: counted, left out.
  void repeated() { ++trace_.rows_repeated; }

  /// What take() did with a row: a skipped row is counted and must not be
  /// handed on (a stream that did fed the core a step back in time).
  enum class Taken { kept, skipped, stop };

  /// Row `row`, read whole: held if its time increases, else a bad row
  /// (skipped, or stop: error() says why). `time_text` is the time as
  /// written, for the message. The row held before it is then confirmed
  /// and appended to the trace's samples, where a reader takes it from;
  /// finish() appends the last. Where the new row goes back before the
  /// held one but not before the row confirmed ahead of it, and the held
  /// row's step is far longer than the steps around it, the held row is
  /// the one out of order (one row stamped in the future): it is the row
  /// skipped, and the new one is held instead. Where the held row's step
  /// is out of line but not that far, both are skipped (skip_both); else
  /// the new row is skipped alone.
  Taken take(const TraceSample& s, std::string_view time_text, std::size_t row) {
    if (have_held_ && !(s.t_s > held_.t_s)) {
      if (!held_is_ahead(s.t_s))
        return s.t_s < held_.t_s && s.t_s > confirmed_time_ && held_out_of_line() ? skip_both(time_text, row)
                                                                                   : skip_new(time_text, row);
      if (!bad(at(held_row_) + "column " + quoted_text(columns_.time) + ": time " + quoted_text(held_text_) +
               " is ahead of the rows around it (" + quoted_text(confirmed_text_) + " on " + row_word_ + " " +
               std::to_string(confirmed_row_) + ", " + quoted_text(time_text) + " on " + row_word_ + " " +
               std::to_string(row) + "): a lone time stamp out of order"))
        return Taken::stop;
      hold(s, time_text, row);
      return Taken::kept;
    }
    if (have_held_) confirm_held();
    hold(s, time_text, row);
    return Taken::kept;
  }

  /// The row kept last (held or confirmed), or null: what a repeated row is compared with.
  const TraceSample* last_kept() const { return have_held_ ? &held_ : nullptr; }

  /// After the last row: the held row appended to the samples (a stream
  /// hands it on before finish() judges the whole).
  void flush() {
    if (have_held_) confirm_held();
    have_held_ = false;
  }

  /// After the last row: flush(), and true, or false with error() set
  /// (more than the allowed share of bad rows; no rows at all).
  bool finish(const std::string& path) {
    flush();
    if (trace_.rows_skipped > 0 &&
        static_cast<double>(trace_.rows_skipped) > columns_.max_bad_row_share * static_cast<double>(rows_)) {
      error_ = path + ": " + std::to_string(trace_.rows_skipped) + " of " + std::to_string(rows_) +
               " rows are bad, more than " + std::to_string(static_cast<int>(100 * columns_.max_bad_row_share + 0.5)) +
               " %; the first: " + trace_.skipped_rows.front();
      for (std::size_t i = 1; i < trace_.skipped_rows.size(); ++i) error_ += "; " + trace_.skipped_rows[i];
      trace_.samples.clear();
      return false;
    }
    if (confirmed_ == 0) {
      error_ = path + ": no data rows";
      return false;
    }
    return true;
  }

  const std::string& error() const { return error_; }

 private:
  /// A held row this many times the steps around it ahead is a time stamp
  /// out of order, not the new row a step back (a log's jitter is a
  /// fraction of a period; a lone wrong stamp is seconds or years off).
  static constexpr double kAheadSteps = 2.0;

  /// Whether the held row, not the new one at time t, is out of order: t
  /// lies after the row confirmed before the held one, and the held row's
  /// step from it is over kAheadSteps times both t's and the step before.
  bool held_is_ahead(double t) const {
    if (!have_confirmed_ || !(t > confirmed_time_)) return false;
    const double held_step = held_.t_s - confirmed_time_;
    return held_step > kAheadSteps * (t - confirmed_time_) && (!(confirmed_step_ > 0.0) || held_step > kAheadSteps * confirmed_step_);
  }

  /// A held row's step from the confirmed one beyond this many of the step
  /// before is out of line with its own past too (a swapped pair's first
  /// row is two steps on; a row in line is one).
  static constexpr double kOutOfLineSteps = 1.5;

  bool held_out_of_line() const {
    return have_confirmed_ && confirmed_step_ > 0.0 && held_.t_s - confirmed_time_ > kOutOfLineSteps * confirmed_step_;
  }

  Taken skip_new(std::string_view time_text, std::size_t row) {
    const bool skipped = bad(at(row) + "column " + quoted_text(columns_.time) + ": time " + quoted_text(time_text) +
                             " is not greater than previous " + quoted_text(held_text_) + " on " + row_word_ + " " +
                             std::to_string(held_row_) + " (time must increase)");
    return skipped ? Taken::skipped : Taken::stop;
  }

  /// The new row goes back before the held one but not before the row
  /// confirmed ahead of them, and the held row's step is out of line too:
  /// two rows whose stamps are swapped, or one of them stamped a step off. Which is wrong cannot
  /// be told, and a row kept at the wrong time is a spike in the velocity
  /// and the acceleration (a swapped pair on EMPS PULSES doubled
  /// diagnose's gap), so both are left out.
  Taken skip_both(std::string_view time_text, std::size_t row) {
    const std::string why = "column " + quoted_text(columns_.time) + ": times " + quoted_text(held_text_) + " on " +
                            row_word_ + " " + std::to_string(held_row_) + " and " + quoted_text(time_text) + " on " +
                            row_word_ + " " + std::to_string(row) +
                            " are out of order (time must increase); which is stamped wrong cannot be told, so "
                            "both rows are left out";
    if (!bad(at(held_row_) + why)) return Taken::stop;
    have_held_ = false;
    return bad(at(row) + "column " + quoted_text(columns_.time) + ": out of order with " + row_word_ + " " +
               std::to_string(held_row_) + ", left out with it")
               ? Taken::skipped
               : Taken::stop;
  }

  void hold(const TraceSample& s, std::string_view time_text, std::size_t row) {
    held_ = s;
    held_text_.assign(time_text);  // reuses its capacity: no allocation per row
    held_row_ = row;
    have_held_ = true;
  }

  void confirm_held() {
    if (have_confirmed_) confirmed_step_ = held_.t_s - confirmed_time_;
    confirmed_time_ = held_.t_s;
    confirmed_text_.swap(held_text_);
    confirmed_row_ = held_row_;
    have_confirmed_ = true;
    ++confirmed_;
    trace_.samples.push_back(held_);
  }

  const CsvColumns& columns_;
  Trace& trace_;
  std::string where_prefix_;
  const char* row_word_;
  std::size_t rows_ = 0, held_row_ = 0, confirmed_row_ = 0, confirmed_ = 0;
  bool have_held_ = false, have_confirmed_ = false;
  TraceSample held_{};
  double confirmed_time_ = 0.0, confirmed_step_ = 0.0;
  std::string held_text_, confirmed_text_, error_;
};

}  // namespace feedid::host
