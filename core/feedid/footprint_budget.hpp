// RAM budget of one axis's estimator, checked at compile time by the
// firmware (main.cpp, for the target's sizes) and by the host test suite
// (tests/firmware/firmware_footprint_test.cpp). A change to the core that needs more
// must raise the number here, on purpose, with the reason in docs/firmware.md.
#pragma once

#include <stddef.h>

namespace feedid::fw {

/// Estimator<float>, the target's instance (bytes): the product's
/// target of at most 8 KiB per axis (6 % of the 128 KB SRAM of an
/// STM32F407-class part, room for four axes next to the drive's firmware).
constexpr size_t estimator_float_ram_budget = 8 * 1024;
/// Estimator<double>, the host reference; about twice the float one.
constexpr size_t estimator_double_ram_budget = 20 * 1024;
/// HealthTracker<float>, one axis's friction-health tracking (epoch
/// estimator, change monitor, last epoch): the same 8 KiB per axis.
constexpr size_t health_tracker_float_ram_budget = 8 * 1024;

}  // namespace feedid::fw
