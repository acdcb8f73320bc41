// Numbers with the digits their uncertainty justifies, written once for the
// text summaries and the HTML report. Host only.
#pragma once
#include <cmath>
#include <cstdio>
#include <string>

namespace feedid::host {

struct Rounded {
  std::string value, se;
};

/// v and its standard error: two significant digits of se, v rounded to the
/// same place (0.0612 +- 0.38 becomes 0.06 and 0.38). Without a usable se,
/// v with four significant digits and se "?".
inline Rounded round_to_se(double v, double se) {
  char a[48], b[48];
  if (!(se > 0) || !std::isfinite(se) || !std::isfinite(v)) {
    std::snprintf(a, sizeof a, "%.4g", v);
    return {a, "?"};
  }
  const int place = static_cast<int>(std::floor(std::log10(se))) - 1;  // last digit kept, as a power of ten
  if (place >= 0) {
    const double q = std::pow(10.0, place);
    std::snprintf(a, sizeof a, "%.0f", std::round(v / q) * q);
    std::snprintf(b, sizeof b, "%.0f", std::round(se / q) * q);
  } else {
    std::snprintf(a, sizeof a, "%.*f", -place, v);
    std::snprintf(b, sizeof b, "%.*f", -place, se);
  }
  return {a, b};
}

}  // namespace feedid::host
