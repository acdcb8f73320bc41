// libFuzzer target: arbitrary bytes as a trace CSV (host_sim/io/csv_trace.hpp).
// Invariants, besides ASan/UBSan: a parse either fails with a message that
// names the source, or gives a trace whose every value is finite, whose time
// increases strictly, and which has force and position or velocity. Every
// message (the error, each skipped row) is printable ASCII and bounded
// (is_bounded_printable), whatever bytes the input holds.
// Build: cmake -DFEEDID_FUZZ=ON with clang (docs/reference.md, "Fuzzing").
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "io/csv_trace.hpp"
#include "io/message_text.hpp"

namespace {
void require(bool ok) {
  if (!ok) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const feedid::host::CsvResult r = feedid::host::parse_trace_csv(text, "fuzz.csv", feedid::host::CsvColumns{});
  require(feedid::host::is_bounded_printable(r.error));
  for (const auto& why : r.trace.skipped_rows) require(feedid::host::is_bounded_printable(why));
  for (const auto& note : r.trace.notes) require(feedid::host::is_bounded_printable(note));
  if (!r.ok) {
    require(r.error.rfind("fuzz.csv", 0) == 0);
    return 0;
  }
  require(r.error.empty());
  require(r.trace.has_position || r.trace.has_velocity);
  double t_prev = -INFINITY;
  for (const auto& s : r.trace.samples) {
    require(std::isfinite(s.t_s) && std::isfinite(s.x_m) && std::isfinite(s.v_m_s) && std::isfinite(s.u_N));
    require(s.t_s > t_prev);
    t_prev = s.t_s;
  }
  return 0;
}
