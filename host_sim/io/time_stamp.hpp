// ISO 8601 date-times in a time column (2026-11-25T12:00:00.123Z), as
// loggers write them, read to whole seconds plus a fraction so that the
// time since the first row keeps its microseconds: a double of seconds
// since 1970 keeps only about 0.2 us. Host only.
#pragma once
#include <cstdint>
#include <string_view>

namespace feedid::host {

/// A date-time in UTC: whole seconds since 1970-01-01 and the fraction.
struct IsoTime {
  std::int64_t seconds = 0;
  double fraction = 0.0;  ///< in [0, 1)
};

/// Reads `YYYY-MM-DD` then `T`, `t` or one space, `hh:mm:ss`, an optional
/// fraction after `.` (or `,` when comma_fraction: ISO allows it, and a
/// `;`-separated log with decimal commas writes it), and an optional zone:
/// `Z`, `+hh:mm`, `+hhmm` or `+hh` (or `-`). A stamp without a zone is taken
/// as UTC: only differences are used, so one zone throughout is enough.
/// False when `text` is anything else or a field is out of range.
bool parse_iso8601(std::string_view text, bool comma_fraction, IsoTime& out);

/// Seconds from `from` to `to`, exact to the fraction's precision.
inline double seconds_between(const IsoTime& from, const IsoTime& to) {
  return static_cast<double>(to.seconds - from.seconds) + (to.fraction - from.fraction);
}

}  // namespace feedid::host
