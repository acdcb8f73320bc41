// Text output for the firmware example without printf (which would link
// newlib's stdio, malloc and _sbrk): integers and floats formatted into a
// fixed line buffer, handed line by line to a Sink (`static void
// write(const char*)`: semihosting on target, a string in the host test
// tests/firmware/firmware_footprint_test.cpp). Float formatting works in
// float only (no soft double): the value is scaled into [1, 10) by one
// division or multiplication with an exact power of ten and rounded to the
// requested significant digits, so the last printed digit is within one unit
// of the correctly rounded one. Context: task.
#pragma once

#include <stdint.h>

#include "feedid_port/math.hpp"

namespace feedid::fw {

template <typename Sink> class Console {
 public:
  Console& operator<<(const char* s) {
    while (*s) put(*s++);
    return *this;
  }
  Console& operator<<(char c) {
    put(c);
    return *this;
  }
  Console& operator<<(uint32_t v) { return unsigned_(v); }
  Console& operator<<(int v) {
    if (v < 0) {
      put('-');
      return unsigned_(static_cast<uint64_t>(-static_cast<int64_t>(v)));
    }
    return unsigned_(static_cast<uint64_t>(v));
  }
  Console& operator<<(uint64_t v) { return unsigned_(v); }
  /// %.6g-like: fixed notation for 1e-4 <= |x| < 1e6, else d.ddddde+XX.
  Console& operator<<(float x) { return real(x, 6); }

  /// A float with `digits` significant digits (1..8).
  Console& real(float x, int digits) {
    if (port::is_nan(x)) return *this << "nan";
    if (x < 0.0f) { put('-'); x = -x; }
    if (!port::is_finite(x)) return *this << "inf";
    if (x == 0.0f) return *this << "0";
    digits = digits < 1 ? 1 : (digits > 8 ? 8 : digits);
    // Decimal exponent e with 10^e <= x < 10^(e+1), then the mantissa as
    // an integer of `digits` digits.
    int e = 0;
    float probe = x;
    while (probe >= 10.0f) { probe *= 0.1f; ++e; }
    while (probe < 1.0f) { probe *= 10.0f; --e; }
    uint32_t m = mantissa(x, e, digits);
    if (m >= pow10u(digits)) { ++e; m = mantissa(x, e, digits); }  // rounded up to 10.000
    if (m < pow10u(digits - 1)) { --e; m = mantissa(x, e, digits); }
    char d[10];
    for (int i = digits - 1; i >= 0; --i) { d[i] = static_cast<char>('0' + m % 10u); m /= 10u; }
    if (e >= -4 && e < 6) {
      // Fixed: digits before the point, then the rest; trailing zeros dropped.
      int last = digits - 1;
      while (last > 0 && last > e && d[last] == '0') --last;
      if (e < 0) {
        put('0'); put('.');
        for (int i = 0; i < -e - 1; ++i) put('0');
        for (int i = 0; i <= last; ++i) put(d[i]);
      } else {
        for (int i = 0; i <= e; ++i) put(i < digits ? d[i] : '0');
        if (last > e) { put('.'); for (int i = e + 1; i <= last; ++i) put(d[i]); }
      }
    } else {
      put(d[0]);
      int last = digits - 1;
      while (last > 0 && d[last] == '0') --last;
      if (last > 0) { put('.'); for (int i = 1; i <= last; ++i) put(d[i]); }
      put('e'); put(e < 0 ? '-' : '+');
      const int a = e < 0 ? -e : e;
      put(static_cast<char>('0' + a / 10)); put(static_cast<char>('0' + a % 10));
    }
    return *this;
  }

  /// Writes what is buffered (a line is flushed at '\n' anyway).
  void flush() {
    if (len_ == 0) return;
    buf_[len_] = '\0';
    Sink::write(buf_);
    len_ = 0;
  }

 private:
  static uint32_t pow10u(int n) {
    uint32_t p = 1;
    for (int i = 0; i < n; ++i) p *= 10u;
    return p;
  }
  /// 10^n as a float, exact for 0 <= n <= 10.
  static float pow10f(int n) {
    float p = 1.0f;
    for (int i = 0; i < n; ++i) p *= 10.0f;
    return p;
  }
  /// round(x * 10^(digits-1-e)) with at most two roundings (|e| <= 38).
  static uint32_t mantissa(float x, int e, int digits) {
    int k = digits - 1 - e;  // scale by 10^k
    float y = x;
    while (k > 10) { y *= 1e10f; k -= 10; }
    while (k < -10) { y /= 1e10f; k += 10; }
    y = k >= 0 ? y * pow10f(k) : y / pow10f(-k);
    return static_cast<uint32_t>(y + 0.5f);
  }
  Console& unsigned_(uint64_t v) {
    char d[20];
    int n = 0;
    do { d[n++] = static_cast<char>('0' + v % 10u); v /= 10u; } while (v != 0);
    while (n > 0) put(d[--n]);
    return *this;
  }
  void put(char c) {
    buf_[len_++] = c;
    if (c == '\n' || len_ + 1 >= sizeof buf_) flush();
  }

  char buf_[160] = {};
  uint32_t len_ = 0;
};

}  // namespace feedid::fw
