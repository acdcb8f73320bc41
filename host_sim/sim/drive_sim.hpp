// Closed-loop feed-drive simulator: a rigid body with direction-dependent
// Stribeck friction and physical stick/slip, driven by a cascaded P (position)
// / PI (velocity) controller at the servo rate, following a reciprocating
// reference whose peak speeds are spread from very slow to fast. Measured
// signals carry encoder quantisation, velocity from position differences and
// force noise. Deterministic for a given seed. Host only.
#pragma once
#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "drive_log.hpp"
#include "motion_path.hpp"
#include "io/trace.hpp"
#include "model/drive_model.hpp"
#include "model/effects.hpp"

namespace feedid::host {

struct ControllerParams {
  double servo_rate_hz = 2000.0;      ///< controller and sampling rate (Hz)
  double position_gain_1_s = 60.0;    ///< kp: velocity command per position error (1/s)
  double velocity_bandwidth_hz = 40.0;///< velocity loop crossover; kv = 2*pi*bw*mass (N s/m)
  double velocity_integral_hz = 8.0;  ///< PI zero (Hz): ki = kv*2*pi*f (N/m)
  double force_limit_N = 5000.0;      ///< actuator saturation (N)
  bool acceleration_feedforward = true;///< add mass*a_ref (mass as the drive believes it)
};


struct SensorParams {
  double encoder_resolution_m = 1.0e-8;  ///< position quantum (m)
  double force_noise_N = 0.5;            ///< std of white noise on the recorded force (N)
  double force_process_noise_N = 0.0;    ///< std of white disturbance force acting on the plant (N)
};

/// Extra force acting on the plant: a generic hook beside `Effects`. Returns
/// the force (N) that adds to friction (on the motor side when the plant is
/// compliant); it opposes motion when positive for positive velocity, like
/// friction, and acts at rest too. Empty: none.
using ExtraForce = std::function<double(double t_s, double x_m, double v_m_s)>;

/// How fast an ExtraForce, opaque to the plant, changes: its steepest slope
/// in velocity and in position (a stiffness, where the axis dwells in a
/// well of it), and the shortest distance and time over which it changes
/// (the replay resolves them in its plant steps, sim/plant.hpp).
struct ExtraForceScales {
  double viscous_Ns_m = 0.0;
  double stiffness_N_m = 0.0;
  double length_m = std::numeric_limits<double>::infinity();
  double time_s = std::numeric_limits<double>::infinity();
};

/// Sim-to-real effects (NOTES.md table), each switched off by a zero first
/// field; several may be on at once. SI units throughout. With every effect off
/// the simulator produces exactly the traces it produced before effects existed.
///
/// Notation: x, v the motor-side position and velocity (what the encoder
/// measures), t the time since the start of the trace, s = sign of the sliding
/// velocity, m the total mass. The plant is
///
///     m1 dv/dt = u + w - F_fric(t, x, v) - F_load(t, x) - F_spring    (m1 = m unless compliant)
///
/// F_fric is friction: it is direction dependent, zero at rest and takes part
/// in the stick/slip band. F_load acts at rest and in motion alike. A
/// positive F_load needs positive drive force to hold the axis (like gravity on
/// an axis inclined so that + is uphill).
struct Effects {
  // --- offset and an arm's weight (in F_load) ------------------------------
  /// F_load += load.at(x): a constant force F0 (gravity on an inclined axis,
  /// cable drag, current-sensor offset: the recorded force shifts by +F0 in
  /// both directions and at rest) and an arm's weight G cos(x - q0), x in
  /// rad (a model identified with --gravity angle replays with it). The
  /// models' rule (ModelLoad), not a copy of it.
  ModelLoad load;

  // --- position ripple (in F_load) ----------------------------------------
  /// Amplitude A (N) of F_load += A sin(2 pi x / P + phi) (cogging, screw pitch error).
  double ripple_amplitude_N = 0.0;
  double ripple_period_m = 5.0e-3;  ///< P (m), > 0
  double ripple_phase_rad = 0.0;    ///< phi (rad)

  // --- position-dependent friction (in F_fric) ----------------------------
  /// dF (N): F_fric += dF s for x_min <= x <= x_max; the static band there
  /// grows by dF as well. May be negative (less friction there) down to
  /// -min(Fc+, Fc-).
  double position_friction_N = 0.0;
  double position_friction_x_min_m = 0.04;  ///< x_min (m)
  double position_friction_x_max_m = 0.07;  ///< x_max (m), > x_min

