// Text from an input inside a message: printable and bounded, whatever the
// input holds (binary junk, escape sequences, a 1 GiB line). Every reader
// quotes file content through these, and the fuzz target checks the bounds
// (tests/fuzz/fuzz_csv.cpp). Host only.
#pragma once
#include <cstddef>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

namespace feedid::host {

/// Bytes of input text a message quotes at most; the rest is counted.
constexpr std::size_t kQuotedBytes = 64;
/// Header names a message lists at most.
constexpr std::size_t kListedNames = 12;
/// Longest line a trace CSV may have: a row is a few dozen bytes, a header
/// of hundreds of columns a few kilobytes. A longer line is no trace (a
/// binary file, /dev/zero) and is refused before it fills memory.
constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;
/// Bound on any message about an input (bytes): a path, a few quoted
/// fields and up to five skipped rows.
constexpr std::size_t kMaxMessageBytes = 4096;

/// `s` with bytes outside printable ASCII as \xNN, cut after max_bytes of
/// input with the length said: never raw binary, never unbounded.
inline std::string printable(std::string_view s, std::size_t max_bytes = kQuotedBytes) {
  std::string r;
  const std::size_t shown = s.size() < max_bytes ? s.size() : max_bytes;
  r.reserve(shown + 24);
  for (std::size_t i = 0; i < shown; ++i) {
    const auto b = static_cast<unsigned char>(s[i]);
    if (b >= 0x20 && b < 0x7f) {
      r += static_cast<char>(b);
    } else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02X", b);
      r += hex;
    }
  }
  if (shown < s.size()) r += "... (" + std::to_string(s.size()) + " bytes)";
  return r;
}

/// printable(s) in single quotes (not std::quoted, which escapes nothing).
inline std::string quoted_text(std::string_view s) { return '\'' + printable(s) + '\''; }

/// The names, quoted and comma-separated, at most kListedNames of them.
inline std::string name_list(const std::vector<std::string>& names) {
  std::string s;
  for (std::size_t i = 0; i < names.size() && i < kListedNames; ++i) s += (i ? ", " : "") + quoted_text(names[i]);
  if (names.size() > kListedNames) s += " and " + std::to_string(names.size() - kListedNames) + " more";
  return s;
}

/// What every message about an input must be: printable ASCII within
/// kMaxMessageBytes (checked by the fuzz target and the reader tests).
inline bool is_bounded_printable(std::string_view message) {
  if (message.size() > kMaxMessageBytes) return false;
  for (const char c : message)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) return false;
  return true;
}

}  // namespace feedid::host
