// Closed-loop feed-drive simulator (see drive_sim.hpp). Host only.
//
// Structure of one servo period [t_k, t_k + dt):
//   1. sample the encoder at t_k, form the drive's velocity by position
//      difference, evaluate the reference, run the P / PI cascade -> u_k;
//   2. record (t_k, x_meas, v_meas, u_k + measurement noise), with u_k
//      replaced by the delayed applied force when Effects::delay_s is set;
//   3. hold u_k (zero-order hold) and integrate the plant over the period in
//      `plant_substeps` RK4 substeps with Karnopp-style stick/slip (motor
//      side), the sim-to-real effects of Effects included.
#include "drive_sim.hpp"

#include "model/constants.hpp"

#include "open_loop_plant.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace feedid::host {

namespace {


// ---------------------------------------------------------------------------
// Input validation
// ---------------------------------------------------------------------------

// Throws std::invalid_argument("<field> (<unit>) must be <condition>, got <v>").
[[noreturn]] void reject(const std::string& field, const std::string& unit,
                         const std::string& condition, double value) {
  std::ostringstream os;
  os << field << " (" << unit << ") must be " << condition << ", got " << value;
  throw std::invalid_argument(os.str());
}

void require_positive(double v, const char* field, const char* unit) {
  if (!(std::isfinite(v) && v > 0.0)) reject(field, unit, "finite and > 0", v);
}

void require_non_negative(double v, const char* field, const char* unit) {
  if (!(std::isfinite(v) && v >= 0.0)) reject(field, unit, "finite and >= 0", v);
}

void validate_friction(const DirectionFriction& f, const std::string& side) {
  require_non_negative(f.viscous_Ns_m, ("drive." + side + ".viscous_Ns_m").c_str(), "N s/m");
  require_non_negative(f.coulomb_N, ("drive." + side + ".coulomb_N").c_str(), "N");
  require_non_negative(f.breakaway_N, ("drive." + side + ".breakaway_N").c_str(), "N");
  require_positive(f.stribeck_velocity_m_s, ("drive." + side + ".stribeck_velocity_m_s").c_str(),
                   "m/s");
}

void require_finite(double v, const char* field, const char* unit) {
  if (!std::isfinite(v)) reject(field, unit, "finite", v);
}

void validate_effects(const SimConfig& c) {
  const Effects& e = c.effects;
  require_finite(e.offset_N, "effects.offset_N", "N");

  require_finite(e.ripple_amplitude_N, "effects.ripple_amplitude_N", "N");
  require_finite(e.ripple_phase_rad, "effects.ripple_phase_rad", "rad");
  if (e.ripple_amplitude_N != 0.0) require_positive(e.ripple_period_m, "effects.ripple_period_m", "m");

  require_finite(e.position_friction_N, "effects.position_friction_N", "N");
  if (e.position_friction_N != 0.0) {
    const double floor = -std::min(c.drive.pos.coulomb_N, c.drive.neg.coulomb_N);
    if (e.position_friction_N < floor)
      reject("effects.position_friction_N", "N", ">= -min(Fc+, Fc-) (friction stays >= 0)", e.position_friction_N);
    require_finite(e.position_friction_x_min_m, "effects.position_friction_x_min_m", "m");
    require_finite(e.position_friction_x_max_m, "effects.position_friction_x_max_m", "m");
    if (!(e.position_friction_x_max_m > e.position_friction_x_min_m))
      reject("effects.position_friction_x_max_m", "m", "> effects.position_friction_x_min_m",
             e.position_friction_x_max_m);
  }

  require_finite(e.drift_fraction, "effects.drift_fraction", "-");
  if (e.drift_fraction != 0.0) {
    if (!(e.drift_fraction > -1.0)) reject("effects.drift_fraction", "-", "> -1", e.drift_fraction);
    require_positive(e.drift_time_constant_s, "effects.drift_time_constant_s", "s");
  }

  require_non_negative(e.quadratic_c2_Ns2_m2, "effects.quadratic_c2_Ns2_m2", "N s^2/m^2");

  require_non_negative(e.presliding_force_N, "effects.presliding_force_N", "N");
  if (e.presliding_force_N > 0.0) require_positive(e.presliding_distance_m, "effects.presliding_distance_m", "m");

  require_non_negative(e.compliance_frequency_hz, "effects.compliance_frequency_hz", "Hz");
  if (e.compliance_frequency_hz > 0.0) {
    const double mu = e.compliance_mass_fraction;
    if (!(std::isfinite(mu) && mu > 0.0 && mu < 1.0))
      reject("effects.compliance_mass_fraction", "-", "in (0, 1)", mu);
    require_non_negative(e.compliance_damping_ratio, "effects.compliance_damping_ratio", "-");
    // RK4 must resolve the resonance: omega * h <= 0.5 with h = dt / substeps.
    const double f_max = 0.5 * c.controller.servo_rate_hz * c.plant_substeps / (2.0 * kPi);
    if (e.compliance_frequency_hz > f_max)
      reject("effects.compliance_frequency_hz", "Hz",
             "<= servo_rate * plant_substeps / (4 pi) (integration accuracy)", e.compliance_frequency_hz);
  }

  require_non_negative(e.delay_s, "effects.delay_s", "s");
  if (e.delay_s > c.motion.duration_s) reject("effects.delay_s", "s", "<= motion.duration_s", e.delay_s);

  require_finite(e.disturbance_amplitude_N, "effects.disturbance_amplitude_N", "N");
  require_finite(e.disturbance_phase_rad, "effects.disturbance_phase_rad", "rad");
  if (e.disturbance_amplitude_N != 0.0)
    require_positive(e.disturbance_frequency_hz, "effects.disturbance_frequency_hz", "Hz");

  require_non_negative(e.wander_force_N, "effects.wander_force_N", "N");
  if (e.wander_force_N > 0.0) require_positive(e.wander_time_constant_s, "effects.wander_time_constant_s", "s");
}

void validate_change(const SimConfig& c) {
  const ServiceChange& ch = c.change;
  if (!ch.on()) return;
  if (c.plant != PlantKind::closed_loop)
    throw std::invalid_argument("--change-time: a change in service is simulated by the closed-loop plant only");
  for (const auto& [v, name] : {std::pair<double, const char*>{ch.coulomb_fraction, "--change-coulomb-fraction"},
                                {ch.viscous_fraction, "--change-viscous-fraction"},
                                {ch.mass_fraction, "--change-mass-fraction"}})
    if (!(v > -1.0) || !std::isfinite(v)) throw std::invalid_argument(std::string(name) + " must be > -1 (a fraction)");
  if (ch.direction < -1 || ch.direction > 1) throw std::invalid_argument("--change-direction must be pos, neg or both");
}

void validate(const SimConfig& c) {
  validate_change(c);
  require_positive(c.drive.mass_kg, "drive.mass_kg", "kg");
  validate_friction(c.drive.pos, "pos");
  validate_friction(c.drive.neg, "neg");

  const ControllerParams& k = c.controller;
  require_positive(k.servo_rate_hz, "controller.servo_rate_hz", "Hz");
  require_non_negative(k.position_gain_1_s, "controller.position_gain_1_s", "1/s");
  require_positive(k.velocity_bandwidth_hz, "controller.velocity_bandwidth_hz", "Hz");
  require_non_negative(k.velocity_integral_hz, "controller.velocity_integral_hz", "Hz");
  require_positive(k.force_limit_N, "controller.force_limit_N", "N");

  const MotionParams& m = c.motion;
  require_positive(m.slowest_speed_m_s, "motion.slowest_speed_m_s", "m/s");
  require_positive(m.fastest_speed_m_s, "motion.fastest_speed_m_s", "m/s");
  if (m.slowest_speed_m_s > m.fastest_speed_m_s)
    reject("motion.slowest_speed_m_s", "m/s", "<= motion.fastest_speed_m_s",
           m.slowest_speed_m_s);
  if (m.speed_levels < 1) reject("motion.speed_levels", "count", ">= 1", m.speed_levels);
  require_positive(m.acceleration_m_s2, "motion.acceleration_m_s2", "m/s^2");
  require_non_negative(m.cruise_time_s, "motion.cruise_time_s", "s");
  require_positive(m.max_travel_m, "motion.max_travel_m", "m");
  require_non_negative(m.dwell_s, "motion.dwell_s", "s");
  require_positive(m.duration_s, "motion.duration_s", "s");

  const SensorParams& s = c.sensors;
  if (std::isnan(s.encoder_resolution_m))
    reject("sensors.encoder_resolution_m", "m", "a number (<= 0 disables quantisation)",
           s.encoder_resolution_m);
  require_non_negative(s.force_noise_N, "sensors.force_noise_N", "N");
  require_non_negative(s.force_process_noise_N, "sensors.force_process_noise_N", "N");

  if (c.plant_substeps < 1) reject("plant_substeps", "count", ">= 1", c.plant_substeps);
  if (c.logging.velocity_average_samples < 1)
    reject("logging.velocity_average_samples", "count", ">= 1", c.logging.velocity_average_samples);
  require_positive(c.logging.velocity_time_constant_s, "logging.velocity_time_constant_s", "s");

  validate_effects(c);

  // Keep the sample count sane (the trace is held in memory).
  const double n = m.duration_s * k.servo_rate_hz;
  if (n > 5.0e8)
    reject("motion.duration_s", "s", "such that duration * servo_rate <= 5e8 samples",
           m.duration_s);
}

// ---------------------------------------------------------------------------
// Plant (equations in drive_sim.hpp, struct Effects):
//   m1 dv/dt  = f_in - F_fric(t, x, v) - extra(t, x, v) - F_load(t, x) - F_spring
//   m2 dv2/dt = F_spring                                   (compliant plant only)
//   dx/dt = v, dx2/dt = v2, f_in = u + w held over the servo period; m1 = m for
//   a rigid plant. Karnopp stick/slip on the motor side: at rest it stays at
//   rest while |f_in - extra - F_load - F_spring| <= the static band of the
//   direction it pushes (Fc + Fs without friction effects).
// With no effect on, every expression below reduces to the operations of the
// rigid plant of earlier versions, so the traces are bit-for-bit the same.
// ---------------------------------------------------------------------------
struct State {
  double x = 0.0, v = 0.0;    ///< motor side (the rigid body when not compliant)
  double x2 = 0.0, v2 = 0.0;  ///< load behind the spring (compliant plant only)
};

class Plant {
 public:
  Plant(const DriveParams& d, const Effects& e, const ExtraForce& extra, const ServiceChange& change)
      : d_(d), e_(e), extra_(extra), change_(change) {
    plain_friction_ = e.drift_fraction == 0.0 && e.position_friction_N == 0.0 && e.quadratic_c2_Ns2_m2 == 0.0 &&
                      e.presliding_force_N == 0.0;
    loads_ = e.offset_N != 0.0 || e.ripple_amplitude_N != 0.0 || e.disturbance_amplitude_N != 0.0 ||
             e.wander_force_N > 0.0;
    two_mass_ = e.compliance_frequency_hz > 0.0;
    m1_ = d.mass_kg;
    if (two_mass_) {
      // k = w^2 m1 m2 / m, c = 2 zeta w m1 m2 / m: free resonance w.
      const double mu = e.compliance_mass_fraction;
      m1_ = d.mass_kg * (1.0 - mu);
      m2_ = d.mass_kg * mu;
      const double w = 2.0 * kPi * e.compliance_frequency_hz;
      const double reduced = m1_ * m2_ / d.mass_kg;
      k_ = w * w * reduced;
      c_ = 2.0 * e.compliance_damping_ratio * w * reduced;
    }
  }

