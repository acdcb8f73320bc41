// Start-up for a bare Cortex-M4F (QEMU mps2-an386): the vector table, a
// reset handler that enables the FPU, copies .data, zeroes .bss and runs the
// static constructors, and fault handlers that report through semihosting
// instead of hanging. No C library start-up files (-nostartfiles).
#include <stdint.h>

#include "board.hpp"
#include "semihosting.hpp"

extern "C" {
// Linker script symbols (mps2_an386.ld).
extern uint32_t __data_start, __data_end, __data_load, __bss_start, __bss_end, __stack_top;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();

int main();
[[noreturn]] void Reset_Handler();
[[noreturn]] void Fault_Handler();
void SysTick_Handler();  // defined by the application (the servo tick)
}

extern "C" [[noreturn]] void Fault_Handler() {
  feedid::fw::semihosting::write0(
      "FAIL: CPU fault (HardFault/MemManage/BusFault/UsageFault or unexpected interrupt)\n");
  feedid::fw::semihosting::exit(3);
}

// ARMv7-M vector table: initial stack pointer, then the 15 system exceptions.
// External interrupts are never enabled by this firmware, so none follow.
using Vector = void (*)();
extern "C" __attribute__((section(".isr_vector"), used)) const Vector feedid_vectors[16] = {
    reinterpret_cast<Vector>(&__stack_top),
    Reset_Handler,
    Fault_Handler,  // NMI
    Fault_Handler,  // HardFault
    Fault_Handler,  // MemManage
    Fault_Handler,  // BusFault
    Fault_Handler,  // UsageFault
    nullptr, nullptr, nullptr, nullptr,
    Fault_Handler,  // SVCall
    Fault_Handler,  // DebugMonitor
    nullptr,
    Fault_Handler,  // PendSV
    SysTick_Handler,
};

extern "C" [[noreturn]] void Reset_Handler() {
  // FPU first: the compiler may use FPU registers anywhere after this.
  feedid::fw::board::fpu_enable();
  // Word loops through volatile pointers, so the compiler cannot turn them
  // into memcpy/memset calls before memory is set up.
  volatile uint32_t* dst = &__data_start;
  const volatile uint32_t* src = &__data_load;
  while (dst < &__data_end) *dst++ = *src++;
  for (volatile uint32_t* p = &__bss_start; p < &__bss_end; ++p) *p = 0;
  for (void (**f)() = __init_array_start; f < __init_array_end; ++f) (*f)();
  const int rc = main();
  feedid::fw::semihosting::exit(static_cast<uint32_t>(rc));
}
