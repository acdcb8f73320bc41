#include "held_values.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>

namespace feedid::host {

HoldPattern detect_hold(const std::vector<double>& y, double min_change) {
  HoldPattern out;
  std::map<int, std::size_t> spacing;  // rows between counted changes -> how often
  std::size_t last_change = 0;
  bool have_last = false;
  for (std::size_t k = 1; k < y.size(); ++k) {
    if (y[k] == y[k - 1]) continue;
    if (have_last && std::fabs(y[k] - y[k - 1]) > min_change) {
      ++spacing[static_cast<int>(std::min<std::size_t>(k - last_change, 1000))];
      ++out.changes;
    }
    last_change = k;
    have_last = true;
  }
  if (out.changes < 20) return out;
  const auto commonest = std::max_element(spacing.begin(), spacing.end(),
                                          [](const auto& a, const auto& b) { return a.second < b.second; });
  const int period = commonest->first;
  std::size_t near = 0;
  for (const auto& [rows, count] : spacing)
    if (std::abs(rows - period) <= 1) near += count;
  if (period >= 2 && 4 * near >= 3 * out.changes) out.period_rows = period;
  return out;
}

void spread_held_values(std::vector<double>& y, const std::vector<double>& t, int max_rows, double max_step_s) {
  const std::size_t n = y.size();
  std::size_t from = n;  // row where the current value first appeared (n: none yet)
  const std::vector<double> logged = y;
  for (std::size_t k = 1; k < n; ++k) {
    if (t[k] - t[k - 1] > max_step_s) { from = n; continue; }  // a gap: a new start, nothing spread across it
    if (logged[k] == logged[k - 1]) continue;
    if (from < n && k - from <= static_cast<std::size_t>(max_rows) && k - from >= 2) {
      const double y0 = logged[from], slope = (logged[k] - y0) / (t[k] - t[from]);
      for (std::size_t j = from + 1; j < k; ++j) y[j] = y0 + slope * (t[j] - t[from]);
    }
    from = k;
  }
}

}  // namespace feedid::host