  double x() const { return s_.x; }
  double v() const { return s_.v; }
  double load_x() const { return s_.x2; }
  double load_v() const { return s_.v2; }

  /// Load force held over the coming servo period (the wandering disturbance), N.
  void set_held_load(double f) { held_load_ = f; }

  /// Advance by h (s) with constant input force f_in (N), starting at time t.
  void step(double t, double h, double f_in) {
    double remaining = h;
    // Each pass either finishes the substep or ends at a velocity zero
    // crossing (v clamped to 0); a few passes are enough in practice.
    for (int pass = 0; pass < 8 && remaining > 0.0; ++pass) {
      if (std::fabs(s_.v) <= kRestVelocity) {
        s_.v = 0.0;
        // Net applied force excluding friction, at rest.
        double f_net = f_in - extra(t, s_.x, 0.0);
        if (loads_) f_net -= load(t, s_.x);
        if (two_mass_) f_net -= spring(s_);
        const double s = f_net >= 0.0 ? 1.0 : -1.0;
        if (std::fabs(f_net) <= static_band(t, s_.x, s)) {  // sticks
          if (two_mass_) {
            // The load keeps moving behind the spring while the motor sticks.
            locked_ = true;
            s_ = rk4(t, remaining, f_in, s_);
            s_.v = 0.0;
            locked_ = false;
          }
          return;
        }
        // Breaks away in the direction of the applied force; a break-away
        // against the previous sliding direction is a reversal.
        if (last_dir_ != 0.0 && s != last_dir_) since_reversal_ = 0.0;
        dir_ = s;
      } else {
        dir_ = s_.v > 0.0 ? 1.0 : -1.0;
      }
      last_dir_ = dir_;
      x_pass0_ = s_.x;

      const State s1 = rk4(t, remaining, f_in, s_);
      if (dir_ * s1.v > 0.0) {
        end_pass(s1);
        return;
      }
      // Velocity reached 0 within the step: locate the crossing time by
      // bracketed secant (Illinois) search on v(tau), then clamp v = 0.
      const double tau = find_zero_crossing(t, remaining, f_in, s1.v);
      State sc = s_;
      if (tau > 0.0) sc = rk4(t, tau, f_in, s_);
      sc.v = 0.0;
      end_pass(sc);
      t += tau;
      remaining -= tau;
    }
  }

