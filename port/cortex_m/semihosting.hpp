// Minimal ARM semihosting (the "Angel" interface, BKPT 0xAB on M-profile):
// write a string to the debugger's console and exit with a status. Our own
// three calls instead of newlib's rdimon, which would link malloc and stdio.
// Needs `qemu-system-arm ... -semihosting`; on hardware without a debugger
// attached a BKPT would halt the core, so this file is for the emulated run.
#pragma once

#include <stdint.h>

namespace feedid::fw::semihosting {

enum Operation : uint32_t {
  sys_write0 = 0x04,         ///< r1 -> NUL-terminated string
  sys_exit = 0x18,           ///< r1 = reason code
  sys_exit_extended = 0x20,  ///< r1 -> {reason, exit code}
};
/// Reason code of a normal program exit.
constexpr uint32_t adp_stopped_application_exit = 0x20026;

inline uint32_t call(uint32_t op, const void* arg) {
  register uint32_t r0 __asm("r0") = op;
  register const void* r1 __asm("r1") = arg;
  __asm volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}

/// Writes a NUL-terminated string to the host console (QEMU's stdout).
inline void write0(const char* s) { (void)call(sys_write0, s); }

/// Ends the emulation; QEMU exits with `code` (0 = success).
[[noreturn]] inline void exit(uint32_t code) {
  const uint32_t block[2] = {adp_stopped_application_exit, code};
  (void)call(sys_exit_extended, block);
  // A host without SYS_EXIT_EXTENDED: plain exit (status 0 or 1 only).
  (void)call(sys_exit, reinterpret_cast<const void*>(code == 0 ? adp_stopped_application_exit : 0x20023u));
  for (;;) __asm volatile("wfi");
}

}  // namespace feedid::fw::semihosting
