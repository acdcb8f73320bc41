// Reading and writing traces as CSV. Host only.
#include "csv_trace.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <vector>

#include "trace_rows.hpp"

namespace feedid::host {
namespace {

// Roles a header column can play (a column may serve several).
enum Role : unsigned {
  kTime = 1u << 0,
  kPosition = 1u << 1,
  kVelocity = 1u << 2,
  kForce = 1u << 3,
};

std::string errno_text(int err) { return std::strerror(err); }

/// Reads the whole file into `out`. On failure returns false with `error` set.
bool read_file(const std::string& path, std::string& out, std::string& error) {
  errno = 0;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    error = path + ": cannot open: " + errno_text(errno);
    return false;
  }
  // Size hint when the file is seekable (not for directories and the like,
  // where ftell can report nonsense); the read loop does not rely on it.
  long size = -1;
  if (std::fseek(f, 0, SEEK_END) == 0) {
    size = std::ftell(f);
    std::rewind(f);
  }
  char chunk[1 << 16];
  bool first = true;
  for (;;) {
    const std::size_t n = std::fread(chunk, 1, sizeof chunk, f);
    if (first && n > 0 && size > 0 &&
        static_cast<unsigned long>(size) < out.max_size() / 2) {
      out.reserve(static_cast<std::size_t>(size) + 1);
    }
    first = false;
    if (n > 0) out.append(chunk, n);
    if (n < sizeof chunk) break;
  }
  if (std::ferror(f)) {
    const int err = errno;
    std::fclose(f);
    error = path + ": cannot read: " + errno_text(err);
    return false;
  }
  std::fclose(f);
  return true;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

/// Trims whitespace, then one pair of surrounding double quotes (and whitespace inside).
std::string_view trim_field(const char* b, const char* e) {
  while (b < e && is_space(*b)) ++b;
  while (e > b && is_space(e[-1])) --e;
  if (e - b >= 2 && *b == '"' && e[-1] == '"') {
    ++b;
    --e;
    while (b < e && is_space(*b)) ++b;
    while (e > b && is_space(e[-1])) --e;
  }
  return std::string_view(b, static_cast<std::size_t>(e - b));
}

/// True when [b, e) holds only whitespace other than the separator.
bool is_blank(const char* b, const char* e, char sep) {
  for (; b < e; ++b) {
    if (*b == sep || !is_space(*b)) return false;
  }
  return true;
}

/// Splits [b, e) at `sep` into `fields` (raw, untrimmed ranges).
void split(const char* b, const char* e, char sep,
           std::vector<std::pair<const char*, const char*>>& fields) {
  fields.clear();
  for (;;) {
    const void* hit = std::memchr(b, sep, static_cast<std::size_t>(e - b));
    if (hit == nullptr) {
      fields.emplace_back(b, e);
      return;
    }
    const char* s = static_cast<const char*>(hit);
    fields.emplace_back(b, s);
    b = s + 1;
  }
}

/// 'text' with bytes outside printable ASCII as \xNN: a message never
/// echoes raw binary to the terminal.
std::string quoted(std::string_view s) {
  std::string r;
  r.reserve(s.size() + 2);
  r += '\'';
  for (const char c : s) {
    const auto b = static_cast<unsigned char>(c);
    if (b >= 0x20 && b < 0x7f) {
      r += c;
    } else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02X", b);
      r += hex;
    }
  }
  r += '\'';
  return r;
}

/// Parsed line cursor over an in-memory buffer; counts lines 1-based.
struct LineCursor {
  const char* p;
  const char* end;
  std::size_t line = 0;  ///< number of the line last returned

  /// Next line without its '\n' (a trailing '\r' is left for trimming).
  bool next(const char*& b, const char*& e) {
    if (p >= end) return false;
    b = p;
    const void* nl = std::memchr(p, '\n', static_cast<std::size_t>(end - p));
    e = nl ? static_cast<const char*>(nl) : end;
    p = nl ? e + 1 : end;
    ++line;
    return true;
  }
};

}  // namespace

CsvResult read_trace_csv(const std::string& path, const CsvColumns& columns) {
  std::string buf;
  CsvResult failed;
  if (!read_file(path, buf, failed.error)) return failed;
  return parse_trace_csv(buf, path, columns);
}

