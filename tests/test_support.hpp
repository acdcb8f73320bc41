// Small helpers shared by the tests: simulate a drive, turn a host Trace into
// core samples, and a default core Config for a simulated sensor. No core
// logic is repeated here.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>

#include "core/core_trace.hpp"
#include "sim/drive_sim.hpp"
#include "feedid/feedid.hpp"
#include "io/trace.hpp"

namespace feedid::test {

/// What varies between the simulated drives of the tests.
struct SimSpec {
  double mass_kg = 100.0;
  double rate_hz = 2000.0;
  std::uint64_t seed = 1;
  double encoder_m = 1e-8;
  double force_noise_N = 0.5;
  double duration_s = 60.0;
};

/// Simulator configuration for a spec (all other settings at their defaults).
inline host::SimConfig sim_config(const SimSpec& s) {
  host::SimConfig c;
  c.drive.mass_kg = s.mass_kg;
  c.controller.servo_rate_hz = s.rate_hz;
  c.seed = s.seed;
  c.sensors.encoder_resolution_m = s.encoder_m;
  c.sensors.force_noise_N = s.force_noise_N;
  c.motion.duration_s = s.duration_s;
  return c;
}

/// The same, logged with a force convention and a velocity filter (a
/// 3-sample mean, or a low-pass of one period).
inline host::SimConfig logged_config(const SimSpec& s, host::ForceLog force, host::VelocityLog velocity) {
  host::SimConfig c = sim_config(s);
  c.logging.force = force;
  c.logging.velocity = velocity;
  c.logging.velocity_average_samples = 3;
  c.logging.velocity_time_constant_s = 1.0 / s.rate_hz;
  return c;
}

inline host::Trace simulate(const SimSpec& s) { return host::simulate(sim_config(s)); }

/// The default drive's 60 s ladder as a rotary arm: its travel of 0.11 m
/// read as 20 times as many rad (2.25 rad), with G cos(q - q0) added to the
/// force. The friction and mass are the drive's in the arm's units.
inline host::Trace arm_trace(double G, double q0) {
  host::Trace tr = simulate(SimSpec{});
  for (host::TraceSample& s : tr.samples) {
    s.x_m *= 20.0;
    s.v_m_s *= 20.0;
    s.u_N += G * std::cos(s.x_m - q0);
  }
  return tr;
}

/// The core configuration for an encoder of quantum q (m) sampled at rate
/// (Hz), and the relative error: the core tests' own (core_trace.hpp).
using core_test::default_config;
using core_test::rel_err;

template <typename T> Config<T> default_config(const host::SimConfig& sc) {
  return default_config<T>(sc.sensors.encoder_resolution_m, sc.controller.servo_rate_hz);
}

template <typename T> Sample<T> to_sample(const host::TraceSample& s, double dt_s) {
  Sample<T> x;
  x.dt_s = T(dt_s);
  x.position_m = T(s.x_m);
  x.velocity_m_s = T(s.v_m_s);
  x.force_N = T(s.u_N);
  return x;
}

struct PushCounts {
  std::size_t accepted = 0;
  std::size_t rejected = 0;
};

/// Pushes every sample of `tr` with dt from consecutive t. The first sample
/// gets `first_dt_s` (irrelevant for a fresh estimator; when appending a
/// trace to a running stream it is the step from the previous trace's end).
template <typename T, int B, int C>
PushCounts push_trace(Estimator<T, B, C>& est, const host::Trace& tr, double first_dt_s = 0.0) {
  PushCounts n;
  double t_prev = 0.0;
  for (std::size_t k = 0; k < tr.samples.size(); ++k) {
    const host::TraceSample& s = tr.samples[k];
    const double dt = k == 0 ? first_dt_s : s.t_s - t_prev;
    t_prev = s.t_s;
    if (est.push(to_sample<T>(s, dt)) == Status::ok) ++n.accepted;
    else ++n.rejected;
  }
  return n;
}

/// An axis at rest under servo jitter: velocity a random whole number of
/// quanta in [-max_quanta, max_quanta] (position is its running sum), force
/// white noise of force_std_N; `seconds` long at rate_hz.
inline host::Trace rest_jitter_trace(double rate_hz, double quantum_m_s, int max_quanta, double force_std_N,
                                     double seconds, std::uint64_t seed) {
  host::Trace tr;
  tr.source = "rest jitter";
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> quanta(-max_quanta, max_quanta);
  std::normal_distribution<double> force(0.0, force_std_N);
  const double dt = 1.0 / rate_hz;
  const auto n = static_cast<std::size_t>(seconds * rate_hz) + 1;
  double x = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double v = k == 0 ? 0.0 : quanta(rng) * quantum_m_s;
    x += v * dt;
    tr.samples.push_back(host::TraceSample{static_cast<double>(k) * dt, x, v, force(rng)});
  }
  return tr;
}


/// The message of the exception (std::exception) that f throws; "" when it throws none.
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace feedid::test
