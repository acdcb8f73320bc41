// WPILib DataLog (.wpilog) reader (wpilog_trace.hpp). Layout, all little
// endian: header "WPILOG", uint16 version (0x0100), uint32 length of an
// extra header string, the string; then records: one bit-field byte
// (entry id length - 1 in bits 0-1, payload size length - 1 in bits 2-3,
// time stamp length - 1 in bits 4-6), the entry id, the payload size, the
// time stamp (us), the payload. Entry id 0 is a control record: payload
// byte 0 is 0 Start (uint32 id, then name, type and metadata each as uint32
// length + UTF-8), 1 Finish (uint32 id) or 2 Set Metadata. Host only.
#include "wpilog_trace.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <stdexcept>
#include <utility>
#include <vector>

#include "column_trace.hpp"
#include "message_text.hpp"

namespace feedid::host {
namespace {

/// One entry's samples in the file: (time stamp in us, value).
struct Entry {
  std::string type;
  std::vector<std::pair<std::int64_t, double>> samples;
};

/// Bytes of the file and a cursor; every read checks the length and throws
/// naming the offset, so that a truncated file is an error, not garbage.
struct Bytes {
  std::string path;
  std::vector<unsigned char> data;
  std::size_t at = 0;
  std::uint64_t uint(std::size_t n, const char* what) {
    if (data.size() - at < n) fail(std::string("the file ends inside ") + what);
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < n; ++i) v |= std::uint64_t(data[at + i]) << (8 * i);
    at += n;
    return v;
  }
  std::string text(const char* what) {
    const std::size_t n = uint(4, what);
    if (data.size() - at < n) fail(std::string("the file ends inside ") + what);
    std::string s(data.begin() + long(at), data.begin() + long(at + n));
    at += n;
    return s;
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw std::invalid_argument(path + ": byte " + std::to_string(at) + ": " + why);
  }
};

/// A data record's payload as a number, by its entry's type; false for a type that is not numeric.
bool payload_value(const std::string& type, const unsigned char* p, std::size_t size, double& out) {
  if ((type == "double" || type == "int64") && size == 8) {
    std::uint64_t bits = 0;
    for (int i = 0; i < 8; ++i) bits |= std::uint64_t(p[i]) << (8 * i);
    if (type == "int64") out = double(static_cast<std::int64_t>(bits));
    else std::memcpy(&out, &bits, 8);
    return true;
  }
  if (type == "float" && size == 4) {
    std::uint32_t bits = 0;
    for (int i = 0; i < 4; ++i) bits |= std::uint32_t(p[i]) << (8 * i);
    float f;
    std::memcpy(&f, &bits, 4);
    out = f;
    return true;
  }
  return false;
}

bool numeric_type(const std::string& type) { return type == "double" || type == "float" || type == "int64"; }

/// A control record: Start maps the id to a (new or same-named) entry, Finish frees the id.
void control_record(Bytes& b, std::size_t end, std::map<std::uint32_t, std::string>& open, std::map<std::string, Entry>& entries) {
  const auto kind = b.uint(1, "a control record");
  if (kind == 0) {
    const auto id = std::uint32_t(b.uint(4, "a Start record"));
    const std::string name = b.text("an entry name"), type = b.text("an entry type");
    (void)b.text("entry metadata");
    open[id] = name;
    Entry& e = entries[name];
    if (!e.samples.empty() && e.type != type) b.fail("entry " + quoted_text(name) + " restarted as " + type + " after " + e.type);
    e.type = type;
  } else if (kind == 1) {
    open.erase(std::uint32_t(b.uint(4, "a Finish record")));
  }
  b.at = end;  // Set Metadata (2), and any later kind, carries nothing a trace reads
}

/// Every numeric entry's samples, by name, in time-stamp order.
std::map<std::string, Entry> read_entries(Bytes& b) {
  if (b.data.size() < 12 || std::memcmp(b.data.data(), "WPILOG", 6) != 0) b.fail("not a WPILib data log (no \"WPILOG\" header)");
  b.at = 6;
  const auto version = b.uint(2, "the header");
  if ((version >> 8) != 1) b.fail("data log version " + std::to_string(version >> 8) + "." + std::to_string(version & 0xff) + " (this reader knows 1.x)");
  (void)b.text("the extra header");
  std::map<std::uint32_t, std::string> open;
  std::map<std::string, Entry> entries;
  while (b.at < b.data.size()) {
    const std::size_t start = b.at;
    const auto bits = b.uint(1, "a record header");
    const auto id = std::uint32_t(b.uint((bits & 3) + 1, "a record's entry id"));
    const auto size = b.uint(((bits >> 2) & 3) + 1, "a record's payload size");
    const auto stamp = static_cast<std::int64_t>(b.uint(((bits >> 4) & 7) + 1, "a record's time stamp"));
    if (b.data.size() - b.at < size) b.fail("the file ends inside the record that starts at byte " + std::to_string(start));
    const std::size_t end = b.at + size;
    if (id == 0) {
      control_record(b, end, open, entries);
      continue;
    }
    const auto name = open.find(id);
    if (name == open.end()) b.fail("a record of entry id " + std::to_string(id) + ", which no Start record opened");
    Entry& e = entries[name->second];
    double v = 0.0;
    if (numeric_type(e.type) && !payload_value(e.type, &b.data[b.at], size, v))
      b.fail("a " + e.type + " record of " + quoted_text(name->second) + " with " + std::to_string(size) + " bytes");
    if (numeric_type(e.type)) e.samples.emplace_back(stamp, v);
    b.at = end;
  }
  // The format does not order records by time; interpolation needs them ordered.
  for (auto& [name, e] : entries)
    std::stable_sort(e.samples.begin(), e.samples.end(), [](const auto& a, const auto& c) { return a.first < c.first; });
  return entries;
}

/// The numeric entries' names, for an error that lists what the file has.
std::string numeric_names(const std::map<std::string, Entry>& entries) {
  std::string s;
  for (const auto& [name, e] : entries)
    if (numeric_type(e.type)) s += (s.empty() ? "" : ", ") + name + " (" + e.type + ")";
  return s.empty() ? "none" : s;
}

/// The entry `name` names; throws naming the file, the role and what it has.
const Entry& entry_named(const std::map<std::string, Entry>& entries, const std::string& name, const char* role,
                         const std::string& path) {
  const auto it = entries.find(name);
  if (it == entries.end())
    throw std::invalid_argument(path + ": no entry " + quoted_text(name) + " (the " + role +
                                "); its numeric entries: " + numeric_names(entries));
  if (!numeric_type(it->second.type))
    throw std::invalid_argument(path + ": entry " + quoted_text(name) + " (the " + role + ") is " + it->second.type +
                                ", not double, float or int64");
  if (it->second.samples.empty()) throw std::invalid_argument(path + ": entry " + quoted_text(name) + " (the " + role + ") has no records");
  return it->second;
}

/// e's value at time stamp t by linear interpolation; false outside its span.
bool value_at(const Entry& e, std::int64_t t, double& out) {
  const auto& s = e.samples;
  if (t < s.front().first || t > s.back().first) return false;
  const auto hi = std::lower_bound(s.begin(), s.end(), t, [](const auto& a, std::int64_t x) { return a.first < x; });
  if (hi->first == t || hi == s.begin()) {
    out = hi->second;
    return true;
  }
  const auto lo = hi - 1;
  const double w = double(t - lo->first) / double(hi->first - lo->first);
  out = lo->second + w * (hi->second - lo->second);
  return true;
}

}  // namespace