 private:
  static constexpr double kRestVelocity = 1.0e-15;  ///< |v| treated as rest (m/s)

  void end_pass(const State& s) {
    if (e_.presliding_force_N > 0.0) since_reversal_ += dir_ * (s.x - x_pass0_);
    s_ = s;
  }

  double extra(double t, double x, double v) const { return extra_ ? extra_(t, x, v) : 0.0; }

  double load(double t, double x) const { return load_force(e_, t, x) + held_load_; }

  // Spring force on the load, = minus the force on the motor (N).
  double spring(const State& s) const { return k_ * (s.x - s.x2) + c_ * (s.v - s.v2); }

  double drift(double t) const {
    return e_.drift_fraction != 0.0 ? e_.drift_fraction * std::exp(-t / e_.drift_time_constant_s) : 0.0;
  }

  double position_friction(double x) const {
    return (e_.position_friction_N != 0.0 && x >= e_.position_friction_x_min_m && x <= e_.position_friction_x_max_m)
               ? e_.position_friction_N
               : 0.0;
  }

  // exp(-r/d) of the presliding term for distance r since the reversal.
  double presliding_decay(double r) const { return std::exp(-r / e_.presliding_distance_m); }

  // Friction while sliding in direction dir_ (continued through v = 0 for the
  // RK stages, like sliding_friction).
  double friction(double t, double x, double v) const {
    const DirectionFriction f = side(dir_, t);
    if (plain_friction_) return sliding_friction(f, dir_, v);
    const double r = v / f.stribeck_velocity_m_s;
    const double ed = drift(t);
    double F = dir_ * (f.coulomb_N * (1.0 + 0.3 * ed) + f.breakaway_N * std::exp(-r * r)) +
               f.viscous_Ns_m * (1.0 + ed) * v;
    F += e_.quadratic_c2_Ns2_m2 * v * std::fabs(v);
    F += dir_ * position_friction(x);
    if (e_.presliding_force_N > 0.0)
      F -= 2.0 * e_.presliding_force_N * dir_ * presliding_decay(since_reversal_ + dir_ * (x - x_pass0_));
    return F;
  }

