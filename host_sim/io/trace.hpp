// A recorded or simulated trace of one axis, in SI units, as the host tools
// pass it around. Host only: uses the standard library freely.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace feedid::host {

struct TraceSample {
  double t_s = 0.0;      ///< time (s)
  double x_m = 0.0;      ///< position (m), load side
  double v_m_s = 0.0;    ///< velocity (m/s), as the drive reports it
  double u_N = 0.0;      ///< drive force (N), load side
};

/// One recording inside a trace that pools several (feedid ... --in a.csv --in b.csv).
struct TraceRun {
  std::string source;          ///< file name
  std::size_t first = 0;       ///< index of its first sample in Trace::samples
  std::size_t samples = 0;
  double time_shift_s = 0.0;   ///< added to its time stamps so that runs follow each other
  double time_origin_s = 0.0;  ///< its file's time origin (Trace::time_origin_s)
  std::size_t rows_skipped = 0, rows_repeated = 0;
};

struct Trace {
  std::vector<TraceSample> samples;
  bool has_position = true;
  bool has_velocity = true;
  std::string source;  ///< file name or "simulator", for messages
  std::size_t rows_skipped = 0;   ///< bad rows the reader left out
  std::size_t rows_repeated = 0;  ///< rows that repeated the previous one exactly
  std::vector<std::string> skipped_rows;  ///< the first few skips, with file:line and why
  /// What the reader did with the file's format, for a note each ("a.csv:
  /// 3 lines before the header ... left out"; ISO 8601 stamps read).
  std::vector<std::string> notes;
  /// Pooled recordings, in order (empty for one file). Between two runs the
  /// time jumps by kRunGap_s, a gap every stage treats as a break: no
  /// integral, section, window or block spans two files.
  std::vector<TraceRun> runs;
  static constexpr double kRunGap_s = 10.0;
  /// The time column's unit was stated (--time-scale, or a unit ending its
  /// name: t_s, t_ms, "time [us]"); otherwise seconds were assumed, and a
  /// log too slow for a drive is refused (condition.hpp).
  bool time_unit_stated = false;
  /// What the file's time stamps count from (s): a numeric time column
  /// whose first stamp is 1e6 or more (Unix time) is read as the time since
  /// that stamp's whole part, so that a double keeps its digits
  /// (csv_table.hpp, Layout::time_origin). Pooled: the runs' own where they
  /// share it, NaN where they differ (TraceRun::time_origin_s says each).
  /// 0: the stamps as logged.
  double time_origin_s = 0.0;
};

}  // namespace feedid::host
