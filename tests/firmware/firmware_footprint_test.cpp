// Host-side checks for the Cortex-M4F port (port/cortex_m/): the estimator
// stays within its RAM budget (the firmware build checks the same for the
// target's sizes), and the firmware's printf-free number formatting prints
// what printf("%.6g") would, within one unit of the last digit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "cortex_m/console.hpp"
#include "feedid/footprint_budget.hpp"
#include "feedid/feedid.hpp"

static_assert(sizeof(feedid::Estimator<float>) <= feedid::fw::estimator_float_ram_budget,
              "Estimator<float> exceeds its RAM budget (core/feedid/footprint_budget.hpp)");
static_assert(sizeof(feedid::Estimator<double>) <= feedid::fw::estimator_double_ram_budget,
              "Estimator<double> exceeds its RAM budget (core/feedid/footprint_budget.hpp)");

static_assert(sizeof(feedid::HealthTracker<float>) <= feedid::fw::health_tracker_float_ram_budget,
              "HealthTracker<float> exceeds its RAM budget (core/feedid/footprint_budget.hpp)");

namespace {

struct StringSink {
  static inline std::string text;
  static void write(const char* s) { text += s; }
};

std::string format(float x, int digits = 6) {
  StringSink::text.clear();
  feedid::fw::Console<StringSink> c;
  c.real(x, digits);
  c.flush();
  return StringSink::text;
}

}  // namespace

TEST(FirmwareFootprint, EstimatorFitsTheRamBudget) {
  // GIVEN the budget of core/feedid/footprint_budget.hpp
  // THEN the host sizes are within it (the target's are checked when the firmware compiles)
  RecordProperty("sizeof_float_estimator", static_cast<int>(sizeof(feedid::Estimator<float>)));
  RecordProperty("sizeof_double_estimator", static_cast<int>(sizeof(feedid::Estimator<double>)));
  EXPECT_LE(sizeof(feedid::Estimator<float>), feedid::fw::estimator_float_ram_budget);
  EXPECT_LE(sizeof(feedid::Estimator<double>), feedid::fw::estimator_double_ram_budget);
}

TEST(FirmwareConsole, FormatsLikePrintfG) {
  // GIVEN values of the ranges the firmware prints
  EXPECT_EQ(format(99.853f), "99.853");
  EXPECT_EQ(format(700.0f), "700");
  EXPECT_EQ(format(0.00199607f), "0.00199607");
  EXPECT_EQ(format(-0.0042f), "-0.0042");
  EXPECT_EQ(format(0.0f), "0");
  EXPECT_EQ(format(1e-7f), "1e-07");
  EXPECT_EQ(format(123456789.0f), "1.23457e+08");
  EXPECT_EQ(format(std::nanf("")), "nan");
  EXPECT_EQ(format(-INFINITY), "-inf");
  EXPECT_EQ(format(2.5f, 3), "2.5");
  // WHEN many values over 1e-12 .. 1e12 are printed
  // THEN each reads back within one unit of the 6th significant digit of %.6g
  unsigned seed = 12345;
  for (int i = 0; i < 20000; ++i) {
    seed = seed * 1103515245u + 12345u;
    const double mant = 1.0 + 9.0 * ((seed >> 8) & 0xFFFF) / 65536.0;
    const int exp10 = static_cast<int>((seed >> 24) % 25) - 12;
    const float x = static_cast<float>(((seed & 1) ? -1.0 : 1.0) * mant * std::pow(10.0, exp10));
    char ref[32];
    std::snprintf(ref, sizeof ref, "%.6g", static_cast<double>(x));
    const std::string got = format(x);
    const double a = std::strtod(got.c_str(), nullptr), b = std::strtod(ref, nullptr);
    const double unit = std::pow(10.0, std::floor(std::log10(std::fabs(b))) - 5);
    ASSERT_LE(std::fabs(a - b), 1.01 * unit) << "x = " << x << ": got " << got << ", printf " << ref;
  }
}