  // Largest net force (N) the motor side withstands at rest when pushed in
  // direction s: the sliding friction at v -> 0 in that direction.
  double static_band(double t, double x, double s) const {
    const DirectionFriction f = side(s, t);
    if (plain_friction_) return f.coulomb_N + f.breakaway_N;
    double band = f.coulomb_N * (1.0 + 0.3 * drift(t)) + f.breakaway_N + position_friction(x);
    if (e_.presliding_force_N > 0.0) {
      const double r = (last_dir_ != 0.0 && s != last_dir_) ? 0.0 : since_reversal_;
      band -= 2.0 * e_.presliding_force_N * presliding_decay(r);
    }
    return std::max(0.0, band);
  }

  // Friction of direction s at time t, with the change in service from its time on.
  DirectionFriction side(double s, double t) const {
    DirectionFriction f = s > 0.0 ? d_.pos : d_.neg;
    if (change_.on() && t >= change_.time_s && (change_.direction == 0 || change_.direction * s > 0.0)) {
      f.coulomb_N *= 1.0 + change_.coulomb_fraction;
      f.viscous_Ns_m *= 1.0 + change_.viscous_fraction;
    }
    return f;
  }

  // Motor-side mass at time t (the change in service scales it).
  double mass1(double t) const {
    return change_.on() && t >= change_.time_s ? m1_ * (1.0 + change_.mass_fraction) : m1_;
  }

