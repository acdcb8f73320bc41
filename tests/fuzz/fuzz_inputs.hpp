// What the core's fuzz targets share: the invariant check, the status
// check, and inputs near a plausible value or anything at all.
#pragma once
#include <fuzzer/FuzzedDataProvider.h>

#include <cstdint>
#include <cstdlib>

#include "feedid/feedid.hpp"

namespace {

void require(bool ok) {
  if (!ok) std::abort();  // libFuzzer records the input that broke an invariant
}

bool named(feedid::Status s) { return static_cast<uint8_t>(s) <= static_cast<uint8_t>(feedid::Status::numerical_error); }

template <typename T> T any(FuzzedDataProvider& in) { return static_cast<T>(in.ConsumeFloatingPoint<double>()); }

/// A value near a plausible one most of the time, anything at all otherwise.
template <typename T> T near(FuzzedDataProvider& in, double typical) {
  return in.ConsumeBool() ? any<T>(in) : static_cast<T>(typical * in.ConsumeFloatingPointInRange<double>(-2.0, 2.0));
}

template <typename T> feedid::Config<T> config(FuzzedDataProvider& in) {
  feedid::Config<T> c;
  if (!in.ConsumeBool()) return c;
  c.velocity_min_m_s = near<T>(in, 1e-4);
  c.velocity_max_m_s = near<T>(in, 0.5);
  c.velocity_resolution_m_s = near<T>(in, 1e-5);
  c.min_section_s = near<T>(in, 0.02);
  c.mass_window_s = near<T>(in, 0.02);
  c.max_force_N = near<T>(in, 1e6);
  c.max_gap_s = near<T>(in, 0.1);
  c.force_lag_samples = near<T>(in, -1.0);
  c.max_vs_iterations = in.ConsumeIntegral<uint16_t>();
  return c;
}

/// The next servo sample: steps, speeds and forces near a drive's, and a
/// position that integrates the velocity (`x`) or is anything at all.
template <typename T> feedid::Sample<T> sample(FuzzedDataProvider& in, T& x) {
  feedid::Sample<T> smp;
  smp.dt_s = near<T>(in, 5e-4);
  smp.velocity_m_s = near<T>(in, 0.05);
  x += smp.velocity_m_s * smp.dt_s;
  smp.position_m = in.ConsumeBool() ? x : any<T>(in);
  smp.force_N = near<T>(in, 50.0);
  return smp;
}

}  // namespace
