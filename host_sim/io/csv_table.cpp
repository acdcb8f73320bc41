// The table inside a trace CSV (csv_table.hpp).
#include "csv_table.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "message_text.hpp"

namespace feedid::host::csv {
namespace {

// Roles a column can play (a column may serve several).
enum Role : unsigned {
  kTime = 1u << 0,
  kPosition = 1u << 1,
  kVelocity = 1u << 2,
  kForce = 1u << 3,
  kTemperature = 1u << 4,
  kLoad = 1u << 5,
};

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

/// Index of `name` among `names`, -1 if absent, -2 if it appears twice.
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

/// The optional covariate columns (--temperature, --load: monitor): a named
/// one must be there, once.
bool covariate_roles(const CsvColumns& columns, const std::string& at, const std::string& has, Layout& out,
                     std::string& error) {
  const std::pair<const std::string*, unsigned> named[2] = {{&columns.temperature, kTemperature}, {&columns.load, kLoad}};
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string& name = *named[k].first;
    out.has_covariate[k] = false;
    if (name.empty()) continue;
    const long i = find_column(out.names, name);
    if (i < 0) {
      error = at + (i == -2 ? "column " + quoted_text(name) + " appears more than once" : "missing column " + quoted_text(name)) +
              (k == 0 ? " (temperature)" : " (load)") + has;
      return false;
    }
    out.roles[static_cast<std::size_t>(i)] |= named[k].second;
    out.has_covariate[k] = true;
  }
  return true;
}

/// The columns `names` (a header's, or --columns; `listed` says which in
/// messages) against the wanted ones: the roles into `out`, or an error
/// naming the line, the column and what the names are. `matched`: how many
/// wanted names were found, to tell a header with a wrong name from a title.
bool layout_from_names(std::vector<std::string> names, const std::string& at, const char* listed,
                       const CsvColumns& columns, Layout& out, std::string& error, std::size_t& matched) {
  out.names = std::move(names);
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
  matched = 0;
  for (Wanted& w : wanted) {
    w.index = find_column(out.names, *w.name);
    matched += w.index != -1;
  }
  const std::string has = std::string("; ") + listed + ": " + name_list(out.names);
  for (const Wanted& w : wanted)
    if (w.index == -2) {
      error = at + "column " + quoted_text(*w.name) + " (" + w.role_name + ") appears more than once" + has;
      return false;
    }
  if (columns.rate_hz > 0 && wanted[0].index >= 0) {
    error = at + "--rate is for a log without a time column, and this one has " + quoted_text(columns.time) +
            ": give one or the other";
    return false;
  }
  out.rate_hz = columns.rate_hz;
  for (const Wanted& w : {wanted[0], wanted[3]})
    if (w.index < 0 && !(w.role == kTime && out.rate_hz > 0)) {
      error = at + "missing column " + quoted_text(*w.name) + " (" + w.role_name + ")" + has +
              (w.role == kTime ? " (a log without a time column: give its sample rate, --rate)" : "");
      return false;
    }
  if (wanted[1].index < 0 && wanted[2].index < 0) {
    error = at + "missing column " + quoted_text(columns.position) + " (position) and " + quoted_text(columns.velocity) +
            " (velocity); need at least one" + has;
    return false;
  }
  if (const std::string missing = named_column_missing(columns, wanted[1].index >= 0, wanted[2].index >= 0); !missing.empty()) {
    error = at + missing + has;
    return false;
  }
  out.time_scale = time_scale(columns);
  out.has_position = wanted[1].index >= 0;
  out.has_velocity = wanted[2].index >= 0;
  out.roles.assign(out.names.size(), 0u);
  for (const Wanted& w : wanted)
    if (w.index >= 0) out.roles[static_cast<std::size_t>(w.index)] |= w.role;
  return covariate_roles(columns, at, has, out, error);
}

std::vector<std::string> trimmed_names(const Fields& fields) {
  std::vector<std::string> names;
  for (const auto& f : fields) names.emplace_back(trim_field(f.first, f.second));
  return names;
}

enum class Number { ok, empty, not_number, out_of_range, not_finite };

/// The (trimmed) field as a number, every byte of it; with decimal_comma a
/// ',' is the decimal point (a `;` or tab file from a German or French
/// locale). `text` lies in a NUL-terminated buffer and ends at a separator,
/// a line end or a quote, so strtod stops inside the line.
Number read_number(std::string_view text, bool decimal_comma, double& value) {
  if (text.empty()) return Number::empty;
  char local[64];
  std::string longer;
  const char* p = text.data();
  if (decimal_comma && text.find(',') != std::string_view::npos) {
    char* copy = local;
    if (text.size() >= sizeof local) {
      longer.assign(text);
      copy = longer.data();
    } else {
      text.copy(local, text.size());
      local[text.size()] = '\0';
    }
    for (std::size_t i = 0; i < text.size(); ++i)
      if (copy[i] == ',') copy[i] = '.';
    p = copy;
  }
  // The common case, a plain decimal number, by from_chars (correctly
  // rounded, as strtod is, so the value is the same bit for bit): strtod
  // was a fifth of identify's command on a 2 kHz CSV. What from_chars does
  // not take whole (a leading '+' or space, hex, inf, nan, a value beyond
  // range) goes to strtod, whose rules and messages stay the reader's.
  if (const auto [ptr, ec] = std::from_chars(p, p + text.size(), value);
      ec == std::errc() && ptr == p + text.size() && std::isfinite(value))
    return Number::ok;
  char* end = nullptr;
  errno = 0;
  value = std::strtod(p, &end);
  if (end != p + text.size()) return Number::not_number;
  if (!std::isfinite(value)) return errno == ERANGE ? Number::out_of_range : Number::not_finite;
  return Number::ok;
}

/// First stamps from this value on (in the column's unit) are read from an
/// origin: below it a double keeps the stamps' digits to 1e-10 of a unit.
constexpr double kTimeOriginFrom = 1e6;

/// Where `text`'s fraction starts ('.', or ',' in a decimal-comma file, as
/// read_number takes either), or its size where it has none.
std::size_t decimal_point_at(std::string_view text, bool decimal_comma) {
  return std::min({text.find('.'), decimal_comma ? text.find(',') : std::string_view::npos, text.size()});
}

/// A stamp's whole part has at most 19 digits (int64); its fraction is
/// kept to 200 digits, which no double of a stamp under 1e19 can hold.
constexpr std::size_t kWholeDigits = 19, kFractionDigits = 200;

/// The integer part of `text` when it is a plain decimal number ("+" at most
/// before it, digits and one point; no exponent), else -1.
std::int64_t whole_part(std::string_view text, bool decimal_comma) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  const std::size_t point = decimal_point_at(text, decimal_comma);
  if (point == 0) return -1;
  for (std::size_t i = 0; i < text.size(); ++i)
    if (i != point && !(text[i] >= '0' && text[i] <= '9')) return -1;
  std::int64_t w = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + point, w);
  return ec == std::errc() && end == text.data() + point ? w : -1;
}

