// Reference paths (motion_path.hpp). Host only.
#include "motion_path.hpp"

#include "model/constants.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace feedid::host {

namespace {


// Sine program: half-periods between 0.05 s and 1 s (10 Hz .. 0.5 Hz cycles),
// so that every block reverses several times within seconds.
constexpr double kSineMinHalfPeriod_s = 0.05;
constexpr double kSineMaxHalfPeriod_s = 1.0;

/// Uniform draws from one 64-bit stream (the same numbers on every platform).
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : rng_(seed ^ 0xD1B54A32D192ED03ull) {}
  double unit() { return static_cast<double>(rng_() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }
  double log_uniform(double lo, double hi) { return lo * std::pow(hi / lo, unit()); }
  int integer(int lo, int hi) { return lo + static_cast<int>(unit() * (hi - lo + 1)); }

 private:
  std::mt19937_64 rng_;
};

/// Appends pieces until the path covers `end_s`.
class PathBuilder {
 public:
  explicit PathBuilder(double end_s) : end_s_(end_s) {}
  bool full() const { return t_ >= end_s_; }
  double x() const { return x_; }
  std::vector<PathPiece> take() { return std::move(pieces_); }

  void dwell(double duration_s) { polynomial(duration_s, 0.0, 0.0); }

  /// Rest-to-rest move to x_to: a trapezoid at v_peak with acceleration
  /// accel, or a triangle when the distance is too short to reach v_peak.
  void move(double x_to, double v_peak, double accel) {
    const double d = std::fabs(x_to - x_), dir = x_to >= x_ ? 1.0 : -1.0;
    if (d <= 0.0) return;
    const double V = std::min(v_peak, std::sqrt(accel * d));
    const double t_acc = V / accel;
    const double d_cruise = d - V * t_acc;
    polynomial(t_acc, 0.0, dir * accel);
    if (d_cruise > 0.0) polynomial(d_cruise / V, dir * V, 0.0);
    polynomial(t_acc, dir * V, -dir * accel);
    x_ = x_to;  // exact, whatever the rounding of the pieces
  }

  /// Rest-to-rest half-cosine to x_to with peak speed v_peak, slowed so that
  /// the peak acceleration stays within accel.
  void half_cosine(double x_to, double v_peak, double accel) {
    const double d = std::fabs(x_to - x_);
    if (d <= 0.0) return;
    // v_peak = (d/2) pi / T, a_peak = (d/2) (pi / T)^2.
    const double T = std::max(0.5 * d * kPi / v_peak, kPi * std::sqrt(0.5 * d / accel));
    PathPiece p;
    p.shape = PathPiece::Shape::half_cosine;
    p.t0_s = t_;
    p.duration_s = T;
    p.x0_m = x_;
    p.x1_m = x_to;
    pieces_.push_back(p);
    t_ += T;
    x_ = x_to;
  }

 private:
  void polynomial(double duration_s, double v0, double a) {
    if (duration_s <= 0.0) return;
    PathPiece p;
    p.t0_s = t_;
    p.duration_s = duration_s;
    p.x0_m = x_;
    p.v0_m_s = v0;
    p.a_m_s2 = a;
    pieces_.push_back(p);
    t_ += duration_s;
    x_ = p.at(duration_s).x_m;
  }

