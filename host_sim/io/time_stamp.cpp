// ISO 8601 date-times (time_stamp.hpp).
#include "time_stamp.hpp"

#include <cstdlib>

namespace feedid::host {
namespace {

/// Reads exactly `n` digits at `p` into `v`; false if any is not a digit.
bool digits(std::string_view s, std::size_t& p, int n, int& v) {
  if (p + static_cast<std::size_t>(n) > s.size()) return false;
  v = 0;
  for (int i = 0; i < n; ++i, ++p) {
    const char c = s[p];
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  return true;
}

/// Days from 1970-01-01 to y-m-d in the proleptic Gregorian calendar
/// (Howard Hinnant's days_from_civil).
std::int64_t days_from_civil(int y, int m, int d) {
  y -= m <= 2;
  const int era = (y >= 0 ? y : y - 399) / 400;
  const int yoe = y - era * 400;
  const int doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return static_cast<std::int64_t>(era) * 146097 + doe - 719468;
}

int days_in_month(int y, int m) {
  static constexpr int kDays[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const bool leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
  return m == 2 && leap ? 29 : kDays[m - 1];
}

/// The zone after the time, from `p` to the end: seconds east of UTC.
bool zone(std::string_view s, std::size_t p, int& east_s) {
  east_s = 0;
  if (p == s.size()) return true;
  if ((s[p] == 'Z' || s[p] == 'z') && p + 1 == s.size()) return true;
  if (s[p] != '+' && s[p] != '-') return false;
  const int sign = s[p] == '-' ? -1 : 1;
  int hh = 0, mm = 0;
  ++p;
  if (!digits(s, p, 2, hh)) return false;
  if (p < s.size() && s[p] == ':') ++p;
  if (p < s.size() && !digits(s, p, 2, mm)) return false;
  if (p != s.size() || hh > 23 || mm > 59) return false;
  east_s = sign * (hh * 3600 + mm * 60);
  return true;
}

}  // namespace

bool parse_iso8601(std::string_view s, bool comma_fraction, IsoTime& out) {
  std::size_t p = 0;
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, sec = 0;
  if (!digits(s, p, 4, y) || p >= s.size() || s[p++] != '-' || !digits(s, p, 2, mo) || p >= s.size() ||
      s[p++] != '-' || !digits(s, p, 2, d))
    return false;
  if (p >= s.size() || (s[p] != 'T' && s[p] != 't' && s[p] != ' ')) return false;
  ++p;
  if (!digits(s, p, 2, h) || p >= s.size() || s[p++] != ':' || !digits(s, p, 2, mi) || p >= s.size() ||
      s[p++] != ':' || !digits(s, p, 2, sec))
    return false;
  if (mo < 1 || mo > 12 || d < 1 || d > days_in_month(y, mo) || h > 23 || mi > 59 || sec > 59) return false;
  double fraction = 0.0;
  if (p < s.size() && (s[p] == '.' || (comma_fraction && s[p] == ','))) {
    const std::size_t first = ++p;
    while (p < s.size() && s[p] >= '0' && s[p] <= '9') ++p;
    if (p == first || p - first > 30) return false;
    // "0." and the digits through strtod: correctly rounded, unlike a sum
    // digit by digit (a parser off by an ulp moved EMPS's result; status.md).
    char buf[34] = "0.";
    s.copy(buf + 2, p - first, first);
    fraction = std::strtod(buf, nullptr);
  }
  int east_s = 0;
  if (!zone(s, p, east_s)) return false;
  out.seconds = days_from_civil(y, mo, d) * 86400 + h * 3600 + mi * 60 + sec - east_s;
  out.fraction = fraction;
  return true;
}

}  // namespace feedid::host
