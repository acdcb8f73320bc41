#include "diagnose_catalogue.hpp"

#include "model/effects.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace feedid::host::diag {

std::size_t run_of(const std::vector<double>& run_starts, double t) {
  const auto it = std::upper_bound(run_starts.begin(), run_starts.end(), t);
  return it == run_starts.begin() ? 0 : static_cast<std::size_t>(it - run_starts.begin()) - 1;
}

namespace {

/// Mean of exp(-s/d) while s runs linearly from s0 to s1.
double mean_decay(double s0, double s1, double d) {
  if (std::fabs(s1 - s0) < 1e-3 * d) return std::exp(-0.5 * (s0 + s1) / d);
  return d * (std::exp(-s0 / d) - std::exp(-s1 / d)) / (s1 - s0);
}

double sign_of(const Segment& sg) { return sg.v > 0 ? 1.0 : -1.0; }

EffectModel offset_model(const Observations& obs) {
  EffectModel m;
  m.kind = effect_name(Effect::offset);
  m.columns = [&obs](double, Observations::Resolution r) {
    return obs.segment_columns(1, false, r, [](std::size_t, const Segment&, double* out) { out[0] = 1.0; });
  };
  m.parameters = [](double, const Vec& c, double) { return nlohmann::json{{"force_N", c(0)}}; };
  return m;
}

/// Load force A sin(2 pi x / P + phi): sin and cos columns, their exact
/// means while x runs linearly across a segment, mean e^{i phi} =
/// (e^{i phi1} - e^{i phi0}) / (i (phi1 - phi0)). Segments join, so each
/// end's e^{i phi} serves twice: one sincos per segment.
EffectModel ripple_model(const Observations& obs, const TraceExtent& e) {
  EffectModel m;
  m.kind = effect_name(Effect::position_ripple);
  m.grid = log_grid(std::max(4e-4, 1e-3 * e.travel), e.travel / 3.0, 160);
  m.continuous = true;
  m.columns = [&obs](double p, Observations::Resolution r) {
    const double k = 2.0 * M_PI / p;
    double x_prev = std::numeric_limits<double>::quiet_NaN(), s_prev = 0.0, c_prev = 0.0;
    return obs.segment_columns(2, false, r, [=](std::size_t, const Segment& sg, double* out) mutable {
      double s0 = s_prev, c0 = c_prev, s1, c1;
      if (sg.x0 != x_prev) sincos(k * sg.x0, &s0, &c0);
      sincos(k * sg.x1, &s1, &c1);
      const double dphi = k * (sg.x1 - sg.x0);
      if (std::fabs(dphi) > 1e-4) {
        out[0] = (c0 - c1) / dphi;  // mean sin
        out[1] = (s1 - s0) / dphi;  // mean cos
      } else {
        out[0] = 0.5 * (s0 + s1);
        out[1] = 0.5 * (c0 + c1);
      }
      x_prev = sg.x1, s_prev = s1, c_prev = c1;
    });
  };
  m.parameters = [](double p, const Vec& c, double) {
    return nlohmann::json{{"period_m", p}, {"amplitude_N", std::hypot(c(0), c(1))}, {"phase_rad", std::atan2(c(1), c(0))}};
  };
  return m;
}

/// Extra friction on a contiguous range of the travel: 200 cells, coarse
/// ranges of 10 cells, then each edge moved cell by cell.
EffectModel position_friction_model(const Observations& obs, const TraceExtent& e) {
  constexpr int cells = 200, coarse = 10;
  EffectModel m;
  m.kind = effect_name(Effect::position_friction);
  for (int a = 0; a < cells; a += coarse)
    for (int b = a + coarse; b <= cells; b += coarse)
      if (!(a == 0 && b == cells)) m.grid.push_back(a * 1000 + b);
  auto range = [e](double code) {
    const int a = static_cast<int>(code) / 1000, b = static_cast<int>(code) % 1000;
    return std::pair<double, double>{e.x_lo + e.travel * a / cells, e.x_lo + e.travel * b / cells};
  };
  m.columns = [&obs, range](double code, Observations::Resolution r) {
    const auto [xa, xb] = range(code);
    return obs.segment_columns(1, false, r, [xa = xa, xb = xb](std::size_t, const Segment& sg, double* out) {
      const double lo = std::min(sg.x0, sg.x1), hi = std::max(sg.x0, sg.x1);
      const double inside = hi - lo < 1e-12 ? (lo >= xa && lo < xb ? 1.0 : 0.0)
                                            : std::max(0.0, std::min(hi, xb) - std::max(lo, xa)) / (hi - lo);
      out[0] = inside * sign_of(sg);
    });
  };
  m.parameters = [range](double code, const Vec& c, double) {
    const auto [xa, xb] = range(code);
    return nlohmann::json{{"x_min_m", xa}, {"x_max_m", xb}, {"delta_N", c(0)}};
  };
  m.refine = [](double code) {
    const int a = static_cast<int>(code) / 1000, b = static_cast<int>(code) % 1000;
    std::vector<double> out;
    for (int d = -coarse; d <= coarse; ++d) {
      if (a + d >= 0 && a + d < b) out.push_back((a + d) * 1000 + b);
      if (b + d > a && b + d <= cells) out.push_back(a * 1000 + b + d);
    }
    return out;
  };
  return m;
}

/// The warm-up's decay exp(-(t - t_run)/tc) on a segment: time counts from
/// the start of the segment's own run, the only clock a recording carries.
double drift_decay(const Segment& sg, const std::vector<double>& run_starts, double tc) {
  return std::exp(-(sg.t - run_starts[run_of(run_starts, sg.t)]) / tc);
}

/// The decay's means over the moving segments of one run and direction
/// (dt-weighted, for the Coulomb term; v^2 dt-weighted, for the viscous
/// term: each the weight its term's least squares gives it).
struct DecayStats {
  double w = 0.0, w_vv = 0.0, sum = 0.0, sum_vv = 0.0;
  double mean() const { return w > 0 ? sum / w : 0.0; }
  double mean_vv() const { return w_vv > 0 ? sum_vv / w_vv : 0.0; }
};

/// Index of a segment's run and direction in decay_stats.
std::size_t run_direction(const Segment& sg, const std::vector<double>& run_starts) {
  return 2 * run_of(run_starts, sg.t) + (sg.v > 0 ? 0 : 1);
}

std::vector<DecayStats> decay_stats(const Observations& obs, Observations::Resolution r,
                                    const std::vector<double>& run_starts, double tc) {
  std::vector<DecayStats> st(2 * run_starts.size());
  for (const Segment& sg : obs.segments(r)) {
    if (sg.block == Segment::kNoBlock) continue;
    const double d = drift_decay(sg, run_starts, tc), vv = sg.v * sg.v;
    DecayStats& s = st[run_direction(sg, run_starts)];
    s.w += sg.dt, s.sum += d * sg.dt;
    s.w_vv += vv * sg.dt, s.sum_vv += d * vv * sg.dt;
  }
  return st;
}

/// Friction cannot push the axis along: with the drift's change added to
/// the level the trace measures (the base model's friction, fitted without
/// any effect: the run's mean), the friction force against the motion must
/// stay positive on every moving segment of every run, at that segment's
/// speed and time (where the measured friction is not positive itself, a
/// Coulomb estimate just below zero, the drift must not lower it further).
/// Anchoring at the measured level, not at the joint fit's warm asymptote,
/// matters: a time constant far beyond the run makes the decay nearly
/// constant, and the joint fit then trades a huge asymptote against a huge
/// change (-38 V "drift" against a 0.09 V Coulomb force on pooled SysId
/// files). A change larger than the friction itself fails this test; a
/// warm-up of the friction that is there never does.
std::string drift_turns_friction_negative(const Observations& obs, const std::vector<double>& run_starts, double tc,
                                          const MeasuredFriction& f, double viscous_change, double coulomb_change) {
  const std::vector<DecayStats> st = decay_stats(obs, Observations::Resolution::fine, run_starts, tc);
  for (const Segment& sg : obs.segments(Observations::Resolution::fine)) {
    if (sg.block == Segment::kNoBlock) continue;
    const std::size_t k = run_direction(sg, run_starts);
    const double d = drift_decay(sg, run_starts, tc), speed = std::fabs(sg.v);
    const double measured = f.coulomb_N[k] + f.viscous_Ns_m[k] * speed;
    const double with_drift = measured + coulomb_change * (d - st[k].mean()) + viscous_change * (d - st[k].mean_vv()) * speed;
    if (with_drift < std::min(0.0, measured))
      return std::string("the friction change exceeds the friction the trace measures: friction against ") +
             (sg.v > 0 ? "positive" : "negative") + " motion would turn negative in run " + std::to_string(k / 2 + 1) +
             " at " + std::to_string(sg.t - run_starts[k / 2]) + " s";
  }
  return std::string();
}

/// Viscous and Coulomb friction decaying with time constant tc as the drive
/// warms, from the start of each run. Pooled runs (docs/diagnosis.md,
/// "Pooled runs"): the time between recordings is made up, so no drift
/// spans a run boundary; each run starts the decay afresh, with one
/// amplitude for all (the same warm-up each time the machine is started).
/// Each run's own friction level is in the base model (add_run_levels in
/// diagnose.cpp), so only the change within a run is read as drift.
EffectModel thermal_drift_model(const Observations& obs, const TraceExtent& e, const MeasuredFriction& friction) {
  EffectModel m;
  m.kind = effect_name(Effect::thermal_drift);
  m.grid = log_grid(std::max(1.0, 0.02 * e.longest_run_s), 5.0 * e.longest_run_s, 40);
  m.continuous = true;
  const bool pooled = e.run_starts.size() > 1;
  m.columns = [&obs, starts = e.run_starts](double tc, Observations::Resolution r) {
    return obs.segment_columns(2, false, r, [&](std::size_t, const Segment& sg, double* out) {
      const double decay = drift_decay(sg, starts, tc);
      out[0] = sg.v * decay;
      out[1] = sign_of(sg) * decay;
    });
  };
  m.parameters = [pooled](double tc, const Vec& c, double) {
    nlohmann::json p{{"time_constant_s", tc}, {"viscous_change_Ns_m", c(0)}, {"coulomb_change_N", c(1)}};
    if (pooled) p["time_origin"] = "the start of each run";
    return p;
  };
  m.implausible = [&obs, starts = e.run_starts, friction](const nlohmann::json& p, double) {
    return drift_turns_friction_negative(obs, starts, p.value("time_constant_s", 1.0), friction,
                                         p.value("viscous_change_Ns_m", 0.0), p.value("coulomb_change_N", 0.0));
  };
  return m;
}

/// c2 v|v|, at every interval (no grid, one pass).
EffectModel quadratic_viscous_model(const Observations& obs) {
  EffectModel m;
  m.kind = effect_name(Effect::quadratic_viscous);
  m.columns = [&obs](double, Observations::Resolution) {
    Mat c(static_cast<Eigen::Index>(obs.size()), 1);
    c.col(0) = obs.sample_column([&obs](std::size_t j) {
      const double v = obs.interval_v(j);
      return v * std::fabs(v);
    });
    return c;
  };
  m.parameters = [](double, const Vec& c, double) { return nlohmann::json{{"c2", c(0)}, {"c2_unit", "N s^2/m^2"}}; };
  return m;
}

/// Bristle friction that builds up over a distance d after a reversal.
/// Whether a stop also resets it depends on how the drive settles (a slip
/// back below one encoder quantum is a reversal no measurement shows), so
/// both readings are tried: p > 0 counts from the last reversal, p < 0 from
/// the last reversal or start from rest.
EffectModel presliding_model(const Observations& obs, const TraceExtent& e) {
  EffectModel m;
  m.kind = effect_name(Effect::presliding_hysteresis);
  m.fine_grid = true;  // it builds up within a few ms of a reversal: a whole block is too coarse
  m.grid = log_grid(1e-6, std::min(2e-3, e.travel / 4), 40);
  const std::size_t n = m.grid.size();
  for (std::size_t i = 0; i < n; ++i) m.grid.push_back(-m.grid[i]);
  m.columns = [&obs](double p, Observations::Resolution r) {
    const double d = std::fabs(p);
    const bool from_reversal = p > 0;
    return obs.segment_columns(1, false, r, [d, from_reversal](std::size_t, const Segment& sg, double* out) {
      const double decay = from_reversal ? mean_decay(sg.rev0, sg.rev1, d) : mean_decay(sg.start0, sg.start1, d);
      out[0] = -sign_of(sg) * decay;
    });
  };
  m.parameters = [](double p, const Vec& c, double) {
    return nlohmann::json{{"distance_m", std::fabs(p)}, {"force_N", 0.5 * c(0)},
                          {"resets", p > 0 ? "at reversals" : "at reversals and starts from rest"}};
  };
  m.refine = [](double p) {  // finer steps in d around the best, same reading
    std::vector<double> out;
    for (int i = -4; i <= 4; ++i) out.push_back(p * std::pow(1.05, i));
    return out;
  };
  m.implausible = [](const nlohmann::json& p, double) {
    return p.value("force_N", 0.0) > 0.0 ? std::string() : std::string("friction would rise after a reversal");
  };
  return m;
}

/// Load acceleration a2 behind a spring, H(s) = w^2/(s^2 + 2 z w s + w^2)
/// of the motor's, discretised exactly for an acceleration held over each
/// segment (the state relaxes to y = a by Phi).
std::vector<double> load_acceleration(const Observations& obs, Observations::Resolution r, double w, double z) {
  const std::vector<Segment>& segs = obs.segments(r);
  std::vector<double> out(segs.size());
  double y = segs.empty() ? 0.0 : segs[0].accel, yd = 0.0, h_prev = -1.0;
  double p11 = 0, p12 = 0, p21 = 0, p22 = 0;
  const double wd = w * std::sqrt(1.0 - z * z);
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const double h = segs[i].dt;
    if (h != h_prev) {
      const double decay = std::exp(-z * w * h), c = std::cos(wd * h), s = std::sin(wd * h);
      p11 = decay * (c + z * w / wd * s);
      p12 = decay * s / wd;
      p21 = -decay * w * w / wd * s;
      p22 = decay * (c - z * w / wd * s);
      h_prev = h;
    }
    const double e = y - segs[i].accel, y0 = y;
    y = segs[i].accel + p11 * e + p12 * yd;
    yd = p21 * e + p22 * yd;
    out[i] = 0.5 * (y0 + y);
  }
  return out;
}

