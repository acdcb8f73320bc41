// Closed-loop feed-drive simulator (see drive_sim.hpp). Host only.
//
// Structure of one servo period [t_k, t_k + dt):
//   1. sample the encoder at t_k, form the drive's velocity by position
//      difference, evaluate the reference, run the P / PI cascade -> u_k;
//   2. record (t_k, x_meas, v_meas, u_k + measurement noise);
//   3. hold u_k (zero-order hold) and integrate the plant over the period in
//      `plant_substeps` RK4 substeps with Karnopp-style stick/slip.
#include "drive_sim.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace feedid::host {

namespace {

constexpr double kPi = 3.14159265358979323846;

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

void validate(const SimConfig& c) {
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

  // Keep the sample count sane (the trace is held in memory).
  const double n = m.duration_s * k.servo_rate_hz;
  if (n > 5.0e8)
    reject("motion.duration_s", "s", "such that duration * servo_rate <= 5e8 samples",
           m.duration_s);
}

// ---------------------------------------------------------------------------
// Friction of one direction, continued analytically through v = 0.
//   s = +1: F+(v) = +(Fc+ + Fs+ exp(-(v/vs+)^2)) + sigma+ v
//   s = -1: F-(v) = -(Fc- + Fs- exp(-(v/vs-)^2)) + sigma- v
// While sliding in direction s the plant uses F_s even for intermediate RK
// stages that cross zero; the crossing itself is resolved separately.
// ---------------------------------------------------------------------------
double branch_friction(const DirectionFriction& f, double s, double v) {
  const double r = v / f.stribeck_velocity_m_s;
  return s * (f.coulomb_N + f.breakaway_N * std::exp(-r * r)) + f.viscous_Ns_m * v;
}

// ---------------------------------------------------------------------------
// Reciprocating reference: a list of strokes, each a trapezoid (or triangle)
// followed by a dwell. Stroke j of level i: direction + for even j, - for odd.
// ---------------------------------------------------------------------------
struct Stroke {
  double dir = 1.0;    ///< +1 or -1
  double v_peak = 0;   ///< peak speed (m/s)
  double t_acc = 0;    ///< acceleration time = decel time (s)
  double t_cruise = 0; ///< cruise time (s)
  double d_acc = 0;    ///< distance while accelerating (m)
  double d_cruise = 0; ///< distance while cruising (m)
  double t_total = 0;  ///< 2*t_acc + t_cruise + dwell (s)
};

struct Reference {
  double x = 0.0;  ///< m
  double v = 0.0;  ///< m/s
};

class ReferenceGenerator {
 public:
  explicit ReferenceGenerator(const MotionParams& m) : accel_(m.acceleration_m_s2), dwell_(m.dwell_s) {
    const int n = m.speed_levels;
    std::vector<double> speeds;
    if (n == 1) {
      speeds.push_back(m.fastest_speed_m_s);
    } else {
      // Log-spaced peak speeds: V_i = V_slow * (V_fast/V_slow)^(i/(n-1)).
      const double ratio = m.fastest_speed_m_s / m.slowest_speed_m_s;
      for (int i = 0; i < n; ++i)
        speeds.push_back(m.slowest_speed_m_s * std::pow(ratio, double(i) / double(n - 1)));
      speeds.back() = m.fastest_speed_m_s;
    }
    for (double V : speeds) {
      Stroke s = make_stroke(V, m);
      s.dir = 1.0;
      strokes_.push_back(s);
      s.dir = -1.0;
      strokes_.push_back(s);
    }
  }

