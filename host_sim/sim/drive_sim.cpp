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

#include <iomanip>

#include "model/constants.hpp"

#include "open_loop_plant.hpp"
#include "plant.hpp"

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

/// The first thing wrong with a configuration, as "<field> (<unit>) must
/// be <condition>, got <v>" (the host's one error form, io/outcome.hpp).
struct ConfigCheck {
  std::string error;
  void reject(const std::string& field, const std::string& unit, const std::string& condition, double value) {
    if (!error.empty()) return;
    std::ostringstream os;
    os << field << " (" << unit << ") must be " << condition << ", got " << value;
    error = os.str();
  }
  void reject(const std::string& why) {
    if (error.empty()) error = why;
  }
  void require_positive(double v, const char* field, const char* unit) {
    if (!(std::isfinite(v) && v > 0.0)) reject(field, unit, "finite and > 0", v);
  }
  void require_non_negative(double v, const char* field, const char* unit) {
    if (!(std::isfinite(v) && v >= 0.0)) reject(field, unit, "finite and >= 0", v);
  }
  void require_finite(double v, const char* field, const char* unit) {
    if (!std::isfinite(v)) reject(field, unit, "finite", v);
  }
};

void validate_friction(const DirectionFriction& f, const std::string& side, ConfigCheck& ck) {
  ck.require_non_negative(f.viscous_Ns_m, ("drive." + side + ".viscous_Ns_m").c_str(), "N s/m");
  ck.require_non_negative(f.coulomb_N, ("drive." + side + ".coulomb_N").c_str(), "N");
  ck.require_non_negative(f.breakaway_N, ("drive." + side + ".breakaway_N").c_str(), "N");
  ck.require_positive(f.stribeck_velocity_m_s, ("drive." + side + ".stribeck_velocity_m_s").c_str(),
                   "m/s");
}

void validate_effects(const SimConfig& c, ConfigCheck& ck) {
  const Effects& e = c.effects;
  ck.require_finite(e.load.offset_N, "effects.load.offset_N", "N");
  ck.require_finite(e.load.gravity_N, "effects.load.gravity_N", "N");
  ck.require_finite(e.load.gravity_angle0_rad, "effects.load.gravity_angle0_rad", "rad");

  ck.require_finite(e.ripple_amplitude_N, "effects.ripple_amplitude_N", "N");
  ck.require_finite(e.ripple_phase_rad, "effects.ripple_phase_rad", "rad");
  if (e.ripple_amplitude_N != 0.0) ck.require_positive(e.ripple_period_m, "effects.ripple_period_m", "m");

  ck.require_finite(e.position_friction_N, "effects.position_friction_N", "N");
  if (e.position_friction_N != 0.0) {
    const double floor = -std::min(c.drive.pos.coulomb_N, c.drive.neg.coulomb_N);
    if (e.position_friction_N < floor)
      ck.reject("effects.position_friction_N", "N", ">= -min(Fc+, Fc-) (friction stays >= 0)", e.position_friction_N);
    ck.require_finite(e.position_friction_x_min_m, "effects.position_friction_x_min_m", "m");
    ck.require_finite(e.position_friction_x_max_m, "effects.position_friction_x_max_m", "m");
    if (!(e.position_friction_x_max_m > e.position_friction_x_min_m))
      ck.reject("effects.position_friction_x_max_m", "m", "> effects.position_friction_x_min_m",
             e.position_friction_x_max_m);
  }

  ck.require_finite(e.drift_fraction, "effects.drift_fraction", "-");
  if (e.drift_fraction != 0.0) {
    if (!(e.drift_fraction > -1.0)) ck.reject("effects.drift_fraction", "-", "> -1", e.drift_fraction);
    ck.require_positive(e.drift_time_constant_s, "effects.drift_time_constant_s", "s");
  }

  ck.require_non_negative(e.quadratic_c2_Ns2_m2, "effects.quadratic_c2_Ns2_m2", "N s^2/m^2");

  ck.require_non_negative(e.presliding_force_N, "effects.presliding_force_N", "N");
  if (e.presliding_force_N > 0.0) ck.require_positive(e.presliding_distance_m, "effects.presliding_distance_m", "m");

  ck.require_non_negative(e.compliance_frequency_hz, "effects.compliance_frequency_hz", "Hz");
  if (e.compliance_frequency_hz > 0.0) {
    const double mu = e.compliance_mass_fraction;
    if (!(std::isfinite(mu) && mu > 0.0 && mu < 1.0))
      ck.reject("effects.compliance_mass_fraction", "-", "in (0, 1)", mu);
    ck.require_non_negative(e.compliance_damping_ratio, "effects.compliance_damping_ratio", "-");
    // RK4 must resolve the resonance: omega * h <= 0.5 with h = dt / substeps.
    const double f_max = 0.5 * c.controller.servo_rate_hz * c.plant_substeps / (2.0 * kPi);
    if (e.compliance_frequency_hz > f_max)
      ck.reject("effects.compliance_frequency_hz", "Hz",
             "<= servo_rate * plant_substeps / (4 pi) (integration accuracy)", e.compliance_frequency_hz);
  }

  ck.require_non_negative(e.delay_s, "effects.delay_s", "s");
  if (e.delay_s > c.motion.duration_s) ck.reject("effects.delay_s", "s", "<= motion.duration_s", e.delay_s);

  ck.require_finite(e.disturbance_amplitude_N, "effects.disturbance_amplitude_N", "N");
  ck.require_finite(e.disturbance_phase_rad, "effects.disturbance_phase_rad", "rad");
  if (e.disturbance_amplitude_N != 0.0)
    ck.require_positive(e.disturbance_frequency_hz, "effects.disturbance_frequency_hz", "Hz");

  ck.require_non_negative(e.wander_force_N, "effects.wander_force_N", "N");
  if (e.wander_force_N > 0.0) ck.require_positive(e.wander_time_constant_s, "effects.wander_time_constant_s", "s");
}