/// Compliance: the base model misses m2 (a2 - a1).
EffectModel compliance_model(const Observations& obs, const TraceExtent& e) {
  EffectModel m;
  m.kind = effect_name(Effect::compliance);
  const double f_top = std::min(0.25 * e.sample_rate_hz, 400.0);
  m.grid = log_grid(3.0, f_top, 50);
  m.continuous = true;
  m.fine_grid = true;
  m.columns = [&obs](double f, Observations::Resolution r) {
    const std::vector<double> a2 = load_acceleration(obs, r, 2 * M_PI * f, 0.05);
    return obs.segment_columns(1, true, r, [&a2](std::size_t i, const Segment& sg, double* out) { out[0] = a2[i] - sg.accel; });
  };
  // c = load mass m2; free resonance sqrt(k (m1 + m2) / (m1 m2)) with k = m2 w^2.
  m.parameters = [](double f, const Vec& c, double mass_kg) {
    const double m2 = c(0), m1 = mass_kg - m2;
    const double free = m1 > 0 && m2 > 0 ? f * std::sqrt(1.0 + m2 / m1) : f;
    return nlohmann::json{{"frequency_hz", free}, {"load_frequency_hz", f}, {"load_mass_kg", m2}};
  };
  // A "compliance" with a negative load mass at the top of its frequency
  // grid is a delay in disguise: both look like jerk there.
  m.implausible = [f_top](const nlohmann::json& p, double mass_kg) {
    const double m2 = p.value("load_mass_kg", 0.0);
    if (!(m2 > 0.0) || !(m2 < mass_kg)) return std::string("load mass outside (0, m)");
    if (p.value("load_frequency_hz", 0.0) > 0.97 * f_top) return std::string("frequency at the top of the search range");
    return std::string();
  };
  return m;
}

