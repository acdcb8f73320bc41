// The feed-drive plant of the closed-loop simulator, shared with the
// replay of a model inside a logged drive's loop (replay/replay.hpp): a
// rigid body (or two masses behind a spring) with direction-dependent
// Stribeck friction and Karnopp stick/slip, advanced with the drive force
// held. Host only.
#pragma once
#include <algorithm>
#include <cmath>
#include <limits>

#include "drive_sim.hpp"
#include "model/constants.hpp"

namespace feedid::host {

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
struct PlantState {
  double x = 0.0, v = 0.0;    ///< motor side (the rigid body when not compliant)
  double x2 = 0.0, v2 = 0.0;  ///< load behind the spring (compliant plant only)
};

class DrivePlant {
 public:
  /// locate_edges: a pass also ends where x crosses an edge of the
  /// position-friction range (found as a velocity zero crossing is), so
  /// that the friction's step in x is integrated exactly whatever the step
  /// (the replay's automatic steps, one per sample on EMPS). The simulator
  /// keeps it off: its traces, and every figure measured on them, stay as
  /// they were.
  DrivePlant(const DriveParams& d, const Effects& e, const ExtraForce& extra, const ServiceChange& change,
             bool locate_edges = false)
      : d_(d), e_(e), extra_(extra), change_(change) {
    locate_edges_ = locate_edges && e.position_friction_N != 0.0;
    plain_friction_ = e.drift_fraction == 0.0 && e.position_friction_N == 0.0 && e.quadratic_c2_Ns2_m2 == 0.0 &&
                      e.presliding_force_N == 0.0;
    loads_ = e.load.any() || e.ripple_amplitude_N != 0.0 || e.disturbance_amplitude_N != 0.0 ||
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

  /// Puts the plant at rest at x (m), both masses relaxed (a replay starts
  /// where the logged axis starts).
  void start_at(double x_m) { s_ = PlantState{x_m, 0.0, x_m, 0.0}; }

  /// Motor-side acceleration (m/s^2) at time t under input force f_in (N),
  /// from the present state: 0 while the axis sticks, else the sliding
  /// equation in the direction it moves or breaks away (what an
  /// integrator's acceleration state reads at a sample instant).
  double acceleration(double t, double f_in) {
    if (std::fabs(s_.v) <= kRestVelocity) {
      double s = 1.0;
      if (holds_at_rest(t, f_in, s)) return 0.0;
      dir_ = s;
    } else {
      dir_ = s_.v > 0.0 ? 1.0 : -1.0;
    }
    begin_pass();  // step() sets both again before it integrates
    return deriv(t, s_, f_in).v;
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
        double s = 1.0;
        if (holds_at_rest(t, f_in, s)) {  // sticks
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
      begin_pass();

      PlantState s1 = rk4(t, remaining, f_in, s_);
      const bool stops = !(dir_ * s1.v > 0.0);
      double tau = remaining;
      if (stops) {
        // Velocity reached 0 within the step: locate the crossing time by
        // bracketed secant (Illinois) search on v(tau), then clamp v = 0.
        tau = find_zero_crossing(t, remaining, f_in, s1.v);
        s1 = tau > 0.0 ? rk4(t, tau, f_in, s_) : s_;
        s1.v = 0.0;
      }
      if (locate_edges_) {
        const double edge = edge_crossed(s_.x, s1.x);
        const double at_edge = std::isnan(edge) ? tau : find_edge_crossing(t, tau, f_in, edge);
        if (at_edge < tau) {
          // The pass ends just past the edge; the next one slides on its far side.
          end_pass(rk4(t, at_edge, f_in, s_));
          t += at_edge;
          remaining -= at_edge;
          continue;
        }
      }
      end_pass(s1);
      if (!stops) return;
      t += tau;
      remaining -= tau;
    }
  }

 private:
  static constexpr double kRestVelocity = 1.0e-15;  ///< |v| treated as rest (m/s)

  // Whether the motor side, at rest, stays at rest under f_in: the net
  // applied force excluding friction within the static band of the
  // direction it pushes, s (the break-away direction when it does not).
  bool holds_at_rest(double t, double f_in, double& s) const {
    const double at_rest = extra(t, s_.x, 0.0);
    double f_net = f_in - at_rest;
    if (loads_) f_net -= load(t, s_.x);
    if (two_mass_) f_net -= spring(s_);
    s = f_net >= 0.0 ? 1.0 : -1.0;
    // An extra force that is friction (a drift's or a profile's Coulomb
    // part: 0 at rest, its level the moment the axis slides) holds the axis
    // as the plant's own Coulomb force does: its step at v -> 0 in the
    // pushed direction moves the band (the sliding friction at v -> 0).
    // Without it the axis crept. 0 for a force continuous in v.
    const double step = extra_ ? s * (extra(t, s_.x, s * std::numeric_limits<double>::denorm_min()) - at_rest) : 0.0;
    return std::fabs(f_net) <= std::max(0.0, static_band(t, s_.x, s) + step);  // floored once, after the step
  }

  // A pass slides in direction dir_ from the present state: where it
  // starts, and, where the range's edges are located (no pass crosses
  // one), the range's friction for the whole pass. Taken per RK stage, a
  // stage past the edge at the pass's last instant put the step of
  // friction into the pass (4e-7 m/s of velocity at 100 N on 92 kg).
  void begin_pass() {
    x_pass0_ = s_.x;
    pass_position_friction_ = position_friction(s_.x, dir_);
  }

  void end_pass(const PlantState& s) {
    if (e_.presliding_force_N > 0.0) since_reversal_ += dir_ * (s.x - x_pass0_);
    s_ = s;
  }

  double extra(double t, double x, double v) const { return extra_ ? extra_(t, x, v) : 0.0; }

  // The velocity the extra force sees within a pass: v while it is on the
  // pass's side of 0, else 0 approached from that side. It continues
  // through v = 0 in the direction dir_, as the friction does for the RK
  // stages: a drift's Coulomb part read at v = 0 as 0 made a break-away
  // the static band allowed turn straight back.
  double sliding(double v) const { return v * dir_ > 0.0 ? v : dir_ * std::numeric_limits<double>::denorm_min(); }

  double load(double t, double x) const { return load_force(e_, t, x) + held_load_; }

  // Spring force on the load, = minus the force on the motor (N).
  double spring(const PlantState& s) const { return k_ * (s.x - s.x2) + c_ * (s.v - s.v2); }

  double drift(double t) const {
    return e_.drift_fraction != 0.0 ? e_.drift_fraction * std::exp(-t / e_.drift_time_constant_s) : 0.0;
  }

  // The range's friction for motion (or a push) in direction s. Where the
  // edges are located, at an edge that of the side the motion enters (a
  // pass ends just past an edge); the simulator's closed range otherwise,
  // so that its traces stay as they were.
  double position_friction(double x, double s) const {
    const double lo = e_.position_friction_x_min_m, hi = e_.position_friction_x_max_m;
    const bool inside = !locate_edges_ ? x >= lo && x <= hi : s > 0.0 ? x >= lo && x < hi : x > lo && x <= hi;
    return e_.position_friction_N != 0.0 && inside ? e_.position_friction_N : 0.0;
  }

  // The edge of the position-friction range strictly between x0 and x1
  // (the nearer to x0), or NaN.
  double edge_crossed(double x0, double x1) const {
    double edge = std::numeric_limits<double>::quiet_NaN();
    for (const double e : {e_.position_friction_x_max_m, e_.position_friction_x_min_m})
      if ((x0 < e && e < x1) || (x1 < e && e < x0))
        if (std::isnan(edge) || std::fabs(e - x0) < std::fabs(edge - x0)) edge = e;
    return edge;
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
    F += dir_ * (locate_edges_ ? pass_position_friction_ : position_friction(x, dir_));
    if (e_.presliding_force_N > 0.0)
      F -= 2.0 * e_.presliding_force_N * dir_ * presliding_decay(since_reversal_ + dir_ * (x - x_pass0_));
    return F;
  }

  // The sliding friction (N) at v -> 0 in direction s, the plant's own
  // terms: the largest net force the motor side withstands at rest when
  // pushed that way, once the extra force's step is added and the sum
  // floored at 0 (holds_at_rest; floored before the step, a bristle's
  // dip below 0 held the axis where the sliding equation moved it).
  double static_band(double t, double x, double s) const {
    const DirectionFriction f = side(s, t);
    if (plain_friction_) return f.coulomb_N + f.breakaway_N;
    double band = f.coulomb_N * (1.0 + 0.3 * drift(t)) + f.breakaway_N + position_friction(x, s);
    if (e_.presliding_force_N > 0.0) {
      const double r = (last_dir_ != 0.0 && s != last_dir_) ? 0.0 : since_reversal_;
      band -= 2.0 * e_.presliding_force_N * presliding_decay(r);
    }
    return band;
  }

  // Friction of direction s at time t, with the change in service from its time on.
  DirectionFriction side(double s, double t) const {
    DirectionFriction f = s > 0.0 ? d_.pos : d_.neg;
    if (change_.on() && t >= change_.time_s && (change_.direction == 0 || change_.direction * s > 0.0)) {
      f.coulomb_N *= 1.0 + change_.coulomb_fraction;
      f.viscous_Ns_m *= 1.0 + change_.viscous_fraction;
    }
    const double warm = 1.0 - change_.warmup_drop * change_.warmup_share(t);
    f.coulomb_N *= warm;
    f.viscous_Ns_m *= warm;
    return f;
  }

  // Motor-side mass at time t (the change in service scales it).
  double mass1(double t) const {
    return change_.on() && t >= change_.time_s ? m1_ * (1.0 + change_.mass_fraction) : m1_;
  }

  // Time derivative of the state while sliding in direction dir_ (or with the
  // motor locked at rest).
  PlantState deriv(double t, const PlantState& s, double f_in) const {
    PlantState d;
    if (!locked_) {
      double f = f_in - friction(t, s.x, s.v) - extra(t, s.x, sliding(s.v));
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

  static PlantState axpy(const PlantState& s0, double a, const PlantState& k) {
    PlantState s;
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
  PlantState rk4(double t, double h, double f_in, const PlantState& s0) const {
    const PlantState k1 = deriv(t, s0, f_in);
    const PlantState k2 = deriv(t + 0.5 * h, axpy(s0, 0.5 * h, k1), f_in);
    const PlantState k3 = deriv(t + 0.5 * h, axpy(s0, 0.5 * h, k2), f_in);
    const PlantState k4 = deriv(t + h, axpy(s0, h, k3), f_in);
    PlantState s1;
    s1.x = rk4_sum(s0.x, h, k1.x, k2.x, k3.x, k4.x);
    s1.v = rk4_sum(s0.v, h, k1.v, k2.v, k3.v, k4.v);
    if (two_mass_) {
      s1.x2 = rk4_sum(s0.x2, h, k1.x2, k2.x2, k3.x2, k4.x2);
      s1.v2 = rk4_sum(s0.v2, h, k1.v2, k2.v2, k3.v2, k4.v2);
    }
    return s1;
  }

  // Time tau in (0, h] at which the motion in direction dir_ reaches x =
  // edge, given it is short of it at 0 and past it at h; the end where it
  // has (just) passed it.
  double find_edge_crossing(double t, double h, double f_in, double edge) const {
    double a = 0.0, fa = dir_ * (s_.x - edge);          // < 0
    double b = h, fb = dir_ * (rk4(t, h, f_in, s_).x - edge);  // > 0
    int side = 0;
    for (int it = 0; it < 60 && b - a > 1e-12 * h; ++it) {
      double c = (a * fb - b * fa) / (fb - fa);
      if (!(c > a && c < b)) c = 0.5 * (a + b);
      const double fc = dir_ * (rk4(t, c, f_in, s_).x - edge);
      if (fc > 0.0) {
        b = c;
        fb = fc;
        if (side == -1) fa *= 0.5;
        side = -1;
      } else {
        a = c;
        fa = fc;
        if (side == 1) fb *= 0.5;
        side = 1;
      }
    }
    return b;
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
  bool locate_edges_ = false;   ///< passes end at the position-friction range's edges
  bool loads_ = false;          ///< some F_load term is on
  bool two_mass_ = false;       ///< compliant plant
  bool locked_ = false;         ///< motor held at rest while the load moves (inside rk4 only)
  double m1_ = 0.0, m2_ = 0.0;  ///< motor-side and load mass (kg)
  const ServiceChange& change_;
  double k_ = 0.0, c_ = 0.0;    ///< spring (N/m) and damper (N s/m)
  double held_load_ = 0.0;      ///< wandering disturbance of this servo period (N)
  PlantState s_{};
  double dir_ = 1.0;       ///< sliding direction of the current pass
  double last_dir_ = 0.0;  ///< direction of the last sliding (0: never moved)
  double since_reversal_ = std::numeric_limits<double>::infinity();  ///< distance slid since the last reversal (m)
  double x_pass0_ = 0.0;   ///< motor position at the start of the current pass (m)
  double pass_position_friction_ = 0.0;  ///< the range's friction over the current pass (locate_edges_ only)
};

/// The plant's shortest time scale (s) while the axis moves at up to
/// speed_m_s: the fastest of the velocity's decay under viscous friction
/// (with drift, c2 v|v| and the extra force's slope), the Stribeck dip's
/// steepest slope, a drift's time constant, a presliding bristle's and an
/// arm's weight's oscillation, a compliance's resonance (or its damping,
/// when that is faster), and the time the axis takes at top speed to cross
/// a ripple's period / 2 pi or the extra force's length, and a ripple's
/// or the extra force's own stiffness. Infinite when nothing sets one. The replay steps its
/// plant finely enough to resolve it; a position-friction range's step in
/// x has no time scale, and the replay's plant locates its edges instead.
inline double shortest_time_scale_s(const DriveParams& d, const Effects& e, const ExtraForceScales& extra,
                                    double speed_m_s) {
  const bool two_mass = e.compliance_frequency_hz > 0.0;
  const double m1 = two_mass ? d.mass_kg * (1.0 - e.compliance_mass_fraction) : d.mass_kg;
  double rate = 0.0;  // 1/s, the fastest so far
  const auto faster = [&rate](double r) {
    if (std::isfinite(r)) rate = std::max(rate, std::fabs(r));
  };
  const double drift = 1.0 + std::fabs(e.drift_fraction);
  for (const DirectionFriction& f : {d.pos, d.neg}) {
    faster((std::fabs(f.viscous_Ns_m) * drift + extra.viscous_Ns_m + 2.0 * std::fabs(e.quadratic_c2_Ns2_m2) * speed_m_s) / m1);
    // The dip Fs exp(-(v/vs)^2) falls by at most 0.86 Fs / vs per m/s.
    if (f.breakaway_N != 0.0 && f.stribeck_velocity_m_s > 0.0) faster(f.breakaway_N / (f.stribeck_velocity_m_s * m1));
  }
  if (e.drift_fraction != 0.0) faster(1.0 / e.drift_time_constant_s);
  faster(1.0 / extra.time_s);
  faster(speed_m_s / extra.length_m);
  faster(std::sqrt(extra.stiffness_N_m / m1));
  // A ripple is crossed at top speed, and is a spring of 2 pi A / P where
  // the axis dwells in its wells; a bristle is a spring of 2 Fp / d near a
  // reversal; an arm's weight one of G per rad.
  if (e.ripple_amplitude_N != 0.0) {
    faster(2.0 * kPi * speed_m_s / e.ripple_period_m);
    faster(std::sqrt(2.0 * kPi * std::fabs(e.ripple_amplitude_N) / (e.ripple_period_m * m1)));
  }
  if (e.presliding_force_N > 0.0) faster(std::sqrt(2.0 * e.presliding_force_N / (e.presliding_distance_m * m1)));
  if (e.load.gravity_N != 0.0) faster(std::max(speed_m_s, std::sqrt(std::fabs(e.load.gravity_N) / m1)));
  if (two_mass) faster(2.0 * kPi * e.compliance_frequency_hz * std::max(1.0, 2.0 * e.compliance_damping_ratio));
  return rate > 0.0 ? 1.0 / rate : std::numeric_limits<double>::infinity();
}

}  // namespace feedid::host