  // --- thermal drift (in F_fric) ------------------------------------------
  /// D (-): with e(t) = D exp(-t / tau), the viscous coefficient is
  /// sigma (1 + e(t)) and the Coulomb force Fc (1 + 0.3 e(t)); the break-away
  /// excess Fs is unchanged. D > 0: friction starts high and falls as the
  /// lubricant warms. D > -1.
  double drift_fraction = 0.0;
  double drift_time_constant_s = 20.0;  ///< tau (s), > 0

  // --- velocity-squared damping (in F_fric) -------------------------------
  /// c2 (N s^2/m^2), >= 0: F_fric += c2 v |v|.
  double quadratic_c2_Ns2_m2 = 0.0;

  // --- presliding hysteresis (in F_fric) ----------------------------------
  /// Fp (N), >= 0: Dahl-like bristle friction. After a reversal (the body
  /// slides in the direction opposite to its previous sliding direction)
  /// friction does not jump from -Fc to +Fc but builds up over distance d:
  /// F_fric += -2 Fp s exp(-r / d), r = distance slid since the reversal
  /// (evaluated exactly inside the integrator: r grows with x while sliding,
  /// stops growing at rest, restarts from 0 at a reversal; before the first
  /// motion r = infinity). The static band for a break-away is the sliding
  /// friction at v -> 0 with the current r (so it is 2 Fp lower right after a
  /// reversal), floored at 0.
  double presliding_force_N = 0.0;
  double presliding_distance_m = 20.0e-6;  ///< d (m), > 0

  // --- structural compliance (two-mass plant) -----------------------------
  /// f_r (Hz), >= 0: the mass splits into a motor side m1 = m (1 - mu) driven
  /// by u and a load m2 = m mu behind a spring k and damper c,
  ///     m1 a1 = u + w - F_fric - F_load - F_spring,  m2 a2 = F_spring,
  ///     F_spring = k (x1 - x2) + c (v1 - v2),
  /// with k = (2 pi f_r)^2 m1 m2 / m (so f_r = sqrt(k (m1 + m2) / (m1 m2)) / 2pi
  /// is the free resonance; the anti-resonance, seen when the motor is held,
  /// is f_r sqrt(1 - mu)) and c = 2 zeta (2 pi f_r) m1 m2 / m. Friction,
  /// F_load, ExtraForce and stick/slip act on the motor side, which the
  /// encoder measures (like the EMPS motor encoder). Starts relaxed at rest.
  double compliance_frequency_hz = 0.0;
  double compliance_mass_fraction = 0.3;  ///< mu (-), in (0, 1)
  double compliance_damping_ratio = 0.05; ///< zeta (-), >= 0

  // --- delay of the recorded force ----------------------------------------
  /// delta (s), >= 0: the recorded force is the applied one delta earlier,
  /// u_rec(t_k) = u(t_k - delta) interpolated linearly between the applied
  /// samples (u(t) = u_0 for t < 0), then measurement noise is added. The
  /// plant and controller are unchanged.
  double delay_s = 0.0;

