// Reading and writing traces as CSV. Host only.
#include "csv_trace.hpp"
#include "output_file.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <string_view>
#include <vector>

#include "message_text.hpp"
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

std::string too_long_line(const std::string& path, std::size_t line) {
  return path + ":" + std::to_string(line) + ": line longer than " + std::to_string(kMaxLineBytes) +
         " bytes: not a trace CSV (a row is a few dozen bytes)";
}

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
  std::size_t line_bytes = 0, lines = 1;  // of the line being read
  for (;;) {
    const std::size_t n = std::fread(chunk, 1, sizeof chunk, f);
    if (first && n > 0 && size > 0 &&
        static_cast<unsigned long>(size) < out.max_size() / 2) {
      out.reserve(static_cast<std::size_t>(size) + 1);
    }
    first = false;
    if (n > 0) out.append(chunk, n);
    const char* begin = chunk;
    const char* end = chunk + n;
    const auto last_newline = std::find(std::make_reverse_iterator(end), std::make_reverse_iterator(begin), '\n');
    lines += static_cast<std::size_t>(std::count(begin, end, '\n'));
    line_bytes = last_newline.base() == begin ? line_bytes + n : static_cast<std::size_t>(end - last_newline.base());
    // Checked as it is read: /dev/zero or a 1 GiB line never fills memory.
    if (line_bytes > kMaxLineBytes) {
      std::fclose(f);
      error = too_long_line(path, lines);
      return false;
    }
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

namespace {

/// What the header says: separator, column names, and which role each
/// column plays (only columns with a role are parsed).
struct CsvLayout {
  char sep = ',';
  std::vector<std::string> names;
  std::vector<unsigned> roles;
  bool has_position = false, has_velocity = false;
  double time_scale = 1.0;  ///< seconds per unit of the time column (time_scale(columns))
  double rate_hz = 0.0;     ///< > 0: no time column, data row k is at k / rate_hz (CsvColumns::rate_hz)
};

/// Index of `name` in the header, -1 if absent, -2 if it appears twice.
long find_column(const std::vector<std::string>& names, const std::string& name) {
  if (name.empty()) return -1;
  long found = -1;
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) {
      if (found >= 0) return -2;
      found = static_cast<long>(i);
    }
  return found;
}

/// The header line [hb, he) against the wanted columns: the layout, or an
/// error naming the line, the column and what the header has.
bool parse_header(const char* hb, const char* he, const std::string& at_header, const CsvColumns& columns, CsvLayout& out,
                  std::string& error) {
  const std::string_view header_text(hb, static_cast<std::size_t>(he - hb));
  if (header_text.find(',') == std::string_view::npos)
    out.sep = header_text.find(';') != std::string_view::npos ? ';' : header_text.find('\t') != std::string_view::npos ? '\t' : ',';
  std::vector<std::pair<const char*, const char*>> fields;
  split(hb, he, out.sep, fields);
  for (const auto& f : fields) out.names.emplace_back(trim_field(f.first, f.second));
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
    w.index = find_column(out.names, *w.name);
    if (w.index == -2) {
      error = at_header + "column " + quoted_text(*w.name) + " (" + w.role_name + ") appears more than once; header has: " +
              name_list(out.names);
      return false;
    }
  }
  if (columns.rate_hz > 0 && wanted[0].index >= 0) {
    error = at_header + "--rate is for a log without a time column, and this one has " + quoted_text(columns.time) +
            ": give one or the other";
    return false;
  }
  out.rate_hz = columns.rate_hz;
  for (const Wanted& w : {wanted[0], wanted[3]})
    if (w.index < 0 && !(w.role == kTime && out.rate_hz > 0)) {
      error = at_header + "missing column " + quoted_text(*w.name) + " (" + w.role_name + "); header has: " + name_list(out.names) +
              (w.role == kTime ? " (a log without a time column: give its sample rate, --rate)" : "");
      return false;
    }
  if (wanted[1].index < 0 && wanted[2].index < 0) {
    error = at_header + "missing column " + quoted_text(columns.position) + " (position) and " + quoted_text(columns.velocity) +
            " (velocity); need at least one; header has: " + name_list(out.names);
    return false;
  }
  out.time_scale = time_scale(columns);
  out.has_position = wanted[1].index >= 0;
  out.has_velocity = wanted[2].index >= 0;
  out.roles.assign(out.names.size(), 0u);
  for (const Wanted& w : wanted)
    if (w.index >= 0) out.roles[static_cast<std::size_t>(w.index)] |= w.role;
  return true;
}