void validate_change(const SimConfig& c, ConfigCheck& ck) {
  const ServiceChange& ch = c.change;
  if (ch.warms_up() && c.plant != PlantKind::closed_loop)
    ck.reject("--warmup-drop: a warm-up is simulated by the closed-loop plant only");
  if (!ch.on()) return;
  if (c.plant != PlantKind::closed_loop)
    ck.reject("--change-time: a change in service is simulated by the closed-loop plant only");
  for (const auto& [v, name] : {std::pair<double, const char*>{ch.coulomb_fraction, "--change-coulomb-fraction"},
                                {ch.viscous_fraction, "--change-viscous-fraction"},
                                {ch.mass_fraction, "--change-mass-fraction"}})
    if (!(v > -1.0) || !std::isfinite(v)) ck.reject(std::string(name) + " must be > -1 (a fraction)");
  if (ch.direction < -1 || ch.direction > 1) ck.reject("--change-direction must be pos, neg or both");
}

void validate(const SimConfig& c, ConfigCheck& ck) {
  validate_change(c, ck);
  ck.require_positive(c.drive.mass_kg, "drive.mass_kg", "kg");
  validate_friction(c.drive.pos, "pos", ck);
  validate_friction(c.drive.neg, "neg", ck);

  const ControllerParams& k = c.controller;
  ck.require_positive(k.servo_rate_hz, "controller.servo_rate_hz", "Hz");
  ck.require_non_negative(k.position_gain_1_s, "controller.position_gain_1_s", "1/s");
  ck.require_positive(k.velocity_bandwidth_hz, "controller.velocity_bandwidth_hz", "Hz");
  ck.require_non_negative(k.velocity_integral_hz, "controller.velocity_integral_hz", "Hz");
  ck.require_positive(k.force_limit_N, "controller.force_limit_N", "N");

  const MotionParams& m = c.motion;
  ck.require_positive(m.slowest_speed_m_s, "motion.slowest_speed_m_s", "m/s");
  ck.require_positive(m.fastest_speed_m_s, "motion.fastest_speed_m_s", "m/s");
  if (m.slowest_speed_m_s > m.fastest_speed_m_s)
    ck.reject("motion.slowest_speed_m_s", "m/s", "<= motion.fastest_speed_m_s",
           m.slowest_speed_m_s);
  if (m.speed_levels < 1) ck.reject("motion.speed_levels", "count", ">= 1", m.speed_levels);
  ck.require_positive(m.acceleration_m_s2, "motion.acceleration_m_s2", "m/s^2");
  ck.require_non_negative(m.cruise_time_s, "motion.cruise_time_s", "s");
  ck.require_positive(m.max_travel_m, "motion.max_travel_m", "m");
  ck.require_non_negative(m.dwell_s, "motion.dwell_s", "s");
  ck.require_positive(m.duration_s, "motion.duration_s", "s");

  const SensorParams& s = c.sensors;
  if (std::isnan(s.encoder_resolution_m))
    ck.reject("sensors.encoder_resolution_m", "m", "a number (<= 0 disables quantisation)",
           s.encoder_resolution_m);
  ck.require_non_negative(s.force_noise_N, "sensors.force_noise_N", "N");
  ck.require_non_negative(s.force_process_noise_N, "sensors.force_process_noise_N", "N");

  if (c.plant_substeps < 1) ck.reject("plant_substeps", "count", ">= 1", c.plant_substeps);
  if (c.logging.velocity_average_samples < 1)
    ck.reject("logging.velocity_average_samples", "count", ">= 1", c.logging.velocity_average_samples);
  ck.require_positive(c.logging.velocity_time_constant_s, "logging.velocity_time_constant_s", "s");

  validate_effects(c, ck);

  // Keep the sample count sane (the trace is held in memory).
  const double n = m.duration_s * k.servo_rate_hz;
  if (n > 5.0e8)
    ck.reject("motion.duration_s", "s", "such that duration * servo_rate <= 5e8 samples",
           m.duration_s);
  // Last, and only for a configuration otherwise sound: it lays out the
  // whole program, which the checks above keep to a size that fits.
  if (ck.error.empty() && MotionPath(c.motion, c.seed).pieces().empty())
    ck.reject("motion: the program produced no motion (check the speeds and travel)");
}