  // Time derivative of the state while sliding in direction dir_ (or with the
  // motor locked at rest).
  State deriv(double t, const State& s, double f_in) const {
    State d;
    if (!locked_) {
      double f = f_in - friction(t, s.x, s.v) - extra(t, s.x, s.v);
      if (loads_) f -= load(t, s.x);
      if (two_mass_) f -= spring(s);
      d.x = s.v;
      d.v = f / mass1(t);
    }
    if (two_mass_) {
      d.x2 = s.v2;
      d.v2 = spring(s) / m2_;
    }
    return d;
  }

  static State axpy(const State& s0, double a, const State& k) {
    State s;
    s.x = s0.x + a * k.x;
    s.v = s0.v + a * k.v;
    s.x2 = s0.x2 + a * k.x2;
    s.v2 = s0.v2 + a * k.v2;
    return s;
  }

  static double rk4_sum(double y0, double h, double k1, double k2, double k3, double k4) {
    return y0 + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }

  // Classical RK4 over h from s0.
  State rk4(double t, double h, double f_in, const State& s0) const {
    const State k1 = deriv(t, s0, f_in);
    const State k2 = deriv(t + 0.5 * h, axpy(s0, 0.5 * h, k1), f_in);
    const State k3 = deriv(t + 0.5 * h, axpy(s0, 0.5 * h, k2), f_in);
    const State k4 = deriv(t + h, axpy(s0, h, k3), f_in);
    State s1;
    s1.x = rk4_sum(s0.x, h, k1.x, k2.x, k3.x, k4.x);
    s1.v = rk4_sum(s0.v, h, k1.v, k2.v, k3.v, k4.v);
    if (two_mass_) {
      s1.x2 = rk4_sum(s0.x2, h, k1.x2, k2.x2, k3.x2, k4.x2);
      s1.v2 = rk4_sum(s0.v2, h, k1.v2, k2.v2, k3.v2, k4.v2);
    }
    return s1;
  }

  // Time tau in (0, h] at which dir_ * v(tau) reaches 0, given dir_*v(h) <= 0.
  double find_zero_crossing(double t, double h, double f_in, double v_h) const {
    double a = 0.0, fa = dir_ * s_.v;  // >= 0
    double b = h, fb = dir_ * v_h;     // <= 0
    if (fa <= 0.0) return 0.0;
    int side = 0;
    for (int it = 0; it < 60; ++it) {
      double c = (a * fb - b * fa) / (fb - fa);
      if (!(c > a && c < b)) c = 0.5 * (a + b);
      const double fc = dir_ * rk4(t, c, f_in, s_).v;
      if (fc > 0.0) {
        a = c;
        fa = fc;
        if (side == 1) fb *= 0.5;
        side = 1;
      } else {
        b = c;
        fb = fc;
        if (side == -1) fa *= 0.5;
        side = -1;
      }
      if (b - a <= 1e-12 * h || std::fabs(fc) <= 1e-18) break;
    }
    return b;  // the end where v has (just) reached zero
  }