enum class RowRead { kept, skipped, stop };

/// One data row [lb, le) (not blank; the buffer NUL-terminated after it)
/// through the row rules: kept, skipped (bad or repeated), or stop (the
/// error, in rules.error()). prev_row: the last kept row's text.
RowRead read_row(const char* lb, const char* le, std::size_t line, std::string_view prev_row, const CsvLayout& lay,
                 const CsvColumns& columns, RowRules& rules, std::vector<std::pair<const char*, const char*>>& fields,
                 TraceSample& s) {
  rules.count_row();
  const std::string_view row_text(lb, static_cast<std::size_t>(le - lb));
  // Without a time column a row like the one before is the axis at rest, not a repeat.
  if (lay.rate_hz == 0 && !prev_row.empty() && row_text == prev_row) {  // the logger wrote the same sample twice
    rules.repeated();
    return RowRead::skipped;
  }
  split(lb, le, lay.sep, fields);
  const std::size_t ncols = lay.names.size();
  if (fields.size() != ncols)
    return rules.bad(rules.at(line) + "expected " + std::to_string(ncols) + " fields, found " + std::to_string(fields.size()))
               ? RowRead::skipped
               : RowRead::stop;
  s = TraceSample{};
  std::string_view time_text;
  std::string row_time;  // the time a --rate log's row is at, for messages
  if (lay.rate_hz > 0) {
    s.t_s = static_cast<double>(rules.rows() - 1) / lay.rate_hz;
    row_time = std::to_string(s.t_s);
    time_text = row_time;
  }
  for (std::size_t i = 0; i < ncols; ++i) {
    const unsigned r = lay.roles[i];
    if (r == 0u) continue;
    const std::string_view text = trim_field(fields[i].first, fields[i].second);
    // `text` starts with a non-space character, so strtod skips nothing and
    // stops no later than the separator / line end that bounds the field
    // (the buffer is NUL-terminated, so it cannot run off the end).
    char* endp = nullptr;
    errno = 0;
    const double value = text.empty() ? 0.0 : std::strtod(text.data(), &endp);
    std::string why;
    if (text.empty())
      why = ": empty value";
    else if (endp != text.data() + text.size())
      why = ": " + quoted_text(text) + " is not a number";
    else if (!std::isfinite(value))
      why = errno == ERANGE ? ": " + quoted_text(text) + " is out of range for a double" : ": value is NaN/Inf";
    if (!why.empty())
      return rules.bad(rules.at(line) + "column " + quoted_text(lay.names[i]) + why) ? RowRead::skipped : RowRead::stop;
    if (r & kTime) {
      s.t_s = value * lay.time_scale;
      time_text = text;
    }
    if (r & kPosition) s.x_m = value * columns.position_scale;
    if (r & kVelocity) s.v_m_s = value * columns.position_scale;
    if (r & kForce) s.u_N = value * columns.force_scale;
  }
  return rules.take(s, time_text, line) ? RowRead::kept : RowRead::stop;
}

/// Skips a UTF-8 byte-order mark.
const char* after_bom(const char* b, const char* e) {
  return e - b >= 3 && static_cast<unsigned char>(b[0]) == 0xEF && static_cast<unsigned char>(b[1]) == 0xBB &&
                 static_cast<unsigned char>(b[2]) == 0xBF
             ? b + 3
             : b;
}

}  // namespace