bool is_wpilog_file(const std::string& path) {
  const std::string ext = ".wpilog";
  if (path.size() < ext.size()) return false;
  std::string tail = path.substr(path.size() - ext.size());
  std::transform(tail.begin(), tail.end(), tail.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return tail == ext;
}

CsvResult read_trace_wpilog(const std::string& path, const CsvColumns& columns) {
  CsvResult r;
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    r.error = path + ": cannot open";
    return r;
  }
  try {
    Bytes b{path, std::vector<unsigned char>(std::istreambuf_iterator<char>(f), {}), 0};
    const std::map<std::string, Entry> entries = read_entries(b);
    const Entry& force = entry_named(entries, columns.force, "force", path);
    const bool own_base = entries.count(columns.time) > 0;
    const Entry& base = own_base ? entry_named(entries, columns.time, "time base", path) : force;
    const Entry* x = entries.count(columns.position) ? &entry_named(entries, columns.position, "position", path) : nullptr;
    const Entry* v = entries.count(columns.velocity) ? &entry_named(entries, columns.velocity, "velocity", path) : nullptr;
    if (!x && !v)
      throw std::invalid_argument(path + ": neither the position " + quoted_text(columns.position) + " nor the velocity " +
                                  quoted_text(columns.velocity) + " is an entry; its numeric entries: " + numeric_names(entries));
    if (const std::string missing = named_column_missing(columns, x != nullptr, v != nullptr); !missing.empty())
      throw std::invalid_argument(path + ": " + missing + "; its numeric entries: " + numeric_names(entries));
    TraceColumns c;
    std::size_t outside = 0;
    for (const auto& [stamp, unused] : base.samples) {
      double xu = 0, vu = 0, uu = 0;
      if (!value_at(force, stamp, uu) || (x && !value_at(*x, stamp, xu)) || (v && !value_at(*v, stamp, vu))) {
        ++outside;
        continue;
      }
      c.t.push_back(double(stamp));
      c.u.push_back(uu);
      if (x) c.x.push_back(xu);
      if (v) c.v.push_back(vu);
    }
    CsvColumns in_us = columns;
    in_us.time_scale = 1e-6;  // the format's time stamps are integer microseconds
    r = trace_from_columns(c, in_us, path, 0);
    if (r.ok) {
      r.trace.notes.push_back(path + ": rows at the time stamps of " + quoted_text(own_base ? columns.time : columns.force) +
                              ", other entries interpolated linearly" +
                              (outside ? "; " + std::to_string(outside) + " time stamps outside another entry's span left out" : ""));
    }
  } catch (const std::invalid_argument& e) {
    r = CsvResult{};
    r.error = e.what();
  }
  return r;
}

}  // namespace feedid::host
