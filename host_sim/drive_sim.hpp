// Closed-loop feed-drive simulator: a rigid body with direction-dependent
// Stribeck friction and physical stick/slip, driven by a cascaded P (position)
// / PI (velocity) controller at the servo rate, following a reciprocating
// reference whose peak speeds are spread from very slow to fast. Measured
// signals carry encoder quantisation, velocity from position differences and
// force noise. Deterministic for a given seed. Host only.
#pragma once
#include <cstdint>
#include <functional>
#include <string>

#include "trace.hpp"

namespace feedid::host {

/// Friction of one direction, positive magnitudes (NOTES.md model).
struct DirectionFriction {
  double viscous_Ns_m = 700.0;            ///< sigma (N s/m)
  double coulomb_N = 25.0;                ///< Fc (N)
  double breakaway_N = 8.0;               ///< Fs (N): static friction is Fc + Fs
  double stribeck_velocity_m_s = 2.0e-3;  ///< vs (m/s)
};

struct DriveParams {
  double mass_kg = 100.0;
  DirectionFriction pos{};
  DirectionFriction neg{720.0, 26.0, 7.5, 1.8e-3};
};

/// F(v) of NOTES.md for v != 0 (sign included); 0 at v == 0.
double stribeck_friction(const DriveParams& p, double v_m_s);

struct ControllerParams {
  double servo_rate_hz = 2000.0;      ///< controller and sampling rate (Hz)
  double position_gain_1_s = 60.0;    ///< kp: velocity command per position error (1/s)
  double velocity_bandwidth_hz = 40.0;///< velocity loop crossover; kv = 2*pi*bw*mass (N s/m)
  double velocity_integral_hz = 8.0;  ///< PI zero (Hz): ki = kv*2*pi*f (N/m)
  double force_limit_N = 5000.0;      ///< actuator saturation (N)
  bool acceleration_feedforward = true;///< add mass*a_ref (mass as the drive believes it)
};

struct MotionParams {
  double slowest_speed_m_s = 2.0e-4;  ///< lowest peak speed of the reciprocating strokes
  double fastest_speed_m_s = 0.15;    ///< highest peak speed
  int speed_levels = 14;              ///< peak speeds log-spaced between slowest and fastest
  double acceleration_m_s2 = 1.0;     ///< reference acceleration (m/s^2)
  double cruise_time_s = 0.6;         ///< time at peak speed per stroke (s), capped by travel
  double max_travel_m = 0.4;          ///< stroke never exceeds this (m)
  double dwell_s = 0.15;              ///< rest between strokes (s)
  double duration_s = 60.0;           ///< total trace length (s); the level list repeats
};

struct SensorParams {
  double encoder_resolution_m = 1.0e-8;  ///< position quantum (m)
  double force_noise_N = 0.5;            ///< std of white noise on the recorded force (N)
  double force_process_noise_N = 0.0;    ///< std of white disturbance force acting on the plant (N)
};

/// Extra force acting on the plant, for sim-to-real effects (issue 3). Returns
/// the force (N) that adds to friction on the load side; it opposes motion when
/// positive for positive velocity, like friction. Empty: none.
using ExtraForce = std::function<double(double t_s, double x_m, double v_m_s)>;

struct SimConfig {
  DriveParams drive{};
  ControllerParams controller{};
  MotionParams motion{};
  SensorParams sensors{};
  std::uint64_t seed = 1;
  int plant_substeps = 20;  ///< integration steps per servo period
  ExtraForce extra_force{}; ///< optional, see above
};

/// Simulate and return the recorded trace (t, x, v, u) at the servo rate.
/// `progress` (optional) is called with the fraction done, at most ~100 times.
Trace simulate(const SimConfig& cfg, const std::function<void(double)>& progress = {});

}  // namespace feedid::host