/// A configuration sim_config_error refuses is a caller's bug here: every
/// command checks it first and says why.
void require_valid(const SimConfig& c) {
  const std::string why = sim_config_error(c);
  if (!why.empty()) throw std::invalid_argument(why);
}

}  // namespace

std::string sim_config_error(const SimConfig& c) {
  ConfigCheck ck;
  validate(c, ck);
  return ck.error;
}

std::string saturated_command(const Trace& t, const SimConfig& c) {
  const double limit = c.controller.force_limit_N;
  std::size_t at_limit = 0;
  for (const TraceSample& s : t.samples)
    if (std::fabs(s.u_N) >= 0.99 * limit) ++at_limit;
  if (t.samples.empty() || 100 * at_limit <= t.samples.size()) return "";
  std::ostringstream o;
  o << "the simulated command sat at its limit (+-" << limit << " N) on " << std::setprecision(3)
    << 100.0 * static_cast<double>(at_limit) / static_cast<double>(t.samples.size()) << std::setprecision(6)
    << " % of the samples: at " << c.controller.servo_rate_hz << " Hz with a " << c.controller.velocity_bandwidth_hz << " Hz velocity loop and a "
    << c.sensors.encoder_resolution_m << " m encoder the loop is not stable, or the motion asks for more force than "
    << "the drive has; the trace is no drive's (raise --rate, lower --velocity-bandwidth or --accel, or refine --encoder)";
  return o.str();
}

bool effect_on(const Effects& e, Effect which) {
  switch (which) {
    case Effect::offset: return e.load.offset_N != 0.0;
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
  double f = e.load.at(x_m);
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
  DrivePlant plant;
  CascadeController control;
  double x_meas_prev = 0.0;
  bool first = true;
};

ServoAxis::ServoAxis(const SimConfig& cfg) : impl_((require_valid(cfg), std::make_unique<Impl>(cfg))) {}
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

Outcome<PlantKind> parse_plant(const std::string& s) {
  for (PlantKind p : {PlantKind::closed_loop, PlantKind::open_loop})
    if (s == plant_name(p)) return {p, ""};
  return refused<PlantKind>("--plant must be closed or open, not '" + s + "'");
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
  require_valid(cfg);
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
  DrivePlant plant(cfg.drive, cfg.effects, cfg.extra_force, cfg.change);
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