/// The recorded force lags, u_rec(t) = u(t - d), so u_rec(t) = model(t) -
/// [u_rec(t + d) - u_rec(t)]: regressor u_f(t + d) - u_f(t) (coefficient
/// near -1), d by grid search. Exact for any d, unlike u - d du/dt.
EffectModel delay_model(const Observations& obs, const TraceExtent& e, double lag_beyond_conventions_s) {
  EffectModel m;
  m.kind = effect_name(Effect::delay);
  m.grid = log_grid(0.2 / e.sample_rate_hz, 25.0 / e.sample_rate_hz, 40);
  m.continuous = true;
  m.columns = [&obs, h = 0.5 / e.sample_rate_hz](double d, Observations::Resolution r) {
    // Mean over the segment's interval ends (a half period after their middles).
    return obs.segment_columns(1, false, r, [&obs, d, h](std::size_t, const Segment& sg, double* out) {
      const double a = sg.t_start + h, b = sg.t_start + sg.dt + h;
      out[0] = obs.lowpass_force_mean(a + d, b + d, sg.j0) - obs.lowpass_force_mean(a, b, sg.j0);
    });
  };
  // For a force smooth on the scale of d only c*d is identified (c d du/dt): -c*d is the delay.
  m.parameters = [](double d, const Vec& c, double) {
    return nlohmann::json{{"delay_s", -c(0) * d}, {"shift_s", d}, {"coefficient", c(0)}};
  };
  // The timing search keeps the base model's lag within what logging
  // conventions explain; only a lag it found beyond them is a delay. A
  // smaller one is the lag estimate's own error, not a physical effect.
  m.implausible = [lag_beyond_conventions_s](const nlohmann::json& p, double) {
    if (!(lag_beyond_conventions_s > 0.0)) return std::string("the force lag is within what logging conventions explain");
    return p.value("delay_s", 0.0) > 0.0 ? std::string() : std::string("recorded force would lead the motion");
  };
  return m;
}

}  // namespace

