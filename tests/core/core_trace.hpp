// Traces for the core's own tests, made from the core's types alone (the
// friction law is the core's friction_magnitude), so that
// feedid_core_tests needs nothing but the core and GoogleTest. An axis
// follows a ladder of strokes open-loop: the velocity is prescribed, the
// force is what the model says it took plus white noise, the position is
// quantised like an encoder's and the logged velocity is its backward
// difference, as a drive logs it. The closed-loop simulator's traces test
// the core in tests/sim/.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "feedid/feedforward.hpp"
#include "feedid/feedid.hpp"

namespace feedid::core_test {

/// The drive the strokes move: the simulator's default 100 kg axis.
inline Estimate<double> default_drive() {
  Estimate<double> d;
  d.mass_kg = 100.0;
  d.pos = {};
  d.pos.viscous_Ns_m = 700.0;
  d.pos.coulomb_N = 25.0;
  d.pos.breakaway_N = 8.0;
  d.pos.stribeck_velocity_m_s = 0.002;
  d.neg.viscous_Ns_m = 720.0;
  d.neg.coulomb_N = 26.0;
  d.neg.breakaway_N = 7.5;
  d.neg.stribeck_velocity_m_s = 0.0018;
  return d;
}

/// What varies between the traces of the tests.
struct StrokeSpec {
  double rate_hz = 1000.0;
  double encoder_m = 1e-8;        ///< position quantum (m)
  double force_noise_N = 0.5;     ///< white, standard deviation (N)
  double slowest_m_s = 2e-4;      ///< peak speed of the slowest stroke
  double fastest_m_s = 0.15;      ///< and of the fastest
  int strokes_per_direction = 20;
  double ramp_s = 0.1;            ///< raised-cosine speed-up and slow-down
  double cruise_s = 1.0;          ///< at the peak speed
  double dwell_s = 0.1;           ///< at rest between strokes
  std::uint64_t seed = 1;
};

/// Speed at time tau into a stroke of peak speed `peak` (m/s) and its
/// derivative (m/s^2): a raised-cosine ramp up, a cruise, a ramp down.
inline void stroke_profile(const StrokeSpec& s, double peak, double tau, double& v, double& a) {
  const double up = s.ramp_s, down = s.ramp_s + s.cruise_s, end = down + s.ramp_s;
  const double w = M_PI / s.ramp_s;
  v = a = 0.0;
  if (tau < up) {
    v = 0.5 * peak * (1.0 - std::cos(w * tau));
    a = 0.5 * peak * w * std::sin(w * tau);
  } else if (tau < down) {
    v = peak;
  } else if (tau < end) {
    v = 0.5 * peak * (1.0 + std::cos(w * (tau - down)));
    a = -0.5 * peak * w * std::sin(w * (tau - down));
  }
}

/// The force the model of `d` needs at velocity v and acceleration a (N).
inline double model_force(const Estimate<double>& d, double v, double a) {
  if (v == 0.0) return d.mass_kg * a;
  const double f = v > 0 ? friction_magnitude(d.pos, v) : -friction_magnitude(d.neg, -v);
  return d.mass_kg * a + f;
}

/// The samples of the ladder, each with dt from the previous one (the
/// first's dt is 0): strokes alternate direction, slowest first, peak
/// speeds log-spaced from slowest_m_s to fastest_m_s.
inline std::vector<Sample<double>> stroke_ladder(const Estimate<double>& d, const StrokeSpec& s) {
  std::mt19937_64 rng(s.seed);
  std::normal_distribution<double> noise(0.0, s.force_noise_N);
  const double dt = 1.0 / s.rate_hz, stroke_s = 2.0 * s.ramp_s + s.cruise_s + s.dwell_s;
  const int strokes = 2 * s.strokes_per_direction;
  const auto n = static_cast<std::size_t>(strokes * stroke_s * s.rate_hz);
  std::vector<Sample<double>> out;
  out.reserve(n);
  double x = 0.0, x_logged_prev = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    const int i = static_cast<int>(t / stroke_s);
    const double share = s.strokes_per_direction > 1 ? static_cast<double>(i / 2) / (s.strokes_per_direction - 1) : 0.0;
    const double peak = s.slowest_m_s * std::pow(s.fastest_m_s / s.slowest_m_s, share) * (i % 2 == 0 ? 1.0 : -1.0);
    double v = 0.0, a = 0.0;
    stroke_profile(s, peak, t - i * stroke_s, v, a);
    x += v * dt;
    const double x_logged = s.encoder_m * std::round(x / s.encoder_m);
    Sample<double> smp;
    smp.dt_s = k == 0 ? 0.0 : dt;
    smp.position_m = x_logged;
    smp.velocity_m_s = k == 0 ? 0.0 : (x_logged - x_logged_prev) / dt;
    smp.force_N = model_force(d, v, a) + noise(rng);
    x_logged_prev = x_logged;
    out.push_back(smp);
  }
  return out;
}

/// The core configuration for an encoder of quantum q (m) sampled at rate
/// (Hz): the velocity quantum is q*rate.
template <typename T> Config<T> default_config(double encoder_m, double rate_hz) {
  const double res = encoder_m * rate_hz;
  Config<T> c;
  c.velocity_min_m_s = T(std::fmax(2.0 * res, 1e-5));
  c.velocity_max_m_s = T(0.2);
  c.velocity_resolution_m_s = T(res);
  return c;
}

/// Sample in another scalar type.
template <typename T> Sample<T> as(const Sample<double>& s) {
  Sample<T> x;
  x.dt_s = T(s.dt_s);
  x.position_m = T(s.position_m);
  x.velocity_m_s = T(s.velocity_m_s);
  x.force_N = T(s.force_N);
  return x;
}

/// Relative error of an estimate against the truth.
inline double rel_err(double estimate, double truth) { return std::fabs(estimate / truth - 1.0); }

}  // namespace feedid::core_test