CsvResult parse_trace_csv(const std::string& buf, const std::string& path, const CsvColumns& columns) {
  CsvResult result;
  result.trace.source = path;
  result.trace.has_position = false;
  result.trace.has_velocity = false;
  result.error = scale_error(columns);
  if (!result.error.empty()) return result;

  const char* data = buf.data();
  const char* data_end = data + buf.size();
  if (buf.size() >= 3 && static_cast<unsigned char>(data[0]) == 0xEF &&
      static_cast<unsigned char>(data[1]) == 0xBB && static_cast<unsigned char>(data[2]) == 0xBF) {
    data += 3;
  }
  LineCursor cursor{data, data_end};
  RowRules rules(columns, result.trace, path + ":", "line");

  // --- header: first non-blank line --------------------------------------
  const char* hb = nullptr;
  const char* he = nullptr;
  bool have_header = false;
  while (cursor.next(hb, he)) {
    if (!is_blank(hb, he, '\0')) {
      have_header = true;
      break;
    }
  }
  if (!have_header) {
    result.error = path + ": empty file (no header row)";
    return result;
  }
  const std::size_t header_line = cursor.line;
  const std::string_view header_text(hb, static_cast<std::size_t>(he - hb));
  char sep = ',';
  if (header_text.find(',') == std::string_view::npos) {
    if (header_text.find(';') != std::string_view::npos) {
      sep = ';';
    } else if (header_text.find('\t') != std::string_view::npos) {
      sep = '\t';
    }
  }

  std::vector<std::pair<const char*, const char*>> fields;
  split(hb, he, sep, fields);
  std::vector<std::string> names;
  names.reserve(fields.size());
  for (const auto& f : fields) names.emplace_back(trim_field(f.first, f.second));
  const std::size_t ncols = names.size();

  auto header_list = [&] {
    std::string s;
    for (std::size_t i = 0; i < ncols; ++i) {
      if (i) s += ", ";
      s += names[i];
    }
    return s;
  };
  // Index of `name` in the header, -1 if absent, -2 if it appears twice.
  auto find_column = [&](const std::string& name) -> long {
    if (name.empty()) return -1;
    long found = -1;
    for (std::size_t i = 0; i < ncols; ++i) {
      if (names[i] == name) {
        if (found >= 0) return -2;
        found = static_cast<long>(i);
      }
    }
    return found;
  };

  struct Wanted {
    const std::string* name;
    const char* role_name;
    unsigned role;
    long index;
  };
  Wanted wanted[4] = {{&columns.time, "time", kTime, -1},
                      {&columns.position, "position", kPosition, -1},
                      {&columns.velocity, "velocity", kVelocity, -1},
                      {&columns.force, "force", kForce, -1}};
  for (Wanted& w : wanted) {
    w.index = find_column(*w.name);
    if (w.index == -2) {
      result.error = rules.at(header_line) + "column " + quoted(*w.name) + " (" + w.role_name +
                     ") appears more than once; header has: " + header_list();
      return result;
    }
  }
  for (const Wanted& w : {wanted[0], wanted[3]}) {
    if (w.index < 0) {
      result.error = rules.at(header_line) + "missing column " + quoted(*w.name) + " (" + w.role_name +
                     "); header has: " + header_list();
      return result;
    }
  }
  if (wanted[1].index < 0 && wanted[2].index < 0) {
    result.error = rules.at(header_line) + "missing column " + quoted(columns.position) +
                   " (position) and " + quoted(columns.velocity) +
                   " (velocity); need at least one; header has: " + header_list();
    return result;
  }
  result.trace.has_position = wanted[1].index >= 0;
  result.trace.has_velocity = wanted[2].index >= 0;

  // Roles per column index; only columns with a role are parsed.
  std::vector<unsigned> roles(ncols, 0u);
  for (const Wanted& w : wanted) {
    if (w.index >= 0) roles[static_cast<std::size_t>(w.index)] |= w.role;
  }

  // --- data rows -----------------------------------------------------------
  std::vector<TraceSample>& samples = result.trace.samples;
  samples.reserve(static_cast<std::size_t>(std::count(cursor.p, cursor.end, '\n')) + 1);
  auto stop = [&] {
    result.error = rules.error();
    return result;
  };
  std::string_view prev_row;

  const char* lb = nullptr;
  const char* le = nullptr;
  while (cursor.next(lb, le)) {
    if (is_blank(lb, le, sep)) continue;
    const std::size_t line = cursor.line;
    rules.count_row();
    const std::string_view row_text(lb, static_cast<std::size_t>(le - lb));
    if (!samples.empty() && row_text == prev_row) {  // the logger wrote the same sample twice
      rules.repeated();
      continue;
    }
    split(lb, le, sep, fields);
    if (fields.size() != ncols) {
      if (!rules.bad(rules.at(line) + "expected " + std::to_string(ncols) + " fields, found " + std::to_string(fields.size())))
        return stop();
      continue;
    }
    bool row_ok = true;
    TraceSample s;
    std::string_view time_text;
    for (std::size_t i = 0; i < ncols && row_ok; ++i) {
      const unsigned r = roles[i];
      if (r == 0u) continue;
      const std::string_view text = trim_field(fields[i].first, fields[i].second);
      std::string why;
      // `text` starts with a non-space character, so strtod skips nothing and
      // stops no later than the separator / line end that bounds the field
      // (the buffer is NUL-terminated, so it cannot run off the end).
      char* endp = nullptr;
      errno = 0;
      const double value = text.empty() ? 0.0 : std::strtod(text.data(), &endp);
      if (text.empty())
        why = ": empty value";
      else if (endp != text.data() + text.size())
        why = ": " + quoted(text) + " is not a number";
      else if (!std::isfinite(value))
        why = errno == ERANGE ? ": " + quoted(text) + " is out of range for a double" : ": value is NaN/Inf";
      if (!why.empty()) {
        row_ok = false;
        if (!rules.bad(rules.at(line) + "column " + quoted(names[i]) + why)) return stop();
        break;
      }
      if (r & kTime) {
        s.t_s = value;
        time_text = text;
      }
      if (r & kPosition) s.x_m = value * columns.position_scale;
      if (r & kVelocity) s.v_m_s = value * columns.position_scale;
      if (r & kForce) s.u_N = value * columns.force_scale;
    }
    if (!row_ok) continue;
    const std::size_t kept = samples.size();
    if (!rules.take(s, time_text, line)) return stop();
    if (samples.size() > kept) prev_row = row_text;
  }
  if (!rules.finish(path)) return stop();
  result.ok = true;
  return result;
}