TraceExtent trace_extent(const Observations& obs, const std::vector<double>& run_starts) {
  const Signals& s = obs.signals();
  TraceExtent e;
  const auto [lo, hi] = std::minmax_element(s.x.begin(), s.x.end());
  e.x_lo = *lo;
  e.travel = std::max(*hi - *lo, 1e-6);
  e.t0 = s.t.front();
  e.duration = s.t.back() - s.t.front();
  e.sample_rate_hz = s.sample_rate_hz;
  e.run_starts = {e.t0};
  for (double t : run_starts)
    if (t > e.run_starts.back()) e.run_starts.push_back(t);
  e.longest_run_s = 0.0;
  for (std::size_t r = 0; r < e.run_starts.size(); ++r) {
    // A run ends at its last sample: the next run's start less the made-up gap.
    const double end = r + 1 < e.run_starts.size()
                           ? *(std::lower_bound(s.t.begin(), s.t.end(), e.run_starts[r + 1]) - 1)
                           : s.t.back();
    e.longest_run_s = std::max(e.longest_run_s, end - e.run_starts[r]);
  }
  return e;
}

std::vector<EffectModel> effect_catalogue(const Observations& obs, const TraceExtent& e, double lag_beyond_conventions_s,
                                          const MeasuredFriction& friction) {
  return {offset_model(obs),          ripple_model(obs, e),    position_friction_model(obs, e),
          thermal_drift_model(obs, e, friction), quadratic_viscous_model(obs), presliding_model(obs, e),
          compliance_model(obs, e),    delay_model(obs, e, lag_beyond_conventions_s)};
}

}  // namespace feedid::host::diag