/// `text` less `origin`, rounded once: the whole part's difference written
/// before the stamp's own fraction and read as one number, so that
/// "1700000012.001" from 1700000000 is the double of "12.001" bit for bit.
/// Other forms, and stamps before the origin, are read whole and then
/// shifted (a stamp before the first row is out of order anyway). Digits
/// past kFractionDigits after the point are dropped.
Number read_since_origin(std::string_view text, bool decimal_comma, std::int64_t origin, double& value) {
  const std::int64_t w = whole_part(text, decimal_comma);
  if (w < origin) {
    const Number n = read_number(text, decimal_comma, value);
    value -= static_cast<double>(origin);
    return n;
  }
  const std::size_t point = decimal_point_at(text, decimal_comma);
  const std::size_t fraction = std::min(text.size() - point, kFractionDigits + 1);  // the point and its digits
  char buf[kWholeDigits + kFractionDigits + 2];  // NUL-terminated, as read_number's text lies
  char* end = std::to_chars(buf, buf + kWholeDigits, w - origin).ptr;
  text.copy(end, fraction, point);
  if (fraction > 0) *end = '.';
  end[fraction] = '\0';
  return read_number(std::string_view(buf, static_cast<std::size_t>(end - buf) + fraction), false, value);
}

/// A number (finite or not) or an ISO 8601 stamp: a value a data row holds.
bool is_value(std::string_view text, char sep) {
  double v = 0.0;
  IsoTime t;
  const Number n = read_number(text, sep != ',', v);
  return n == Number::ok || n == Number::out_of_range || n == Number::not_finite || parse_iso8601(text, sep != ',', t);
}