  const DriveParams& d_;
  const Effects& e_;
  const ExtraForce& extra_;
  bool plain_friction_ = true;  ///< no friction effect: F_fric is the Stribeck model
  bool loads_ = false;          ///< some F_load term is on
  bool two_mass_ = false;       ///< compliant plant
  bool locked_ = false;         ///< motor held at rest while the load moves (inside rk4 only)
  double m1_ = 0.0, m2_ = 0.0;  ///< motor-side and load mass (kg)
  const ServiceChange& change_;
  double k_ = 0.0, c_ = 0.0;    ///< spring (N/m) and damper (N s/m)
  double held_load_ = 0.0;      ///< wandering disturbance of this servo period (N)
  State s_{};
  double dir_ = 1.0;       ///< sliding direction of the current pass
  double last_dir_ = 0.0;  ///< direction of the last sliding (0: never moved)
  double since_reversal_ = std::numeric_limits<double>::infinity();  ///< distance slid since the last reversal (m)
  double x_pass0_ = 0.0;   ///< motor position at the start of the current pass (m)
};

}  // namespace

bool effect_on(const Effects& e, Effect which) {
  switch (which) {
    case Effect::offset: return e.offset_N != 0.0;
    case Effect::position_ripple: return e.ripple_amplitude_N != 0.0;
    case Effect::position_friction: return e.position_friction_N != 0.0;
    case Effect::thermal_drift: return e.drift_fraction != 0.0;
    case Effect::quadratic_viscous: return e.quadratic_c2_Ns2_m2 != 0.0;
    case Effect::presliding_hysteresis: return e.presliding_force_N != 0.0;
    case Effect::compliance: return e.compliance_frequency_hz != 0.0;
    case Effect::delay: return e.delay_s != 0.0;
    case Effect::disturbance: return e.disturbance_amplitude_N != 0.0;
    case Effect::wander: return e.wander_force_N != 0.0;
  }
  return false;
}

std::vector<std::string> active_effects(const Effects& e) {
  std::vector<std::string> on;
  for (const EffectInfo& i : effect_table())
    if (effect_on(e, i.effect)) on.push_back(i.name);
  return on;
}

double load_force(const Effects& e, double t_s, double x_m) {
  double f = e.offset_N;
  if (e.ripple_amplitude_N != 0.0)
    f += e.ripple_amplitude_N * std::sin(2.0 * kPi * x_m / e.ripple_period_m + e.ripple_phase_rad);
  if (e.disturbance_amplitude_N != 0.0)
    f += e.disturbance_amplitude_N * std::sin(2.0 * kPi * e.disturbance_frequency_hz * t_s + e.disturbance_phase_rad);
  return f;
}


namespace {
/// The logged force of a zero-order-held command (ForceLog), one sample at a time.
class HeldForceLog {
 public:
  explicit HeldForceLog(ForceLog kind) : kind_(kind) {}

  /// Logged value for the command u_held applied over [t_k, t_k+1].
  double next(double u_held) {
    const double prev = has_u_ ? u_prev_ : u_held;
    has_u_ = true;
    u_prev_ = u_held;
    switch (kind_) {
      case ForceLog::held: return u_held;
      case ForceLog::instant: return 0.5 * (prev + u_held);
      case ForceLog::averaged: return prev;
    }
    return u_held;
  }

 private:
  ForceLog kind_;
  double u_prev_ = 0.0;
  bool has_u_ = false;
};
}  // namespace

// Cascade: v_cmd = v_ref + kp (x_ref - x_meas);
//          u = kv (v_cmd - v_meas) + I + m a_ref + u_extra, I += ki e dt,
// clamped to the force limit with conditional integration (anti-windup).
// The feed-forward m a_ref uses a_ref averaged over the hold interval,
// (v_ref(t_k+1) - v_ref(t_k)) / dt: the held force then delivers exactly the
// reference velocity change, also for ramps shorter than one period.
CascadeController::CascadeController(const ControllerParams& kc, double mass_kg)
    : kp_(kc.position_gain_1_s),
      kv_(2.0 * kPi * kc.velocity_bandwidth_hz * mass_kg),
      ki_(kv_ * 2.0 * kPi * kc.velocity_integral_hz),
      u_max_(kc.force_limit_N),
      m_ff_(kc.acceleration_feedforward ? mass_kg : 0.0),
      dt_(1.0 / kc.servo_rate_hz) {}