  double end_s_;
  double t_ = 0.0, x_ = 0.0;
  std::vector<PathPiece> pieces_;
};

/// Peak speeds log-spaced between the slowest and the fastest.
std::vector<double> ladder_speeds(const MotionParams& m) {
  const int n = m.speed_levels;
  if (n == 1) return {m.fastest_speed_m_s};
  std::vector<double> speeds;
  const double ratio = m.fastest_speed_m_s / m.slowest_speed_m_s;
  for (int i = 0; i < n; ++i) speeds.push_back(m.slowest_speed_m_s * std::pow(ratio, double(i) / double(n - 1)));
  speeds.back() = m.fastest_speed_m_s;
  return speeds;
}

/// Each level: a + stroke and its - twin from x = 0, each a trapezoid that
/// cruises cruise_time (shortened to fit the travel) and then dwells.
void build_ladder(const MotionParams& m, PathBuilder& b) {
  const std::vector<double> speeds = ladder_speeds(m);
  const double A = m.acceleration_m_s2;
  while (!b.full()) {
    for (double V : speeds) {
      const double stroke = std::min(m.max_travel_m, V * V / A + V * m.cruise_time_s);
      b.move(stroke, V, A);
      b.dwell(m.dwell_s);
      b.move(0.0, V, A);
      b.dwell(m.dwell_s);
      if (b.full()) return;
    }
  }
}

/// Blocks of 2-4 cycles about mid-travel; per block a peak speed log-uniform
/// over [slowest, fastest] and a half-amplitude h log-uniform over what the
/// acceleration bound (h >= V^2/A), the travel and the half-period range allow.
void build_sine(const MotionParams& m, std::uint64_t seed, PathBuilder& b) {
  Draw draw(seed);
  const double A = m.acceleration_m_s2, centre = 0.5 * m.max_travel_m;
  while (!b.full()) {
    double V = draw.log_uniform(m.slowest_speed_m_s, m.fastest_speed_m_s);
    const double h_lo = std::max(V * V / A, V * kSineMinHalfPeriod_s / kPi);
    const double h_hi = std::min(centre, V * kSineMaxHalfPeriod_s / kPi);
    const double h = h_lo < h_hi ? draw.log_uniform(h_lo, h_hi) : h_hi;
    V = std::min(V, std::sqrt(A * h));
    const int cycles = draw.integer(2, 4);
    for (int i = 0; i < 2 * cycles; ++i) {
      // The first half-cycle starts at the last block's turning point; it may
      // run faster than V so that it, too, stays within the longest half-period.
      const double x_to = i % 2 == 0 ? centre + h : centre - h;
      const double V_min = 0.5 * std::fabs(x_to - b.x()) * kPi / kSineMaxHalfPeriod_s;
      b.half_cosine(x_to, std::max(V, V_min), A);
    }
  }
}

/// A part program: rapids to random positions at the top speed, feeds of
/// 0.5-3 s at three feed rates (3, 10 and 30 % of the top speed, each scaled
/// by U(0.7, 1.3) once), jogs of 0.2-3 mm at a slow speed, and dwells of
/// 0.2-1.5 s; every move settles for 20-200 ms.
void build_production(const MotionParams& m, std::uint64_t seed, PathBuilder& b) {
  Draw draw(seed);
  const double A = m.acceleration_m_s2, L = m.max_travel_m, rapid = m.fastest_speed_m_s;
  const double feeds[3] = {0.03 * rapid * draw.uniform(0.7, 1.3), 0.1 * rapid * draw.uniform(0.7, 1.3),
                           0.3 * rapid * draw.uniform(0.7, 1.3)};
  const double jog_lo = std::min(5.0 * m.slowest_speed_m_s, 0.02 * rapid);
  auto inside = [L](double x) { return x < 0.0 ? -x : (x > L ? 2.0 * L - x : x); };  // reflect at the ends
  while (!b.full()) {
    const double op = draw.unit();
    const double dir = draw.unit() < 0.5 ? -1.0 : 1.0;
    if (op < 0.2) {
      b.move(draw.uniform(0.0, L), rapid, A);
    } else if (op < 0.6) {
      const double feed = feeds[draw.integer(0, 2)];
      const double distance = std::min(draw.uniform(0.5, 3.0) * feed, 0.3 * L);
      b.move(inside(b.x() + dir * distance), feed, A);
    } else if (op < 0.8) {
      const double jog = draw.log_uniform(jog_lo, 0.02 * rapid);
      b.move(std::clamp(b.x() + dir * draw.log_uniform(2e-4, 3e-3), 0.0, L), jog, A);
    } else {
      b.dwell(draw.uniform(0.2, 1.5));
      continue;
    }
    b.dwell(draw.uniform(0.02, 0.2));
  }
}

}  // namespace

const char* program_name(Program p) {
  switch (p) {
    case Program::ladder: return "ladder";
    case Program::sine: return "sine";
    case Program::production: return "production";
  }
  return "?";
}

Outcome<Program> parse_program(const std::string& s) {
  for (Program p : {Program::ladder, Program::sine, Program::production})
    if (s == program_name(p)) return {p, ""};
  return refused<Program>("--program must be ladder, sine or production, not '" + s + "'");
}

PathPoint PathPiece::at(double tau) const {
  PathPoint p;
  if (shape == Shape::polynomial) {
    p.x_m = x0_m + v0_m_s * tau + 0.5 * a_m_s2 * tau * tau;
    p.v_m_s = v0_m_s + a_m_s2 * tau;
    p.a_m_s2 = a_m_s2;
  } else {
    // x = c + h cos(pi tau / T): rest at both ends.
    const double c = 0.5 * (x0_m + x1_m), h = 0.5 * (x0_m - x1_m), w = kPi / duration_s;
    p.x_m = c + h * std::cos(w * tau);
    p.v_m_s = -h * w * std::sin(w * tau);
    p.a_m_s2 = -h * w * w * std::cos(w * tau);
  }
  return p;
}

MotionPath::MotionPath(const MotionParams& m, std::uint64_t seed) {
  PathBuilder b(m.duration_s + 1.0);  // a second beyond the end: the simulators look one period ahead
  switch (m.program) {
    case Program::ladder: build_ladder(m, b); break;
    case Program::sine: build_sine(m, seed, b); break;
    case Program::production: build_production(m, seed, b); break;
  }
  pieces_ = b.take();
}

PathPoint MotionPath::at(double t_s) {
  if (pieces_.empty()) return {};  // no stroke fits: the axis rests at 0 (sim_config_error refuses such a program)
  while (cursor_ + 1 < pieces_.size() && t_s >= pieces_[cursor_].t0_s + pieces_[cursor_].duration_s) ++cursor_;
  const PathPiece& p = pieces_[cursor_];
  return p.at(std::clamp(t_s - p.t0_s, 0.0, p.duration_s));
}

}  // namespace feedid::host
