// The few pieces of the Cortex-M4 and of QEMU's mps2-an386 board the
// firmware example uses: SysTick (the servo tick), a CMSDK APB timer (a
// free-running 32-bit counter for cost measurements), interrupt masking
// (the queue's lock policy and the race-free sleep), and the FPU enable.
// Register addresses: ARMv7-M ARM (SysTick, SCB) and ARM AN386 / QEMU
// hw/arm/mps2.c (timer0 at 0x40000000, 25 MHz system and peripheral clock).
#pragma once

#include <stdint.h>

namespace feedid::fw::board {

/// Core and peripheral clock of mps2-an386 (Hz): SysTick with CLKSOURCE=1
/// and the APB timers count at this rate.
constexpr uint32_t clock_hz = 25'000'000;

inline volatile uint32_t& reg(uintptr_t address) { return *reinterpret_cast<volatile uint32_t*>(address); }

// --- SysTick (ARMv7-M B3.3) --------------------------------------------------
constexpr uintptr_t syst_csr = 0xE000E010;  ///< control and status
constexpr uintptr_t syst_rvr = 0xE000E014;  ///< reload value (24 bit)
constexpr uintptr_t syst_cvr = 0xE000E018;  ///< current value
constexpr uint32_t syst_enable = 1u << 0, syst_tickint = 1u << 1, syst_clksource_cpu = 1u << 2;

/// Periodic SysTick interrupt every `period_cycles` core clocks (<= 2^24).
/// Context: task, before the servo runs.
inline void systick_start(uint32_t period_cycles) {
  reg(syst_csr) = 0;
  reg(syst_rvr) = period_cycles - 1u;
  reg(syst_cvr) = 0;
  reg(syst_csr) = syst_enable | syst_tickint | syst_clksource_cpu;
}
inline void systick_stop() { reg(syst_csr) = 0; }

// --- CMSDK APB timer 0: free-running down-counter at clock_hz ----------------
constexpr uintptr_t timer0_ctrl = 0x40000000;
constexpr uintptr_t timer0_value = 0x40000004;
constexpr uintptr_t timer0_reload = 0x40000008;

inline void counter_start() {
  reg(timer0_ctrl) = 0;
  reg(timer0_reload) = 0xFFFFFFFFu;
  reg(timer0_value) = 0xFFFFFFFFu;
  reg(timer0_ctrl) = 1u;  // enable, no interrupt
}
/// Counts up (the hardware counts down); differences are clock_hz ticks.
/// Under `qemu -icount shift=0` one tick is 40 ns of virtual time = 40
/// executed instructions (docs/firmware.md).
inline uint32_t counter_now() { return ~reg(timer0_value); }

// --- interrupt masking --------------------------------------------------------
inline void irq_disable() { __asm volatile("cpsid i" ::: "memory"); }
inline void irq_enable() { __asm volatile("cpsie i" ::: "memory"); }

/// Sleeps until an interrupt is pending, without the lost-wake-up race: the
/// condition is checked with interrupts masked, and WFI wakes on a pending
/// interrupt even while PRIMASK masks it. Context: task.
template <typename Condition> void sleep_while(Condition keep_sleeping) {
  irq_disable();
  if (keep_sleeping()) __asm volatile("dsb\n\twfi" ::: "memory");
  irq_enable();
}

/// SpscQueue lock policy for the task side on a single-core Cortex-M: masks
/// interrupts with PRIMASK. Not nestable; the queue takes it only from task
/// context where interrupts are enabled, and never on the ISR side.
struct InterruptLock {
  static void lock() { irq_disable(); }
  static void unlock() { irq_enable(); }
};

// --- FPU ------------------------------------------------------------------------
/// CP10/CP11 full access (CPACR, 0xE000ED88). Must run before any FPU instruction.
inline void fpu_enable() {
  reg(0xE000ED88) |= (0xFu << 20);
  __asm volatile("dsb\n\tisb" ::: "memory");
}

}  // namespace feedid::fw::board