double CascadeController::command(const PathPoint& r, const PathPoint& r_next, double x_meas, double v_meas,
                                  double u_extra) {
  const double a_ff = (r_next.v_m_s - r.v_m_s) / dt_;
  const double v_cmd = r.v_m_s + kp_ * (r.x_m - x_meas);
  const double e = v_cmd - v_meas;
  const double u_raw = kv_ * e + integral_ + m_ff_ * a_ff + u_extra;
  const double u = std::clamp(u_raw, -u_max_, u_max_);
  const bool winding = (u_raw > u_max_ && e > 0.0) || (u_raw < -u_max_ && e < 0.0);
  if (!winding) integral_ += ki_ * e * dt_;
  return u;
}

struct ServoAxis::Impl {
  // The plant keeps references into cfg: built from the member, not the argument.
  explicit Impl(const SimConfig& c) : cfg(c), plant(cfg.drive, cfg.effects, cfg.extra_force, cfg.change), control(cfg.controller, cfg.drive.mass_kg) {}
  SimConfig cfg;
  Plant plant;
  CascadeController control;
  double x_meas_prev = 0.0;
  bool first = true;
};

ServoAxis::ServoAxis(const SimConfig& cfg) : impl_((validate(cfg), std::make_unique<Impl>(cfg))) {}
ServoAxis::~ServoAxis() = default;
ServoAxis::ServoAxis(ServoAxis&&) noexcept = default;

TraceSample ServoAxis::step(double t, const PathPoint& r, const PathPoint& r_next, double u_extra) {
  Impl& a = *impl_;
  const double dt = 1.0 / a.cfg.controller.servo_rate_hz;
  const double x_meas = quantise(a.plant.x(), a.cfg.sensors.encoder_resolution_m);
  const double v_meas = a.first ? 0.0 : (x_meas - a.x_meas_prev) / dt;
  a.first = false;
  a.x_meas_prev = x_meas;
  const double u = a.control.command(r, r_next, x_meas, v_meas, u_extra);
  const double h = dt / a.cfg.plant_substeps;
  for (int j = 0; j < a.cfg.plant_substeps; ++j) a.plant.step(t + j * h, h, u);
  return TraceSample{t, x_meas, v_meas, u};
}

double ServoAxis::position_m() const { return impl_->plant.x(); }

const char* plant_name(PlantKind p) { return p == PlantKind::open_loop ? "open" : "closed"; }

PlantKind parse_plant(const std::string& s) {
  for (PlantKind p : {PlantKind::closed_loop, PlantKind::open_loop})
    if (s == plant_name(p)) return p;
  throw std::invalid_argument("--plant must be closed or open, not '" + s + "'");
}

namespace {
/// The recorded force of a drive whose log lags the applied force by
/// delay_s: u_rec[k] = u(t_k - delay), linear between the applied samples
/// (history kept only when a delay is set).
class DelayedForceRecord {
 public:
  DelayedForceRecord(double delay_s, double dt, std::size_t n_samples) : delay_samples_(delay_s / dt), on_(delay_s > 0.0) {
    if (on_) applied_.reserve(n_samples);
  }
  /// The recorded value at sample k, given the force u applied from t_k.
  double recorded(double u, std::size_t k) {
    if (!on_) return u;
    applied_.push_back(u);
    const double pos = static_cast<double>(k) - delay_samples_;  // fractional sample index
    if (pos <= 0.0) return applied_.front();
    const auto i0 = static_cast<std::size_t>(std::floor(pos));
    const double alpha = pos - static_cast<double>(i0);
    return i0 + 1 < applied_.size() ? (1.0 - alpha) * applied_[i0] + alpha * applied_[i0 + 1] : applied_[i0];
  }