  /// Reference at time t (s); t must not decrease between calls.
  Reference at(double t) {
    // Advance the current stroke while t lies beyond it. Each positive stroke
    // is followed by its negative twin, so every stroke starts at x = 0 or +L.
    while (t >= stroke_start_ + strokes_[idx_].t_total) {
      const Stroke& s = strokes_[idx_];
      x_start_ += s.dir * (2.0 * s.d_acc + s.d_cruise);
      stroke_start_ += s.t_total;
      idx_ = (idx_ + 1) % strokes_.size();
      if (idx_ == 0) x_start_ = 0.0;  // a full cycle returns to 0 exactly
    }
    const Stroke& s = strokes_[idx_];
    const double tau = t - stroke_start_;
    const double A = accel_;
    Reference r;
    if (tau < s.t_acc) {
      // x = x0 + dir * A tau^2 / 2
      r.v = s.dir * A * tau;
      r.x = x_start_ + s.dir * 0.5 * A * tau * tau;
    } else if (tau < s.t_acc + s.t_cruise) {
      // x = x0 + dir * (d_acc + V (tau - t_acc))
      r.v = s.dir * s.v_peak;
      r.x = x_start_ + s.dir * (s.d_acc + s.v_peak * (tau - s.t_acc));
    } else if (tau < 2.0 * s.t_acc + s.t_cruise) {
      // x = x0 + dir * (d_acc + d_cruise + V tau2 - A tau2^2 / 2)
      const double tau2 = tau - s.t_acc - s.t_cruise;
      r.v = s.dir * std::max(0.0, s.v_peak - A * tau2);
      r.x = x_start_ + s.dir * (s.d_acc + s.d_cruise + s.v_peak * tau2 - 0.5 * A * tau2 * tau2);
    } else {
      r.v = 0.0;
      r.x = x_start_ + s.dir * (2.0 * s.d_acc + s.d_cruise);
    }
    return r;
  }

 private:
  Stroke make_stroke(double V, const MotionParams& m) const {
    Stroke s;
    const double A = m.acceleration_m_s2;
    const double L = m.max_travel_m;
    // Trapezoid: d_acc = V^2/(2A) per ramp, cruise V*T; shorten the cruise to
    // fit L, and if the two ramps alone exceed L make it a triangle with
    // V = sqrt(A L).
    double d_acc = V * V / (2.0 * A);
    double d_cruise = V * m.cruise_time_s;
    if (2.0 * d_acc + d_cruise > L) {
      d_cruise = L - 2.0 * d_acc;
      if (d_cruise < 0.0) {
        V = std::sqrt(A * L);
        d_acc = 0.5 * L;
        d_cruise = 0.0;
      }
    }
    s.v_peak = V;
    s.t_acc = V / A;
    s.d_acc = d_acc;
    s.d_cruise = d_cruise;
    s.t_cruise = d_cruise / V;
    s.t_total = 2.0 * s.t_acc + s.t_cruise + dwell_;
    return s;
  }

  double accel_;
  double dwell_;
  std::vector<Stroke> strokes_;
  std::size_t idx_ = 0;
  double stroke_start_ = 0.0;  ///< time the current stroke began (s)
  double x_start_ = 0.0;       ///< reference position at its start (m)
};

// ---------------------------------------------------------------------------
// Plant: m dv/dt = f_in - F(v) - extra(t, x, v), dx/dt = v, with f_in = u + w
// held over the servo period. Karnopp stick/slip: at rest the body stays at
// rest while |f_in - extra(t, x, 0)| <= Fc + Fs of the direction it pushes.
// ---------------------------------------------------------------------------
class Plant {
 public:
  Plant(const DriveParams& d, const ExtraForce& extra) : d_(d), extra_(extra) {}

  double x() const { return x_; }
  double v() const { return v_; }

