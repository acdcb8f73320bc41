// What every emulated firmware run uses to report (feedid_m4.elf,
// feedid_monitor_m4.elf): the console on semihosting, the stack high-water
// mark, and cost figures from the 25 MHz counter scaled to instructions.
#pragma once

#include <stdint.h>

#include "board.hpp"
#include "console.hpp"
#include "semihosting.hpp"

namespace feedid::fw {

/// Console output goes through semihosting (QEMU prints it on its stderr).
struct SemihostingSink {
  static void write(const char* s) { semihosting::write0(s); }
};
using SemihostingConsole = Console<SemihostingSink>;

// --- stack high-water mark ---------------------------------------------------
extern "C" uint32_t __stack_bottom, __stack_top;
constexpr uint32_t stack_paint = 0xA5A5A5A5u;

/// Fills the unused part of the main stack (below the current frame) with a
/// pattern. Context: start of main, interrupts off.
__attribute__((noinline)) inline void paint_stack() {
  uintptr_t sp;
  __asm volatile("mov %0, sp" : "=r"(sp));
  const uintptr_t limit = sp - 128;  // leave this frame alone
  for (volatile uint32_t* p = &__stack_bottom; reinterpret_cast<uintptr_t>(p) < limit; ++p) *p = stack_paint;
}
inline uint32_t stack_used_bytes() {
  const uint32_t* p = &__stack_bottom;
  while (p < &__stack_top && *p == stack_paint) ++p;
  return static_cast<uint32_t>(reinterpret_cast<uintptr_t>(&__stack_top) - reinterpret_cast<uintptr_t>(p));
}
inline uint32_t stack_size_bytes() {
  return static_cast<uint32_t>(reinterpret_cast<uintptr_t>(&__stack_top) - reinterpret_cast<uintptr_t>(&__stack_bottom));
}

// --- cost ----------------------------------------------------------------------
/// Counter ticks as instructions under -icount shift=0 (1 ns per instruction,
/// 40 ns per tick of the 25 MHz counter).
constexpr uint32_t instructions_per_tick = 1'000'000'000u / board::clock_hz;

/// Runs exactly 2 * n instructions (a subtract and a branch per turn) and
/// returns the counter ticks they took: the scale of every cost figure.
inline uint32_t calibration_ticks(uint32_t n) {
  const uint32_t t0 = board::counter_now();
  __asm volatile("1: subs %0, %0, #1\n\tbne 1b" : "+r"(n) : : "cc");
  return board::counter_now() - t0;
}

/// Instructions per counter tick, measured with calibration_ticks: exact
/// under qemu -icount shift=0 (40), host-time noise without -icount.
inline float measured_instructions_per_tick(uint32_t turns, uint32_t& ticks) {
  ticks = calibration_ticks(turns);
  return float(2 * turns) / float(ticks > 0 ? ticks : 1);
}

inline void print_cost(SemihostingConsole& out, const char* what, float ticks, float instructions_per_tick_measured) {
  out << "  " << what << ": ";
  out.real(ticks, 5) << " ticks = ";
  out.real(ticks * instructions_per_tick_measured, 5) << " instructions\n";
}

}  // namespace feedid::fw