namespace {
struct TimeUnit {
  std::string_view suffix;
  double seconds;
};
constexpr TimeUnit kTimeUnits[] = {{"ms", 1e-3}, {"us", 1e-6}, {"\xC2\xB5s", 1e-6}, {"\xCE\xBCs", 1e-6}, {"ns", 1e-9}, {"s", 1.0}};

/// The unit ending a time column's name, after a non-letter or alone; null if none.
const TimeUnit* unit_ending(std::string_view name) {
  while (!name.empty() && (name.back() == ']' || name.back() == ')' || name.back() == ' ')) name.remove_suffix(1);
  for (const TimeUnit& u : kTimeUnits) {
    if (name.size() < u.suffix.size()) continue;
    std::string lower(name.substr(name.size() - u.suffix.size()));
    for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (lower != u.suffix) continue;
    const std::size_t before = name.size() - u.suffix.size();
    if (before == 0 || !std::isalpha(static_cast<unsigned char>(name[before - 1]))) return &u;
  }
  return nullptr;
}
}  // namespace

double time_unit_from_name(std::string_view name) {
  const TimeUnit* u = unit_ending(name);
  return u ? u->seconds : 1.0;
}

bool time_unit_stated(const CsvColumns& c) {
  return c.rate_hz > 0 || c.time_scale > 0 || (unit_ending(c.time) && c.time != "s");
}

CsvResult parse_trace_csv(const std::string& buf, const std::string& path, const CsvColumns& columns) {
  CsvResult result;
  result.trace.source = path;
  result.trace.has_position = false;
  result.trace.has_velocity = false;
  result.error = scale_error(columns);
  if (!result.error.empty()) return result;
  LineCursor cursor{after_bom(buf.data(), buf.data() + buf.size()), buf.data() + buf.size()};
  RowRules rules(columns, result.trace, path + ":", "line");

  const char* b = nullptr;
  const char* e = nullptr;
  bool have_header = false;
  while (!have_header && cursor.next(b, e)) {
    if (static_cast<std::size_t>(e - b) > kMaxLineBytes) {
      result.error = too_long_line(path, cursor.line);
      return result;
    }
    have_header = !is_blank(b, e, '\0');
  }
  if (!have_header) {
    result.error = path + ": empty file (no header row)";
    return result;
  }
  CsvLayout lay;
  if (!parse_header(b, e, rules.at(cursor.line), columns, lay, result.error)) return result;
  result.trace.has_position = lay.has_position;
  result.trace.has_velocity = lay.has_velocity;
  result.trace.time_unit_stated = time_unit_stated(columns);

  std::vector<TraceSample>& samples = result.trace.samples;
  samples.reserve(static_cast<std::size_t>(std::count(cursor.p, cursor.end, '\n')) + 1);
  std::vector<std::pair<const char*, const char*>> fields;
  std::string_view prev_row;
  TraceSample s;
  while (cursor.next(b, e)) {
    if (static_cast<std::size_t>(e - b) > kMaxLineBytes) {
      result.error = too_long_line(path, cursor.line);
      result.trace.samples.clear();
      return result;
    }
    if (is_blank(b, e, lay.sep)) continue;
    const RowRead r = read_row(b, e, cursor.line, prev_row, lay, columns, rules, fields, s);
    if (r == RowRead::stop) {
      result.error = rules.error();
      return result;
    }
    if (r == RowRead::kept) prev_row = std::string_view(b, static_cast<std::size_t>(e - b));
  }
  if (!rules.finish(path)) {
    result.error = rules.error();
    return result;
  }
  result.ok = true;
  return result;
}

struct CsvStream::Impl {
  std::ifstream file;
  CsvColumns columns;
  Trace counts;  ///< no samples kept: RowRules' counters and skipped rows
  RowRules rules;
  CsvLayout layout;
  std::vector<char> buf = std::vector<char>(kMaxLineBytes + 2);  ///< one line, NUL-terminated: the stream's bound
  std::string_view line;
  std::string prev_row;
  std::size_t line_no = 0, kept = 0;
  std::vector<std::pair<const char*, const char*>> fields;
  Impl(const std::string& path, const CsvColumns& c)
      : file(path, std::ios::binary), columns(c), rules(columns, counts, path + ":", "line") {}

