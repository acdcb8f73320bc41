// Vectors in memory as a trace, by the readers' row rules.
#include "column_trace.hpp"

#include <cmath>
#include <cstdio>

#include "message_text.hpp"
#include "trace_rows.hpp"

namespace feedid::host {

CsvResult trace_from_columns(const TraceColumns& c, const CsvColumns& columns, const std::string& source,
                             std::size_t first_index) {
  CsvResult result;
  Trace& tr = result.trace;
  tr.source = source;
  tr.has_position = !c.x.empty();
  tr.has_velocity = !c.v.empty();
  tr.time_unit_stated = time_unit_stated(columns);
  result.error = scale_error(columns);
  if (!result.error.empty()) return result;
  if (!tr.has_position && !tr.has_velocity) {
    result.error = source + ": no position and no velocity; need at least one";
    return result;
  }
  for (const auto* other : {&c.u, &c.x, &c.v})
    if (!other->empty() && other->size() != c.t.size()) {
      result.error = source + ": the signals differ in length (time " + quoted_text(columns.time) + " has " +
                     std::to_string(c.t.size()) + " elements, another " + std::to_string(other->size()) + ")";
      return result;
    }

  RowRules rules(columns, tr, source + ": element ", "element");
  auto stop = [&] {
    result.error = rules.error();
    return result;
  };
  tr.samples.reserve(c.t.size());
  const double seconds_per_unit = time_scale(columns);
  char time_text[32];
  for (std::size_t k = 0; k < c.t.size(); ++k) {
    rules.count_row();
    TraceSample s;
    s.t_s = c.t[k] * seconds_per_unit;
    s.x_m = c.x.empty() ? 0.0 : c.x[k] * position_scale(columns);
    s.v_m_s = c.v.empty() ? 0.0 : c.v[k] * position_scale(columns);
    s.u_N = c.u[k] * columns.force_scale;
    const std::size_t row = k + first_index;
    if (!std::isfinite(s.t_s) || !std::isfinite(s.x_m) || !std::isfinite(s.v_m_s) || !std::isfinite(s.u_N)) {
      if (!rules.bad(rules.at(row) + "a value is NaN/Inf")) return stop();
      continue;
    }
    const TraceSample* last = rules.last_kept();
    if (last && last->t_s == s.t_s && last->x_m == s.x_m && last->v_m_s == s.v_m_s && last->u_N == s.u_N) {
      rules.repeated();
      continue;
    }
    std::snprintf(time_text, sizeof time_text, "%.17g", s.t_s);
    if (rules.take(s, time_text, row) == RowRules::Taken::stop) return stop();
  }
  if (!rules.finish(source)) return stop();
  result.ok = true;
  return result;
}

}  // namespace feedid::host
