// Open-loop inverse-dynamics plant (open_loop_plant.hpp). Host only.
#include "open_loop_plant.hpp"

#include "model/constants.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace feedid::host {

namespace {

constexpr int kSubsteps = 16;  ///< Simpson intervals per period (even)

double sign_of(double v) { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }

/// The axis on the reference path and the states its effects carry.
class InverseDynamics {
 public:
  InverseDynamics(const DriveParams& d, const Effects& e, const PathPoint& start) : d_(d), e_(e) {
    if (e.compliance_frequency_hz > 0.0) {
      const double mu = e.compliance_mass_fraction, w = 2.0 * kPi * e.compliance_frequency_hz;
      m_motor_ = d.mass_kg * (1.0 - mu);
      m_load_ = d.mass_kg * mu;
      const double reduced = m_motor_ * m_load_ / d.mass_kg;
      k_ = w * w * reduced;
      c_ = 2.0 * e.compliance_damping_ratio * w * reduced;
      x_load_ = start.x_m;
    } else {
      m_motor_ = d.mass_kg;
    }
  }

  void hold_wander(double f_N) { wander_N_ = f_N; }

  /// Force the drive applies at time t on the path point p (N).
  double force(double t, const PathPoint& p) const {
    double u = m_motor_ * p.a_m_s2 + friction(t, p) + load(t, p.x_m);
    if (m_load_ > 0.0) u += spring(p);
    return u;
  }

  /// Moves the carried states from p0 (time t) to p1 (time t + h), pm the midpoint.
  void advance(double h, const PathPoint& p0, const PathPoint& pm, const PathPoint& p1) {
    advance_dahl(p1.x_m - p0.x_m);
    if (m_load_ > 0.0) advance_load(h, p0, pm, p1);
  }

 private:
  double friction(double t, const PathPoint& p) const {
    const double v = p.v_m_s, s = sign_of(v);
    if (s == 0.0) return 0.0;
    const DirectionFriction& f = s > 0.0 ? d_.pos : d_.neg;
    double F = stribeck_friction(d_, v);
    if (e_.drift_fraction != 0.0)
      F += e_.drift_fraction * std::exp(-t / e_.drift_time_constant_s) * (s * f.coulomb_N + f.viscous_Ns_m * v);
    F += e_.quadratic_c2_Ns2_m2 * v * std::fabs(v);
    if (e_.position_friction_N != 0.0) F += s * e_.position_friction_N * range_weight(p.x_m);
    if (e_.presliding_force_N > 0.0) F += e_.presliding_force_N * (dahl_z_ - s);
    return F;
  }

  /// 1 inside [x_min, x_max], ramping linearly to 0 over 10 % of the width at each edge.
  double range_weight(double x) const {
    const double lo = e_.position_friction_x_min_m, hi = e_.position_friction_x_max_m;
    const double ramp = 0.1 * (hi - lo);
    return std::clamp(std::min(x - lo, hi - x) / ramp + 0.5, 0.0, 1.0);
  }

  double load(double t, double x) const { return load_force(e_, t, x) + wander_N_; }

  double spring(const PathPoint& p) const { return k_ * (p.x_m - x_load_) + c_ * (p.v_m_s - v_load_); }

  // Dahl: dz/dx = (s - z)/d with s the sliding direction, solved exactly over a step dx.
  void advance_dahl(double dx) {
    if (e_.presliding_force_N <= 0.0 || dx == 0.0) return;
    const double s = sign_of(dx);
    dahl_z_ = s + (dahl_z_ - s) * std::exp(-std::fabs(dx) / e_.presliding_distance_m);
  }

  // RK4 on the load behind the spring, m2 a2 = k (x1 - x2) + c (v1 - v2), x1 given.
  void advance_load(double h, const PathPoint& p0, const PathPoint& pm, const PathPoint& p1) {
    auto accel = [this](const PathPoint& p, double x2, double v2) {
      return (k_ * (p.x_m - x2) + c_ * (p.v_m_s - v2)) / m_load_;
    };
    const double x0 = x_load_, v0 = v_load_;
    const double k1x = v0, k1v = accel(p0, x0, v0);
    const double k2x = v0 + 0.5 * h * k1v, k2v = accel(pm, x0 + 0.5 * h * k1x, v0 + 0.5 * h * k1v);
    const double k3x = v0 + 0.5 * h * k2v, k3v = accel(pm, x0 + 0.5 * h * k2x, v0 + 0.5 * h * k2v);
    const double k4x = v0 + h * k3v, k4v = accel(p1, x0 + h * k3x, v0 + h * k3v);
    x_load_ = x0 + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    v_load_ = v0 + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
  }

