// Reading and writing traces as CSV. Host only.
#include "csv_trace.hpp"
#include "output_file.hpp"

#include <algorithm>
#include <array>
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

#include "csv_table.hpp"
#include "message_text.hpp"
#include "trace_rows.hpp"

namespace feedid::host {
namespace {

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
struct NamedUnit {
  std::string_view suffix;
  double si;  ///< SI units (s, m or rad) per unit
};
// Longer suffixes first: "min" before a bare "n", "ms" before "s".
constexpr NamedUnit kTimeUnits[] = {{"min", 60.0}, {"ms", 1e-3}, {"us", 1e-6}, {"\xC2\xB5s", 1e-6}, {"\xCE\xBCs", 1e-6},
                                    {"ns", 1e-9}, {"h", 3600.0}, {"s", 1.0}};
constexpr NamedUnit kPositionUnits[] = {{"mm", 1e-3}, {"cm", 1e-2}, {"um", 1e-6}, {"\xC2\xB5m", 1e-6}, {"\xCE\xBCm", 1e-6},
                                        {"nm", 1e-9}, {"deg", M_PI / 180.0}, {"rad", 1.0}, {"m", 1.0}};

/// The unit of `table` ending a column's name, after a non-letter or alone; null if none.
template <std::size_t N>
const NamedUnit* unit_ending(std::string_view name, const NamedUnit (&table)[N]) {
  while (!name.empty() && (name.back() == ']' || name.back() == ')' || name.back() == ' ')) name.remove_suffix(1);
  for (const NamedUnit& u : table) {
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

std::string named_column_missing(const CsvColumns& c, bool has_position, bool has_velocity) {
  const CsvColumns defaults;
  if (!c.named_columns_required) return "";
  if (!has_position && !c.position.empty() && c.position != defaults.position)
    return "missing column " + quoted_text(c.position) + " (position, as named by --position)";
  if (!has_velocity && !c.velocity.empty() && c.velocity != defaults.velocity)
    return "missing column " + quoted_text(c.velocity) + " (velocity, as named by --velocity)";
  return "";
}

double time_unit_from_name(std::string_view name) {
  const NamedUnit* u = unit_ending(name, kTimeUnits);
  return u ? u->si : 1.0;
}

double position_unit_from_name(std::string_view name) {
  const NamedUnit* u = unit_ending(name, kPositionUnits);
  return u ? u->si : 1.0;
}

bool time_unit_stated(const CsvColumns& c) {
  return c.rate_hz > 0 || c.time_scale > 0 || (unit_ending(c.time, kTimeUnits) && c.time != "s");
}

namespace {
/// The line after the cursor's that is not blank, without moving it: the
/// first data row, whose time field says whether the time is ISO 8601.
void detect_from_next_row(LineCursor cursor, csv::Layout& lay) {
  const char* b = nullptr;
  const char* e = nullptr;
  while (cursor.next(b, e))
    if (!csv::is_blank(b, e, lay.sep)) return csv::detect_time_format(lay, b, e);
}
}  // namespace

CsvResult parse_trace_csv(const std::string& buf, const std::string& path, const CsvColumns& columns) {
  CsvResult result;
  result.trace.source = path;
  result.trace.has_position = false;
  result.trace.has_velocity = false;
  result.error = scale_error(columns);
  if (!result.error.empty()) return result;
  LineCursor cursor{csv::after_bom(buf.data(), buf.data() + buf.size()), buf.data() + buf.size()};
  RowRules rules(columns, result.trace, path + ":", "line");
  csv::TableSearch search(columns, rules, path);

  const char* b = nullptr;
  const char* e = nullptr;
  csv::TableSearch::Step step = csv::TableSearch::Step::more;
  while (step == csv::TableSearch::Step::more && cursor.next(b, e)) {
    if (static_cast<std::size_t>(e - b) > kMaxLineBytes) {
      result.error = too_long_line(path, cursor.line);
      return result;
    }
    if (!csv::is_blank(b, e, '\0')) step = search.feed(b, e, cursor.line);
  }
  if (step == csv::TableSearch::Step::more || step == csv::TableSearch::Step::error) {
    result.error = step == csv::TableSearch::Step::more ? search.end_error() : search.error();
    return result;
  }
  csv::Layout& lay = search.layout();
  const bool first_row_here = step == csv::TableSearch::Step::data;  // --columns: this line is data
  if (first_row_here) csv::detect_time_format(lay, b, e);
  else detect_from_next_row(cursor, lay);
  result.trace.has_position = lay.has_position;
  result.trace.has_velocity = lay.has_velocity;
  result.trace.notes = csv::layout_notes(lay, columns, path);
  csv::note_time_format(lay, columns, path, result.trace.notes);

  std::vector<TraceSample>& samples = result.trace.samples;
  samples.reserve(static_cast<std::size_t>(std::count(cursor.p, cursor.end, '\n')) + 1);
  csv::Fields fields;
  std::string_view prev_row;
  TraceSample s;
  for (bool have = first_row_here || cursor.next(b, e); have; have = cursor.next(b, e)) {
    if (static_cast<std::size_t>(e - b) > kMaxLineBytes) {
      result.error = too_long_line(path, cursor.line);
      result.trace.samples.clear();
      return result;
    }
    if (csv::is_blank(b, e, lay.sep)) continue;
    const csv::RowRead r = csv::read_row(b, e, cursor.line, prev_row, lay, columns, rules, fields, s);
    csv::note_time_format(lay, columns, path, result.trace.notes);
    if (r == csv::RowRead::stop) {
      result.error = rules.error();
      return result;
    }
    if (r == csv::RowRead::kept) prev_row = std::string_view(b, static_cast<std::size_t>(e - b));
  }
  if (!rules.finish(path)) {
    result.error = rules.error();
    return result;
  }
  result.trace.time_origin_s = csv::time_origin_s(lay);
  result.trace.time_unit_stated = time_unit_stated(columns) || lay.iso_time;
  result.ok = true;
  return result;
}

struct CsvStream::Impl {
  std::ifstream file;
  CsvColumns columns;
  Trace counts;  ///< RowRules' counters, skipped rows, notes; samples: the row confirmed and not yet handed on (whole: all)
  RowRules rules;
  csv::Layout layout;
  std::vector<char> buf = std::vector<char>(kMaxLineBytes + 2);  ///< one line, NUL-terminated: the stream's bound
  std::string_view line;
  bool pending = false;  ///< `line` is the first data row, read before next() (its time said whether it is ISO 8601)
  bool whole = false;    ///< a trace read whole (a .mat): counts.samples are handed on from `index`
  bool unit_stated = false;
  std::string prev_row;
  std::size_t line_no = 0, index = 0;
  bool finished = false;  ///< the end of the file was met and the last row flushed
  /// Temperature and load of the row RowRules holds, and of the row handed
  /// on last: the stream is a row behind the file.
  std::array<double, 2> held_covariates{}, covariates{};
  csv::Fields fields;
  Impl(const std::string& path, const CsvColumns& c, bool open)
      : columns(c), rules(columns, counts, path + ":", "line") {
    if (open) file.open(path, std::ios::binary);
  }

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
    if (line_no == 1) line.remove_prefix(static_cast<std::size_t>(csv::after_bom(line.data(), line.data() + size) - line.data()));
    return Line::read;
  }
  /// The first non-blank line after the header, held for next(): the
  /// whole-file reader looks at the same row. False: a line too long.
  bool hold_first_row() {
    for (Line got; (got = next_line()) != Line::end;) {
      if (got == Line::too_long) return false;
      if (csv::is_blank(line.data(), line.data() + line.size(), layout.sep)) continue;
      pending = true;
      return true;
    }
    return true;
  }
};

CsvStream::CsvStream(const std::string& path, const CsvColumns& columns)
    : impl_(std::make_unique<Impl>(path, columns, true)) {
  Impl& m = *impl_;
  source_ = path;
  error_ = scale_error(columns);
  if (!error_.empty()) return;
  if (!m.file) {
    error_ = path + ": cannot open: " + errno_text(errno);
    return;
  }
  csv::TableSearch search(m.columns, m.rules, path);
  csv::TableSearch::Step step = csv::TableSearch::Step::more;
  for (Impl::Line got; step == csv::TableSearch::Step::more && (got = m.next_line()) != Impl::Line::end;) {
    if (got == Impl::Line::too_long) {
      error_ = too_long_line(path, m.line_no + 1);
      return;
    }
    const char* b = m.line.data();
    if (!csv::is_blank(b, b + m.line.size(), '\0')) step = search.feed(b, b + m.line.size(), m.line_no);
  }
  if (step == csv::TableSearch::Step::more || step == csv::TableSearch::Step::error) {
    error_ = step == csv::TableSearch::Step::more ? search.end_error() : search.error();
    return;
  }
  m.layout = std::move(search.layout());
  m.pending = step == csv::TableSearch::Step::data;  // --columns: this line is the first row
  if (!m.pending && !m.hold_first_row()) {
    error_ = too_long_line(path, m.line_no + 1);
    return;
  }
  if (m.pending) csv::detect_time_format(m.layout, m.line.data(), m.line.data() + m.line.size());
  m.unit_stated = feedid::host::time_unit_stated(columns);
  m.counts.notes = csv::layout_notes(m.layout, columns, path);
  csv::note_time_format(m.layout, columns, path, m.counts.notes);
  has_position_ = m.layout.has_position;
  has_velocity_ = m.layout.has_velocity;
  ok_ = true;
}

CsvStream::CsvStream(CsvResult read) : impl_(std::make_unique<Impl>(read.trace.source, CsvColumns{}, false)) {
  Impl& m = *impl_;
  source_ = read.trace.source;
  error_ = read.error;
  ok_ = read.ok;
  has_position_ = read.trace.has_position;
  has_velocity_ = read.trace.has_velocity;
  m.whole = true;
  m.unit_stated = read.trace.time_unit_stated;
  m.counts = std::move(read.trace);
}

CsvStream::CsvStream(CsvStream&&) noexcept = default;
CsvStream::~CsvStream() = default;

bool CsvStream::time_unit_stated() const { return impl_->unit_stated || (!impl_->whole && impl_->layout.iso_time); }
bool CsvStream::has_temperature() const { return impl_->layout.has_covariate[0]; }
bool CsvStream::has_load() const { return impl_->layout.has_covariate[1]; }
double CsvStream::temperature() const { return impl_->covariates[0]; }
double CsvStream::load() const { return impl_->covariates[1]; }
const std::vector<std::string>& CsvStream::notes() const { return impl_->counts.notes; }
double CsvStream::time_origin_s() const { return impl_->whole ? impl_->counts.time_origin_s : csv::time_origin_s(impl_->layout); }

bool CsvStream::next(TraceSample& s) {
  if (!ok_) return false;
  Impl& m = *impl_;
  if (m.whole) {
    ok_ = m.index < m.counts.samples.size();
    if (ok_) s = m.counts.samples[m.index++];
    return ok_;
  }
  for (;;) {
    // RowRules appends a row once the next one confirms its time (or at
    // the end): the stream hands it on from there, one row behind the file.
    if (!m.counts.samples.empty()) {
      s = m.counts.samples.front();
      m.counts.samples.clear();
      m.covariates = m.held_covariates;
      m.held_covariates = m.layout.covariate;  // the row held now (none after the end)
      return true;
    }
    if (m.finished) {
      // Too many bad rows, or none kept, is an error, in the whole-file reader's words.
      if (!m.rules.finish(source_)) error_ = m.rules.error();
      break;
    }
    if (m.pending) {
      m.pending = false;
    } else {
      const Impl::Line got = m.next_line();
      if (got == Impl::Line::end) {
        m.finished = true;
        m.rules.flush();  // the last row, handed on before the whole is judged
        continue;
      }
      if (got == Impl::Line::too_long) {
        error_ = too_long_line(source_, m.line_no + 1);
        break;
      }
    }
    const char* b = m.line.data();
    const char* e = b + m.line.size();
    if (csv::is_blank(b, e, m.layout.sep)) continue;
    const csv::RowRead r = csv::read_row(b, e, m.line_no, m.prev_row, m.layout, m.columns, m.rules, m.fields, s);
    csv::note_time_format(m.layout, m.columns, source_, m.counts.notes);
    if (r == csv::RowRead::stop) {
      error_ = m.rules.error();
      break;
    }
    if (r != csv::RowRead::kept) continue;
    m.prev_row.assign(b, e);  // reuses its capacity
    // The first row held, or a row held in place of one out of order: its covariates wait with it.
    if (m.counts.samples.empty()) m.held_covariates = m.layout.covariate;
  }
  ok_ = false;
  return false;
}

std::size_t CsvStream::rows_skipped() const { return impl_->counts.rows_skipped; }
std::size_t CsvStream::rows_repeated() const { return impl_->counts.rows_repeated; }
const std::vector<std::string>& CsvStream::skipped_rows() const { return impl_->counts.skipped_rows; }

bool write_trace_csv(const std::string& path, const Trace& trace, std::string& error, const ExtraColumn* extra) {
  OutputFile f(path);
  // Format into a buffer and write it in large blocks. std::to_chars with
  // general format and precision 17 gives the same text as printf("%.17g")
  // in the C locale, which round-trips every double exactly.
  std::string out;
  constexpr std::size_t kFlushAt = 1 << 20;
  out.reserve(kFlushAt + 256);
  out += extra ? "t,x,v,u," + extra->name + "\n" : "t,x,v,u\n";
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
    put(s.u_N, extra ? ',' : '\n');
    if (extra) put(extra->of_time(s.t_s), '\n');
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