  enum class Line { read, end, too_long };
  /// The next line into `line` (without its newline), never more than
  /// kMaxLineBytes of it held: a longer one is too_long, whatever its size.
  Line next_line() {
    file.getline(buf.data(), static_cast<std::streamsize>(buf.size()));
    const auto n = static_cast<std::size_t>(file.gcount());
    if (file.bad() || (file.fail() && file.eof() && n == 0)) return Line::end;
    if (file.fail() && !file.eof()) return Line::too_long;  // buf filled before a newline
    ++line_no;
    const std::size_t size = file.eof() ? n : n - 1;  // gcount counts the newline it took
    if (size > kMaxLineBytes) return Line::too_long;
    line = std::string_view(buf.data(), size);
    return Line::read;
  }
};

CsvStream::CsvStream(const std::string& path, const CsvColumns& columns) : impl_(std::make_unique<Impl>(path, columns)) {
  Impl& m = *impl_;
  source_ = path;
  error_ = scale_error(columns);
  if (!error_.empty()) return;
  if (!m.file) {
    error_ = path + ": cannot open: " + errno_text(errno);
    return;
  }
  for (Impl::Line got; (got = m.next_line()) != Impl::Line::end;) {
    if (got == Impl::Line::too_long) {
      error_ = too_long_line(path, m.line_no + 1);
      return;
    }
    const char* b = m.line.data();
    if (m.line_no == 1) b = after_bom(b, b + m.line.size());
    if (is_blank(b, m.line.data() + m.line.size(), '\0')) continue;
    if (parse_header(b, m.line.data() + m.line.size(), m.rules.at(m.line_no), columns, m.layout, error_)) {
      has_position_ = m.layout.has_position;
      has_velocity_ = m.layout.has_velocity;
      ok_ = true;
    }
    return;
  }
  error_ = path + ": empty file (no header row)";
}

CsvStream::~CsvStream() = default;

bool CsvStream::time_unit_stated() const { return feedid::host::time_unit_stated(impl_->columns); }

bool CsvStream::next(TraceSample& s) {
  if (!ok_) return false;
  Impl& m = *impl_;
  for (Impl::Line got; (got = m.next_line()) != Impl::Line::end;) {
    if (got == Impl::Line::too_long) {
      error_ = too_long_line(source_, m.line_no + 1);
      ok_ = false;
      return false;
    }
    const char* b = m.line.data();
    const char* e = b + m.line.size();
    if (is_blank(b, e, m.layout.sep)) continue;
    const RowRead r = read_row(b, e, m.line_no, m.prev_row, m.layout, m.columns, m.rules, m.fields, s);
    if (r == RowRead::stop) {
      error_ = m.rules.error();
      ok_ = false;
      return false;
    }
    if (r == RowRead::kept) {
      ++m.kept;
      m.counts.samples.clear();  // RowRules keeps each row; the stream hands it on instead
      m.prev_row.assign(b, e);   // reuses its capacity
      return true;
    }
  }
  // End of the file: too many bad rows, or none kept, is an error, in the
  // whole-file reader's words (finish() tells "no rows" by an empty trace).
  if (m.kept > 0) m.counts.samples.push_back(s);
  if (!m.rules.finish(source_)) error_ = m.rules.error();
  ok_ = false;
  return false;
}

std::size_t CsvStream::rows_skipped() const { return impl_->counts.rows_skipped; }
std::size_t CsvStream::rows_repeated() const { return impl_->counts.rows_repeated; }
const std::vector<std::string>& CsvStream::skipped_rows() const { return impl_->counts.skipped_rows; }

bool write_trace_csv(const std::string& path, const Trace& trace, std::string& error) {
  OutputFile f(path);
  // Format into a buffer and write it in large blocks. std::to_chars with
  // general format and precision 17 gives the same text as printf("%.17g")
  // in the C locale, which round-trips every double exactly.
  std::string out;
  constexpr std::size_t kFlushAt = 1 << 20;
  out.reserve(kFlushAt + 256);
  out += "t,x,v,u\n";
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
      if (!f.write(out)) break;
      out.clear();
    }
  }
  f.write(out);
  f.commit();
  error = f.error();
  return f.ok();
}

}  // namespace feedid::host
