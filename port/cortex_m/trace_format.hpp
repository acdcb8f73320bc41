// Layout of the trace the firmware replays from flash and of the reference
// results it is compared with. The generator (host_sim/firmware_traces/firmware_trace_gen.cpp, host) writes
// <build>/generated/trace_data.h in this layout; the firmware (main.cpp)
// includes it. Freestanding: plain aggregates of float and integers.
#pragma once

#include <stdint.h>

namespace feedid::fw {

/// One recorded servo sample as the drive has it (SI units). Stored in flash.
struct TracePoint {
  float dt_s;          ///< time since the previous sample (s); 0 for the first
  float velocity_m_s;  ///< load-side velocity, backward difference of the encoder (m/s)
  float force_N;       ///< commanded force on the load side (N)
};

/// The nine identified parameters plus their flags, in float for the
/// firmware's comparison (the host reference was computed in double and
/// rounded once when the header was written).
struct DirectionResult {
  float viscous_Ns_m;           ///< sigma (N s/m)
  float coulomb_N;              ///< Fc (N)
  float breakaway_N;            ///< Fs (N)
  float stribeck_velocity_m_s;  ///< vs (m/s)
  uint32_t flags;               ///< feedid::Flag bits
};

struct Result {
  float mass_kg;        ///< m (kg)
  uint32_t mass_flags;  ///< feedid::Flag bits of the mass
  DirectionResult pos;  ///< positive direction
  DirectionResult neg;  ///< negative direction
};

}  // namespace feedid::fw

namespace feedid::fw {

/// One servo sample of the tracking trace as a drive's logger keeps it:
/// velocity and force as 16-bit counts of a fixed scale (the header gives
/// the scales), the servo period fixed. Half the flash of TracePoint.
struct CountPoint {
  int16_t velocity;  ///< x velocity_lsb_m_s
  int16_t force;     ///< x force_lsb_N
};

/// A change alarm as the host's HealthTracker<double> raised it.
struct AlarmResult {
  uint8_t parameter;  ///< feedid::Tracked
  int8_t direction;   ///< +1 pos, -1 neg, 0 mass
  float t_s;          ///< start of the run that crossed (s)
  float raised_t_s;   ///< end of the epoch that crossed (s)
  float change;       ///< in the parameter's unit
  float change_se;
};

}  // namespace feedid::fw