  /// Advance by h (s) with constant input force f_in (N), starting at time t.
  void step(double t, double h, double f_in) {
    double remaining = h;
    // Each pass either finishes the substep or ends at a velocity zero
    // crossing (v clamped to 0); a few passes are enough in practice.
    for (int pass = 0; pass < 8 && remaining > 0.0; ++pass) {
      if (std::fabs(v_) <= kRestVelocity) {
        v_ = 0.0;
        // Net applied force excluding friction, at rest.
        const double f_net = f_in - extra(t, x_, 0.0);
        const double s = f_net >= 0.0 ? 1.0 : -1.0;
        const DirectionFriction& f = s > 0.0 ? d_.pos : d_.neg;
        if (std::fabs(f_net) <= f.coulomb_N + f.breakaway_N) return;  // sticks
        dir_ = s;  // breaks away in the direction of the applied force
      } else {
        dir_ = v_ > 0.0 ? 1.0 : -1.0;
      }

      double x1 = x_, v1 = v_;
      rk4(t, remaining, f_in, x_, v_, x1, v1);
      if (dir_ * v1 > 0.0) {
        x_ = x1;
        v_ = v1;
        return;
      }
      // Velocity reached 0 within the step: locate the crossing time by
      // bracketed secant (Illinois) search on v(tau), then clamp v = 0.
      const double tau = find_zero_crossing(t, remaining, f_in, v1);
      double xc = x_, vc = v_;
      if (tau > 0.0) rk4(t, tau, f_in, x_, v_, xc, vc);
      x_ = xc;
      v_ = 0.0;
      t += tau;
      remaining -= tau;
    }
  }

 private:
  static constexpr double kRestVelocity = 1.0e-15;  ///< |v| treated as rest (m/s)

  double extra(double t, double x, double v) const { return extra_ ? extra_(t, x, v) : 0.0; }

  // Acceleration while sliding in direction dir_ (m/s^2).
  double accel(double t, double x, double v, double f_in) const {
    const DirectionFriction& f = dir_ > 0.0 ? d_.pos : d_.neg;
    return (f_in - branch_friction(f, dir_, v) - extra(t, x, v)) / d_.mass_kg;
  }

  // Classical RK4 on (x, v) over h from (x0, v0).
  void rk4(double t, double h, double f_in, double x0, double v0, double& x1, double& v1) const {
    const double k1v = accel(t, x0, v0, f_in);
    const double k1x = v0;
    const double k2v = accel(t + 0.5 * h, x0 + 0.5 * h * k1x, v0 + 0.5 * h * k1v, f_in);
    const double k2x = v0 + 0.5 * h * k1v;
    const double k3v = accel(t + 0.5 * h, x0 + 0.5 * h * k2x, v0 + 0.5 * h * k2v, f_in);
    const double k3x = v0 + 0.5 * h * k2v;
    const double k4v = accel(t + h, x0 + h * k3x, v0 + h * k3v, f_in);
    const double k4x = v0 + h * k3v;
    x1 = x0 + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    v1 = v0 + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
  }