bool write_trace_csv(const std::string& path, const Trace& trace, std::string& error) {
  errno = 0;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) {
    error = path + ": cannot write: " + errno_text(errno);
    return false;
  }
  // Format into a buffer and write it in large blocks. std::to_chars with
  // general format and precision 17 gives the same text as printf("%.17g")
  // in the C locale, which round-trips every double exactly.
  std::string out;
  constexpr std::size_t kFlushAt = 1 << 20;
  out.reserve(kFlushAt + 256);
  out += "t,x,v,u\n";

  bool ok = true;
  int err = 0;
  auto flush = [&] {
    if (ok && !out.empty() && std::fwrite(out.data(), 1, out.size(), f) != out.size()) {
      ok = false;
      err = errno;
    }
    out.clear();
  };
  auto put = [&](double v, char after) {
    char tmp[40];
    const std::to_chars_result r =
        std::to_chars(tmp, tmp + sizeof tmp, v, std::chars_format::general, 17);
    out.append(tmp, static_cast<std::size_t>(r.ptr - tmp));
    out += after;
  };
  for (const TraceSample& s : trace.samples) {
    put(s.t_s, ',');
    put(s.x_m, ',');
    put(s.v_m_s, ',');
    put(s.u_N, '\n');
    if (out.size() >= kFlushAt) {
      flush();
      if (!ok) break;
    }
  }
  flush();
  if (ok && std::fflush(f) != 0) {
    ok = false;
    err = errno;
  }
  if (std::fclose(f) != 0 && ok) {
    ok = false;
    err = errno;
  }
  if (!ok) {
    error = path + ": cannot write: " + errno_text(err != 0 ? err : EIO);
    return false;
  }
  return true;
}

}  // namespace feedid::host