  // --- outside the catalogue (for "unexplained") ---------------------------
  /// B (N): time-periodic load force F_load += B sin(2 pi f t + psi), e.g. a
  /// vibrating auxiliary unit (pump, unbalanced spindle) on the machine.
  double disturbance_amplitude_N = 0.0;
  double disturbance_frequency_hz = 2.0;  ///< f (Hz), > 0
  double disturbance_phase_rad = 0.0;     ///< psi (rad)
  /// Slowly wandering load force: a stationary Ornstein-Uhlenbeck process of
  /// this standard deviation (N) and correlation time, updated once per servo
  /// period and held (own random stream, so the noise of the other signals is
  /// unchanged). F_load += w_wander.
  double wander_force_N = 0.0;
  double wander_time_constant_s = 2.0;  ///< correlation time (s), > 0
};


/// F_load(t, x) of the offset, position ripple and time-periodic disturbance
/// (N), without the wandering force (a random state the plant holds).
double load_force(const Effects& e, double t_s, double x_m);

/// Catalogue names (diagnose's effect_kinds()) of the effects switched on, in
/// catalogue order, followed by "disturbance" / "wander" for the two outside
/// the catalogue. Empty when none is on.
std::vector<std::string> active_effects(const Effects& e);
/// Whether one effect is switched on in e.
bool effect_on(const Effects& e, Effect which);

/// A change in service at one instant (friction health, `feedid monitor`):
/// from time_s on, the Coulomb and viscous friction of the chosen
/// direction(s) and the plant's mass are scaled by (1 + fraction). The
/// controller keeps its nominal mass. Closed-loop plant only.
struct ServiceChange {
  double time_s = -1.0;           ///< < 0: no change (s)
  double coulomb_fraction = 0.0;  ///< Fc x (1 + this), > -1
  double viscous_fraction = 0.0;  ///< sigma x (1 + this), > -1
  double mass_fraction = 0.0;     ///< m x (1 + this), > -1
  int direction = 0;              ///< +1: positive only, -1: negative only, 0: both
  bool on() const { return time_s >= 0.0; }
  /// A warm-up (--warmup-drop, --warmup-minutes): from t = 0 the temperature
  /// rises linearly from 20 to 45 °C over warmup_s and stays there, and the
  /// Coulomb and viscous friction of both directions fall with it, by
  /// warmup_drop at its end (friction x (1 - drop * share)).
  double warmup_drop = 0.0;
  double warmup_s = 1200.0;
  double warmup_share(double t) const { return warmup_drop != 0.0 ? std::min(1.0, std::max(0.0, t / warmup_s)) : 0.0; }
  double temperature_C(double t) const { return 20.0 + 25.0 * std::min(1.0, std::max(0.0, t / warmup_s)); }
  bool warms_up() const { return warmup_drop != 0.0; }
};

/// Which plant makes the trace: the closed-loop drive of this file, or the
/// independent open-loop inverse dynamics of open_loop_plant.hpp.
enum class PlantKind { closed_loop, open_loop };
const char* plant_name(PlantKind p);
/// "closed", "open"; the error names --plant.
Outcome<PlantKind> parse_plant(const std::string& s);

struct SimConfig {
  PlantKind plant = PlantKind::closed_loop;
  DriveParams drive{};
  ControllerParams controller{};
  MotionParams motion{};
  SensorParams sensors{};
  std::uint64_t seed = 1;
  int plant_substeps = 20;  ///< integration steps per servo period
  ExtraForce extra_force{}; ///< optional, see above
  Effects effects{};        ///< sim-to-real effects, all off by default
  LoggingParams logging{};  ///< how force and velocity are recorded
  ServiceChange change{};   ///< a step change in service, off by default
};

/// The cascaded position / velocity controller of the simulated drive, one
/// servo period at a time (drive_sim.cpp states the law).
class CascadeController {
 public:
  CascadeController(const ControllerParams& kc, double mass_kg);
  /// The held force (N) for the period starting at reference r, given the
  /// next period's reference (for the acceleration feed-forward), the
  /// measured position and velocity, and an extra feed-forward u_extra (N).
  double command(const PathPoint& r, const PathPoint& r_next, double x_meas, double v_meas, double u_extra);

 private:
  double kp_, kv_, ki_, u_max_, m_ff_, dt_;
  double integral_ = 0.0;  ///< PI integrator state (N)
};

/// One closed-loop axis (plant, encoder, controller of SimConfig) advanced
/// a servo period at a time toward any reference: the circle test drives
/// two. No noise, delay or logging conventions: the plant's own response.
class ServoAxis {
 public:
  explicit ServoAxis(const SimConfig& cfg);  ///< cfg as simulate takes it
  ~ServoAxis();
  ServoAxis(ServoAxis&&) noexcept;
  /// Measure, command toward r (+ u_extra, N), advance the plant over the
  /// period. Returns t, measured position and velocity, and the command.
  TraceSample step(double t, const PathPoint& r, const PathPoint& r_next, double u_extra);
  double position_m() const;  ///< true (unquantised) position

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The first parameter out of range, naming the field and its unit ("drive.mass_kg (kg)
/// must be finite and > 0, got 0"), or a motion with no stroke; empty when
/// the configuration can be simulated.
std::string sim_config_error(const SimConfig& c);

/// Where the simulated command sat at its limit (controller.force_limit_N)
/// on more than 1 % of the trace's samples, what that says and what to
/// change; empty otherwise. A loop sampled too slowly for its velocity
/// bandwidth, or fed by an encoder too coarse for it, swings between the
/// limits (100 Hz at the default 40 Hz: 59 % of the samples, the axis 6 m
/// beyond its 0.4 m travel), and its trace is no drive's; so is a motion
/// that asks for more force than the limit.
std::string saturated_command(const Trace& t, const SimConfig& c);

/// Simulate and return the recorded trace (t, x, v, u) at the servo rate.
/// The configuration must pass sim_config_error (a caller that did not ask
/// gets std::invalid_argument: a bug, not an input error).
/// `progress` (optional) is called with the fraction done, at most ~100 times.
Trace simulate(const SimConfig& cfg, const std::function<void(double)>& progress = {});

}  // namespace feedid::host