  // Time tau in (0, h] at which dir_ * v(tau) reaches 0, given dir_*v(h) <= 0.
  double find_zero_crossing(double t, double h, double f_in, double v_h) const {
    double a = 0.0, fa = dir_ * v_;   // >= 0
    double b = h, fb = dir_ * v_h;    // <= 0
    if (fa <= 0.0) return 0.0;
    int side = 0;
    for (int it = 0; it < 60; ++it) {
      double c = (a * fb - b * fa) / (fb - fa);
      if (!(c > a && c < b)) c = 0.5 * (a + b);
      double xc, vc;
      rk4(t, c, f_in, x_, v_, xc, vc);
      const double fc = dir_ * vc;
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
  const ExtraForce& extra_;
  double x_ = 0.0;    ///< true position (m)
  double v_ = 0.0;    ///< true velocity (m/s)
  double dir_ = 1.0;  ///< sliding direction of the current pass
};

double quantise(double x, double q) { return q > 0.0 ? std::round(x / q) * q : x; }

}  // namespace

double stribeck_friction(const DriveParams& p, double v_m_s) {
  if (v_m_s > 0.0) return branch_friction(p.pos, 1.0, v_m_s);
  if (v_m_s < 0.0) return branch_friction(p.neg, -1.0, v_m_s);
  return 0.0;
}

Trace simulate(const SimConfig& cfg, const std::function<void(double)>& progress) {
  validate(cfg);

  const ControllerParams& kc = cfg.controller;
  const double m = cfg.drive.mass_kg;
  const double dt = 1.0 / kc.servo_rate_hz;
  const double h = dt / cfg.plant_substeps;
  const double q = cfg.sensors.encoder_resolution_m;

  // Velocity PI: kv = 2 pi f_bw m (N s/m), ki = kv 2 pi f_i (N/m).
  const double kp = kc.position_gain_1_s;
  const double kv = 2.0 * kPi * kc.velocity_bandwidth_hz * m;
  const double ki = kv * 2.0 * kPi * kc.velocity_integral_hz;
  const double u_max = kc.force_limit_N;

  // Samples at t_k = k dt for k dt <= duration (with a tolerance of 1e-9 dt).
  const auto n_samples =
      static_cast<std::size_t>(std::floor(cfg.motion.duration_s / dt + 1e-9)) + 1;

  std::mt19937_64 rng(cfg.seed);
  std::normal_distribution<double> normal(0.0, 1.0);

  ReferenceGenerator ref_gen(cfg.motion);
  Plant plant(cfg.drive, cfg.extra_force);

  Trace trace;
  trace.source = "simulator";
  trace.has_position = true;
  trace.has_velocity = true;
  trace.samples.reserve(n_samples);

  const std::size_t progress_every = std::max<std::size_t>(1, (n_samples + 99) / 100);
  double integral = 0.0;  // PI integrator state (N)
  double x_meas_prev = 0.0;
  Reference r_next = ref_gen.at(0.0);  // reference at t_k, carried from tick to tick

  for (std::size_t k = 0; k < n_samples; ++k) {
    const double t = static_cast<double>(k) * dt;

    // Encoder and drive velocity: v_meas = (x_meas[k] - x_meas[k-1]) / dt.
    const double x_meas = quantise(plant.x(), q);
    const double v_meas = k == 0 ? 0.0 : (x_meas - x_meas_prev) / dt;
    x_meas_prev = x_meas;

    // Cascade: v_cmd = v_ref + kp (x_ref - x_meas);
    //          u = kv (v_cmd - v_meas) + I + m a_ref, I += ki e dt.
    // Feedforward m * a_ref with a_ref averaged over the hold interval,
    // (v_ref(t_k+1) - v_ref(t_k)) / dt: the held force then delivers exactly
    // the reference velocity change, also for ramps shorter than one period.
    const Reference r = r_next;
    r_next = ref_gen.at(static_cast<double>(k + 1) * dt);
    const double a_ff = (r_next.v - r.v) / dt;
    const double v_cmd = r.v + kp * (r.x - x_meas);
    const double e = v_cmd - v_meas;
    const double ff = kc.acceleration_feedforward ? m * a_ff : 0.0;
    const double u_raw = kv * e + integral + ff;
    const double u = std::clamp(u_raw, -u_max, u_max);
    // Anti-windup (conditional integration): freeze the integrator while
    // saturated and the error would drive further into saturation.
    const bool winding = (u_raw > u_max && e > 0.0) || (u_raw < -u_max && e < 0.0);
    if (!winding) integral += ki * e * dt;

    // Noise draws in a fixed order so a seed gives one trace.
    const double w_meas = normal(rng) * cfg.sensors.force_noise_N;
    const double w_proc = normal(rng) * cfg.sensors.force_process_noise_N;

    trace.samples.push_back(TraceSample{t, x_meas, v_meas, u + w_meas});

    // Plant over [t_k, t_k + dt) with u held.
    if (k + 1 < n_samples) {
      const double f_in = u + w_proc;
      for (int j = 0; j < cfg.plant_substeps; ++j) plant.step(t + j * h, h, f_in);
    }

    if (progress && (k % progress_every == 0))
      progress(static_cast<double>(k) / static_cast<double>(n_samples));
  }
  if (progress) progress(1.0);
  return trace;
}

}  // namespace feedid::host