 private:
  double delay_samples_;
  bool on_;
  std::vector<double> applied_;
};

/// Wandering load force: Ornstein-Uhlenbeck, w <- a w + sqrt(1 - a^2) s n,
/// a = exp(-dt / tau), stationary from the start; its own random stream.
class WanderingLoad {
 public:
  WanderingLoad(const Effects& fx, double dt, std::uint64_t seed) : rng_(seed ^ 0x9E3779B97F4A7C15ull), on_(fx.wander_force_N > 0.0) {
    a_ = on_ ? std::exp(-dt / fx.wander_time_constant_s) : 0.0;
    b_ = fx.wander_force_N * std::sqrt(std::max(0.0, 1.0 - a_ * a_));
    w_ = on_ ? fx.wander_force_N * normal_(rng_) : 0.0;
  }
  bool on() const { return on_; }
  /// The load over this servo period; moves on to the next.
  double next() {
    const double w = w_;
    w_ = a_ * w_ + b_ * normal_(rng_);
    return w;
  }

 private:
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};  // own object: normal_distribution caches draws
  bool on_;
  double a_ = 0.0, b_ = 0.0, w_ = 0.0;
};

Trace simulator_trace(std::size_t n_samples) {
  Trace trace;
  trace.source = "simulator";
  trace.has_position = true;
  trace.has_velocity = true;
  trace.samples.reserve(n_samples);
  return trace;
}
}  // namespace

Trace simulate(const SimConfig& cfg, const std::function<void(double)>& progress) {
  validate(cfg);
  if (cfg.plant == PlantKind::open_loop) return simulate_open_loop(cfg, progress);

  const ControllerParams& kc = cfg.controller;
  const double dt = 1.0 / kc.servo_rate_hz;
  const double h = dt / cfg.plant_substeps;
  // Samples at t_k = k dt for k dt <= duration (with a tolerance of 1e-9 dt).
  const auto n_samples = static_cast<std::size_t>(std::floor(cfg.motion.duration_s / dt + 1e-9)) + 1;

  CascadeController control(kc, cfg.drive.mass_kg);
  std::mt19937_64 rng(cfg.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  MotionPath path(cfg.motion, cfg.seed);
  Plant plant(cfg.drive, cfg.effects, cfg.extra_force, cfg.change);
  DelayedForceRecord delayed(cfg.effects.delay_s, dt, n_samples);
  WanderingLoad wander(cfg.effects, dt, cfg.seed);
  HeldForceLog force_log(cfg.logging.force);
  LoggedVelocity velocity_log(cfg.logging, dt);
  Trace trace = simulator_trace(n_samples);

  const std::size_t progress_every = std::max<std::size_t>(1, (n_samples + 99) / 100);
  double x_meas_prev = 0.0;
  PathPoint r_next = path.at(0.0);  // reference at t_k, carried from tick to tick
  for (std::size_t k = 0; k < n_samples; ++k) {
    const double t = static_cast<double>(k) * dt;
    // Encoder and drive velocity: v_meas = (x_meas[k] - x_meas[k-1]) / dt.
    const double x_meas = quantise(plant.x(), cfg.sensors.encoder_resolution_m);
    const double v_meas = k == 0 ? 0.0 : (x_meas - x_meas_prev) / dt;
    x_meas_prev = x_meas;

    const PathPoint r = r_next;
    r_next = path.at(static_cast<double>(k + 1) * dt);
    const double u = control.command(r, r_next, x_meas, v_meas, 0.0);
    // Noise draws in a fixed order so a seed gives one trace.
    const double w_meas = normal(rng) * cfg.sensors.force_noise_N;
    const double w_proc = normal(rng) * cfg.sensors.force_process_noise_N;
    const double u_rec = delayed.recorded(u, k);
    trace.samples.push_back(TraceSample{t, x_meas, velocity_log.next(v_meas), force_log.next(u_rec) + w_meas});

    // Plant over [t_k, t_k + dt) with u held.
    if (k + 1 < n_samples) {
      if (wander.on()) plant.set_held_load(wander.next());
      for (int j = 0; j < cfg.plant_substeps; ++j) plant.step(t + j * h, h, u + w_proc);
    }
    if (progress && (k % progress_every == 0)) progress(static_cast<double>(k) / static_cast<double>(n_samples));
  }
  if (progress) progress(1.0);
  return trace;
}

}  // namespace feedid::host