/// The number of fields of a data row: two or more values split at tab, `;`
/// or `,` (tried in this order: a `;` row may hold decimal commas); 0 when
/// the line is not one.
std::size_t value_fields(const char* b, const char* e, Fields& fields) {
  for (const char sep : {'\t', ';', ','}) {
    if (std::memchr(b, sep, static_cast<std::size_t>(e - b)) == nullptr) continue;
    split(b, e, sep, fields);
    bool all = fields.size() >= 2;
    for (std::size_t i = 0; all && i < fields.size(); ++i) all = is_value(trim_field(fields[i].first, fields[i].second), sep);
    if (all) return fields.size();
  }
  return 0;
}

/// A comment line: `#`, `%` or `//` first (after whitespace).
bool is_comment(const char* b, const char* e) {
  while (b < e && is_space(*b)) ++b;
  return b < e && (*b == '#' || *b == '%' || (*b == '/' && e - b >= 2 && b[1] == '/'));
}

}  // namespace

void split(const char* b, const char* e, char sep, Fields& fields) {
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

bool is_blank(const char* b, const char* e, char sep) {
  for (; b < e; ++b) {
    if (*b == sep || !is_space(*b)) return false;
  }
  return true;
}

const char* after_bom(const char* b, const char* e) {
  return e - b >= 3 && static_cast<unsigned char>(b[0]) == 0xEF && static_cast<unsigned char>(b[1]) == 0xBB &&
                 static_cast<unsigned char>(b[2]) == 0xBF
             ? b + 3
             : b;
}

TableSearch::TableSearch(const CsvColumns& columns, const RowRules& rules, std::string source)
    : columns_(columns), rules_(rules), source_(std::move(source)) {
  if (columns.names_by_position.empty()) return;
  std::size_t matched = 0;
  if (!layout_from_names(columns.names_by_position, source_ + ": ", "--columns names", columns, layout_, error_, matched))
    error_ = source_ + ": --columns: " + error_.substr(source_.size() + 2);
}

void TableSearch::before_table(const char* b, const char* e, std::size_t line) {
  if (layout_.lines_before++ > 0) return;
  layout_.first_before_line = line;
  layout_.first_before.assign(trim_field(b, e));
}

TableSearch::Step TableSearch::feed(const char* b, const char* e, std::size_t line) {
  if (!error_.empty()) return Step::error;
  if (!columns_.names_by_position.empty()) return feed_named(b, e, line);
  if (is_comment(b, e)) {
    before_table(b, e, line);
    return Step::more;
  }
  if (const std::size_t n = value_fields(b, e, fields_)) return no_header_at_data(line, n);
  for (const char sep : {',', ';', '\t'}) {
    split(b, e, sep, fields_);
    Layout found;
    found.sep = sep;
    std::string why;
    std::size_t matched = 0;
    if (layout_from_names(trimmed_names(fields_), rules_.at(line), "header has", columns_, found, why, matched)) {
      found.lines_before = layout_.lines_before;
      found.first_before_line = layout_.first_before_line;
      found.first_before = std::move(layout_.first_before);
      found.table_line = line;
      layout_ = std::move(found);
      return Step::header;
    }
    // Kept: the line with the most wanted names, or with none anywhere the
    // one with the most fields (a header of other names, not a title).
    if (!any_candidate_ || matched > best_matched_ ||
        (matched == 0 && best_matched_ == 0 && fields_.size() > best_fields_)) {
      best_matched_ = matched;
      best_fields_ = fields_.size();
      best_error_ = std::move(why);
      any_candidate_ = true;
    }
  }
  before_table(b, e, line);
  return Step::more;
}

TableSearch::Step TableSearch::no_header_at_data(std::size_t line, std::size_t fields) {
  const std::string hint = "name the columns by position with --columns (one name per field, e.g. --columns " +
                           columns_.time + "," + columns_.position + "," + columns_.force + ")";
  if (best_matched_ > 0)
    error_ = best_error_;
  else if (!any_candidate_ || best_fields_ < fields)
    error_ = rules_.at(line) + "no header row names the columns (line " + std::to_string(line) + " is data, " +
             std::to_string(fields) + " fields): " + hint;
  else
    error_ = best_error_ + "; if the file has no header row, " + hint;
  return Step::error;
}

TableSearch::Step TableSearch::feed_named(const char* b, const char* e, std::size_t line) {
  if (is_comment(b, e)) {
    before_table(b, e, line);
    return Step::more;
  }
  const std::size_t want = layout_.names.size();
  for (const char sep : {'\t', ';', ','}) {
    split(b, e, sep, fields_);
    if (fields_.size() != want) continue;
    bool values = true;
    for (std::size_t i = 0; values && i < want; ++i)
      values = layout_.roles[i] == 0u || is_value(trim_field(fields_[i].first, fields_[i].second), sep);
    if (!values) continue;
    layout_.sep = sep;
    layout_.table_line = line;
    return Step::data;
  }
  if (const std::size_t n = value_fields(b, e, fields_)) {
    error_ = rules_.at(line) + "a data row of " + std::to_string(n) + " fields, and --columns names " +
             std::to_string(want) + " (" + name_list(layout_.names) + "): give one name per field, empty for a column not read";
    return Step::error;
  }
  before_table(b, e, line);
  return Step::more;
}

std::string TableSearch::end_error() const {
  if (!error_.empty()) return error_;
  if (!columns_.names_by_position.empty())
    return source_ + ": no data rows" +
           (layout_.lines_before > 0 ? " (no line of " + std::to_string(layout_.names.size()) +
                                           " fields whose named columns are values, as --columns says)"
                                     : "");
  if (any_candidate_) return best_error_;
  return source_ + (layout_.lines_before > 0 ? ": no header row (only comment lines)" : ": empty file (no header row)");
}

void decide_time_format(Layout& lay, std::string_view text) {
  double value = 0.0;
  if (lay.time_format_decided || lay.rate_hz > 0) return;
  if (parse_iso8601(text, lay.sep != ',', lay.epoch)) {
    lay.time_format_decided = lay.iso_time = lay.have_epoch = true;
    lay.epoch_text.assign(text);
  } else if (read_number(text, lay.sep != ',', value) == Number::ok) {
    lay.time_format_decided = true;
    const std::int64_t w = whole_part(text, lay.sep != ',');
    if (static_cast<double>(w) >= kTimeOriginFrom) lay.time_origin = w;
  }
}

void detect_time_format(Layout& lay, const char* b, const char* e) {
  Fields fields;
  split(b, e, lay.sep, fields);
  for (std::size_t i = 0; i < fields.size() && i < lay.roles.size(); ++i)
    if (lay.roles[i] & kTime) decide_time_format(lay, trim_field(fields[i].first, fields[i].second));
}

void note_time_format(Layout& lay, const CsvColumns& columns, const std::string& source, std::vector<std::string>& notes) {
  if (lay.time_format_noted) return;
  if (lay.iso_time) {
    lay.time_format_noted = true;
    notes.push_back(source + ": time column " + quoted_text(columns.time) +
                    " read as ISO 8601 time stamps, in seconds since the first row's " + quoted_text(lay.epoch_text) +
                    (columns.time_scale > 0 ? " (--time-scale does not apply)" : ""));
    return;
  }
  if (lay.time_origin == 0) return;
  lay.time_format_noted = true;
  const double first = static_cast<double>(lay.time_origin);
  char kept[32];
  std::snprintf(kept, sizeof kept, "%.2g s", 0.5 * (std::nextafter(first, 2 * first) - first) * lay.time_scale);
  notes.push_back(source + ": time column " + quoted_text(columns.time) + " counted from " + std::to_string(lay.time_origin) +
                  " (its first stamp's whole part, in the column's unit), so that the stamps keep their digits (a double of a whole stamp keeps them to " +
                  kept + "); the times reported count from there, and the JSON's time_origin_s (per run where pooled) states it");
}

std::vector<std::string> layout_notes(const Layout& lay, const CsvColumns& columns, const std::string& source) {
  std::vector<std::string> notes;
  if (lay.lines_before > 0)
    notes.push_back(source + ": " + std::to_string(lay.lines_before) + " line" + (lay.lines_before == 1 ? "" : "s") +
                    " before the " + (columns.names_by_position.empty() ? "header" : "first data row") + " (line " +
                    std::to_string(lay.table_line) + ") left out as comments or metadata; the first, line " +
                    std::to_string(lay.first_before_line) + ": " + quoted_text(lay.first_before));
  return notes;
}

RowRead read_row(const char* lb, const char* le, std::size_t line, std::string_view prev_row, Layout& lay,
                 const CsvColumns& columns, RowRules& rules, Fields& fields, TraceSample& s) {
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
    double value = 0.0;
    std::string why;
    IsoTime stamp;
    if (r & kTime) decide_time_format(lay, text);  // the first stamp that reads, where the first row's did not
    const bool iso = (r & kTime) && lay.iso_time;  // in seconds whatever the column's name says
    if (iso) {
      if (!parse_iso8601(text, lay.sep != ',', stamp))
        why = ": " + quoted_text(text) + " is not an ISO 8601 time stamp like the first row's";
      else
        value = seconds_between(lay.epoch, stamp);
    } else {
      const bool from_origin = (r & kTime) && lay.time_origin != 0;
      switch (from_origin ? read_since_origin(text, lay.sep != ',', lay.time_origin, value)
                          : read_number(text, lay.sep != ',', value)) {
        case Number::ok: break;
        case Number::empty: why = ": empty value"; break;
        case Number::not_number: why = ": " + quoted_text(text) + " is not a number"; break;
        case Number::out_of_range: why = ": " + quoted_text(text) + " is out of range for a double"; break;
        case Number::not_finite: why = ": value is NaN/Inf"; break;
      }
    }
    if (!why.empty())
      return rules.bad(rules.at(line) + "column " + quoted_text(lay.names[i]) + why) ? RowRead::skipped : RowRead::stop;
    if (r & kTime) {
      s.t_s = iso ? value : value * lay.time_scale;
      time_text = text;
    }
    if (r & kPosition) s.x_m = value * position_scale(columns);
    if (r & kVelocity) s.v_m_s = value * position_scale(columns);
    if (r & kForce) s.u_N = value * columns.force_scale;
    if (r & kTemperature) lay.covariate[0] = value;
    if (r & kLoad) lay.covariate[1] = value;
  }
  switch (rules.take(s, time_text, line)) {
    case RowRules::Taken::kept: return RowRead::kept;
    case RowRules::Taken::skipped: return RowRead::skipped;
    case RowRules::Taken::stop: break;
  }
  return RowRead::stop;
}

}  // namespace feedid::host::csv