  const DriveParams& d_;
  const Effects& e_;
  double m_motor_ = 0.0, m_load_ = 0.0, k_ = 0.0, c_ = 0.0;
  double x_load_ = 0.0, v_load_ = 0.0;  ///< load behind the spring (m, m/s)
  double dahl_z_ = 0.0;                 ///< presliding state, -1..1
  double wander_N_ = 0.0;               ///< wandering load force of this period (N)
};

/// u(t_k) and the mean of u over [t_k, t_k+1] for one period.
struct PeriodForce {
  double at_start_N = 0.0;
  double mean_N = 0.0;
  double at_end_N = 0.0;  ///< u(t_k+1), the next period's start
};

/// Integrates one period on kSubsteps substeps; `u_start` is u(t_k), carried
/// over from the previous period's end.
PeriodForce integrate_period(InverseDynamics& axis, MotionPath& path, double t, double dt, double u_start) {
  const double h = dt / kSubsteps;
  PathPoint p0 = path.at(t);
  double simpson = u_start, u = u_start;
  for (int j = 1; j <= kSubsteps; ++j) {
    const PathPoint pm = path.at(t + (j - 0.5) * h);
    const PathPoint p1 = path.at(t + j * h);
    axis.advance(h, p0, pm, p1);
    u = axis.force(t + j * h, p1);
    simpson += (j == kSubsteps ? 1.0 : (j % 2 == 1 ? 4.0 : 2.0)) * u;
    p0 = p1;
  }
  return {u_start, simpson / (3.0 * kSubsteps), u};
}

/// The logged force of period k under the convention, before any delay.
double logged_force(ForceLog kind, const PeriodForce& now, const PeriodForce& before) {
  switch (kind) {
    case ForceLog::held: return now.mean_N;
    case ForceLog::instant: return now.at_start_N;
    case ForceLog::averaged: return before.mean_N;
  }
  return now.mean_N;
}

/// Sequence value at fractional index pos (linear; held at the first sample before it).
double delayed(const std::vector<double>& seq, double pos) {
  if (pos <= 0.0) return seq.front();
  const auto i0 = static_cast<std::size_t>(std::floor(pos));
  const double a = pos - static_cast<double>(i0);
  return i0 + 1 < seq.size() ? (1.0 - a) * seq[i0] + a * seq[i0 + 1] : seq[i0];
}

}  // namespace

Trace simulate_open_loop(const SimConfig& cfg, const std::function<void(double)>& progress) {
  const double dt = 1.0 / cfg.controller.servo_rate_hz;
  const auto n_samples = static_cast<std::size_t>(std::floor(cfg.motion.duration_s / dt + 1e-9)) + 1;
  const Effects& fx = cfg.effects;

  MotionPath path(cfg.motion, cfg.seed);
  InverseDynamics axis(cfg.drive, fx, path.at(0.0));
  std::mt19937_64 rng(cfg.seed ^ 0x5851F42D4C957F2Dull);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::mt19937_64 wander_rng(cfg.seed ^ 0x9E3779B97F4A7C15ull);
  std::normal_distribution<double> wander_normal(0.0, 1.0);
  const double wander_a = fx.wander_force_N > 0.0 ? std::exp(-dt / fx.wander_time_constant_s) : 0.0;
  const double wander_b = fx.wander_force_N * std::sqrt(std::max(0.0, 1.0 - wander_a * wander_a));
  double wander = fx.wander_force_N > 0.0 ? fx.wander_force_N * wander_normal(wander_rng) : 0.0;

  LoggedVelocity velocity_log(cfg.logging, dt);
  std::vector<double> force_seq;  // logged force before delay and noise
  force_seq.reserve(n_samples);
  Trace trace;
  trace.source = "open-loop plant";
  trace.samples.reserve(n_samples);

  const std::size_t progress_every = std::max<std::size_t>(1, (n_samples + 99) / 100);
  const double q = cfg.sensors.encoder_resolution_m;
  double x_prev = quantise(path.at(0.0).x_m, q);
  double u_start = axis.force(0.0, path.at(0.0));
  PeriodForce before{};
  for (std::size_t k = 0; k < n_samples; ++k) {
    const double t = static_cast<double>(k) * dt;
    const double x_meas = quantise(path.at(t).x_m, q);
    const double v_meas = k == 0 ? 0.0 : (x_meas - x_prev) / dt;
    x_prev = x_meas;

    axis.hold_wander(wander);
    if (fx.wander_force_N > 0.0) wander = wander_a * wander + wander_b * wander_normal(wander_rng);
    const PeriodForce now = integrate_period(axis, path, t, dt, u_start);
    u_start = now.at_end_N;
    force_seq.push_back(logged_force(cfg.logging.force, now, k == 0 ? now : before) +
                        normal(rng) * cfg.sensors.force_process_noise_N);
    before = now;

    const double u_log = fx.delay_s > 0.0 ? delayed(force_seq, static_cast<double>(k) - fx.delay_s / dt)
                                          : force_seq.back();
    trace.samples.push_back(TraceSample{t, x_meas, velocity_log.next(v_meas), u_log + normal(rng) * cfg.sensors.force_noise_N});
    if (progress && (k % progress_every == 0)) progress(static_cast<double>(k) / static_cast<double>(n_samples));
  }
  if (progress) progress(1.0);
  return trace;
}

}  // namespace feedid::host
