#include "gravity.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "io/number_format.hpp"
#include "signals/filters.hpp"

namespace feedid::host {
namespace {

/// Block means of the friction fit's residual against cos q and sin q, with
/// each direction's own level (the Coulomb terms keep the mean load of the
/// travel in each direction). Blocks of kBlock_s within one direction:
/// their means are close to independent, so the scatter gives the error.
struct AngleFit {
  bool ok = false;
  double a = 0.0, b = 0.0;   ///< G cos q0, G sin q0
  double cov[2][2] = {};     ///< of (a, b)
};

constexpr double kBlock_s = 0.05;
constexpr int kMaxRounds = 6;

/// Columns of the load fit: what the friction fit can still move (each
/// direction's level and slope, the mass) beside the load's cos q and sin q,
/// so that the load is not fitted to what correlates with them (a stroke's
/// speed with where on the travel it runs): fitted alone, it needed a dozen
/// alternations with the friction fit to settle.
enum Column { kLevelPos, kLevelNeg, kSlopePos, kSlopeNeg, kMass, kCos, kSin, kColumns };

/// Inverts the normal equations (Gauss-Jordan, partial pivots); false where
/// they are singular (the travel does not separate the columns).
bool invert(double A[kColumns][kColumns], double inv[kColumns][kColumns]) {
  for (int i = 0; i < kColumns; ++i)
    for (int j = 0; j < kColumns; ++j) inv[i][j] = i == j ? 1.0 : 0.0;
  double scale = 0.0;
  for (int i = 0; i < kColumns; ++i) scale = std::max(scale, std::fabs(A[i][i]));
  for (int c = 0; c < kColumns; ++c) {
    int p = c;
    for (int r = c + 1; r < kColumns; ++r)
      if (std::fabs(A[r][c]) > std::fabs(A[p][c])) p = r;
    if (!(std::fabs(A[p][c]) > 1e-13 * scale)) return false;
    std::swap(A[p], A[c]);
    std::swap(inv[p], inv[c]);
    const double d = A[c][c];
    for (int j = 0; j < kColumns; ++j) { A[c][j] /= d; inv[c][j] /= d; }
    for (int r = 0; r < kColumns; ++r) {
      if (r == c) continue;
      const double f = A[r][c];
      for (int j = 0; j < kColumns; ++j) { A[r][j] -= f * A[c][j]; inv[r][j] -= f * inv[c][j]; }
    }
  }
  return true;
}

struct Block {
  double row[kColumns] = {};  ///< time means of the columns
  double residual = 0.0;
  double tau = 0.0;
};

/// The slowest speed a block takes: velocity_min, or kAboveStribeck Stribeck
/// velocities where a direction has a dip. Below it the simulated drive's
/// stick and slip leave residuals the friction law does not have, at the
/// ends of the travel, where they took G 3 of its errors low (0.12 N m of
/// 30 on simulated arms; taken out, 0.006 +- 0.05).
double slowest_block_speed(const IdentifyResult& r, const DriveParams& p) {
  constexpr double kAboveStribeck = 3.0;
  double vs = 0.0;
  for (const DirectionFriction* f : {&p.pos, &p.neg})
    if (f->breakaway_N > 0.0) vs = std::max(vs, f->stribeck_velocity_m_s);
  return std::max(r.config.velocity_min_m_s, kAboveStribeck * vs);
}

std::vector<Block> residual_blocks(const IdentifyResult& r) {
  const Signals& s = r.signals;
  const DriveParams p = to_drive_params(r.estimate);
  const double slowest = slowest_block_speed(r, p);
  const std::vector<double> a = central_difference(s.v, s.t);
  std::vector<Block> out;
  Block cur;
  int dir = 0;
  const auto full = s.reached_at(kBlock_s), half = s.reached_at(0.5 * kBlock_s);
  auto close = [&]() {
    if (half.by(cur.tau)) {
      for (double& x : cur.row) x /= cur.tau;
      cur.residual /= cur.tau;
      out.push_back(cur);
    }
    cur = Block{};
  };
  for (std::size_t k = 1; k < s.t.size(); ++k) {
    const double dt = s.t[k] - s.t[k - 1];
    const int d = std::fabs(s.v[k]) < slowest ? 0 : (s.v[k] > 0 ? 1 : -1);
    if (d != dir || s.gap_before(k)) close();
    dir = d;
    if (d == 0) continue;
    const double res = s.u[k] - p.mass_kg * a[k] - stribeck_friction(p, s.v[k]);
    cur.row[d > 0 ? kLevelPos : kLevelNeg] += dt;
    cur.row[d > 0 ? kSlopePos : kSlopeNeg] += s.v[k] * dt;
    cur.row[kMass] += a[k] * dt;
    cur.row[kCos] += std::cos(s.x[k]) * dt;
    cur.row[kSin] += std::sin(s.x[k]) * dt;
    cur.residual += res * dt;
    cur.tau += dt;
    if (full.by(cur.tau)) close();
  }
  close();
  return out;
}

/// The least-squares fit of the blocks `use` keeps: (cos, sin) coefficients
/// and their covariance from the blocks' scatter. A column no kept block
/// touches (the other direction's) is held at 0.
template <typename Use>
AngleFit fit_blocks(const std::vector<Block>& blocks, Use use) {
  AngleFit f;
  double A[kColumns][kColumns] = {}, y[kColumns] = {}, inv[kColumns][kColumns];
  std::size_t n = 0;
  for (const Block& b : blocks) {
    if (!use(b)) continue;
    ++n;
    for (int i = 0; i < kColumns; ++i) {
      y[i] += b.row[i] * b.residual;
      for (int j = 0; j < kColumns; ++j) A[i][j] += b.row[i] * b.row[j];
    }
  }
  if (n < 4 * kColumns) return f;
  for (int i = 0; i < kColumns; ++i)
    if (A[i][i] == 0.0) A[i][i] = 1.0;
  if (!invert(A, inv)) return f;
  double beta[kColumns] = {};
  for (int i = 0; i < kColumns; ++i)
    for (int j = 0; j < kColumns; ++j) beta[i] += inv[i][j] * y[j];
  double ss = 0.0;
  for (const Block& b : blocks) {
    if (!use(b)) continue;
    double e = b.residual;
    for (int i = 0; i < kColumns; ++i) e -= beta[i] * b.row[i];
    ss += e * e;
  }
  const double s2 = ss / static_cast<double>(n - kColumns);
  f.ok = true;
  f.a = beta[kCos];
  f.b = beta[kSin];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) f.cov[i][j] = s2 * inv[kCos + i][kCos + j];
  return f;
}

/// The load fitted to every block, its covariance widened by how far the
/// fits of each direction's blocks alone part: residuals the friction law
/// does not have (stick and slip at the travel's ends, a different pattern
/// each way) shift the load without adding scatter, and block scatter alone
/// covered q0 in 3 of 12 simulated arms.
AngleFit fit_angle(const IdentifyResult& r) {
  const std::vector<Block> blocks = residual_blocks(r);
  AngleFit f = fit_blocks(blocks, [](const Block&) { return true; });
  if (!f.ok) return f;
  const AngleFit pos = fit_blocks(blocks, [](const Block& b) { return b.row[kLevelPos] > 0.0; });
  const AngleFit neg = fit_blocks(blocks, [](const Block& b) { return b.row[kLevelNeg] > 0.0; });
  if (pos.ok && neg.ok) {
    const double da = 0.5 * (pos.a - neg.a), db = 0.5 * (pos.b - neg.b);
    f.cov[0][0] += da * da;
    f.cov[0][1] += da * db;
    f.cov[1][0] += da * db;
    f.cov[1][1] += db * db;
  }
  return f;
}

/// The prepared signals with the load a cos q + b sin q + c taken off the
/// force (oriented: the load is a force on the motion, whatever sign the
/// log had), at the angle x as aligned with the force: where the alignment
/// delayed the motion by whole samples (a force logged late), a force
/// sample carries the load of that earlier angle, which is where x puts it
/// (and where fit_angle and diagnose's load prediction read it).
Signals without_load(Signals s, double a, double b, double c) {
  for (std::size_t k = 0; k < s.u.size(); ++k) s.u[k] -= a * std::cos(s.x[k]) + b * std::sin(s.x[k]) + c;
  return s;
}

double travel_span(const Signals& s) {
  if (s.x.empty()) return 0.0;
  auto [lo, hi] = std::minmax_element(s.x.begin(), s.x.end());
  return *hi - *lo;
}

/// The prepared signals the rounds start from, where to say so, and the
/// options each round identifies with (no gravity term: that is the rounds').
struct Rounds {
  const Signals& prepared;
  const IdentifyOptions& base;
  const std::string& source;
  const std::vector<std::size_t>& run_starts;
  IdentifyResult without(double a, double b, double c) const {
    return identify_prepared(without_load(prepared, a, b, c), base, source, run_starts);
  }
};

/// Each direction's Coulomb term takes the load with opposite signs, and a
/// load beyond the friction turns one negative and the fit's law with it:
/// so G is refitted on the friction fitted without the last G until its step
/// is a tenth of its standard error.
IdentifyResult with_constant(const Rounds& rounds, IdentifyResult r0) {
  auto half_difference = [](const IdentifyResult& r) { return 0.5 * (r.estimate.pos.coulomb_N - r.estimate.neg.coulomb_N); };
  auto its_se = [](const IdentifyResult& r) { return 0.5 * std::hypot(r.estimate.pos.coulomb_se, r.estimate.neg.coulomb_se); };
  double G = 0.0;
  IdentifyResult r = r0;
  for (int round = 0; round < kMaxRounds; ++round) {
    const double step = half_difference(r);
    G += step;
    IdentifyResult next = rounds.without(0.0, 0.0, G);
    if (!next.error.empty()) return r0;
    r = std::move(next);
    if (std::fabs(step) < 0.1 * its_se(r) && round > 0) break;
  }
  r.gravity = {GravityTerm::constant, G, its_se(r), 0.0, 0.0,
               "G = (Fc+ - Fc-)/2, taken off the force and refitted until it settles: Coulomb friction assumed the "
               "same both ways (the data cannot tell a constant load from their difference)"};
  return r;
}

IdentifyResult with_angle(const Rounds& rounds, IdentifyResult r0, bool automatic) {
  const double span = travel_span(rounds.prepared);
  if (automatic && span < kGravityMinSpan_rad) {
    std::ostringstream o;
    o << "none: the axis turns " << std::setprecision(2) << span << " rad, too little to tell G cos(q - q0) from friction";
    r0.gravity.note = o.str();
    return r0;
  }
  double a = 0.0, b = 0.0;
  IdentifyResult r = r0;
  AngleFit f;
  // The friction fit without the load took up part of it (Column); the load
  // is refitted on what the next friction fit leaves until its step is a
  // tenth of its standard error (the Stribeck terms are not in the columns).
  for (int round = 0; round < kMaxRounds; ++round) {
    f = fit_angle(r);
    if (!f.ok) break;
    a += f.a;
    b += f.b;
    const bool settled = std::hypot(f.a, f.b) < 0.1 * std::sqrt(f.cov[0][0] + f.cov[1][1]);
    if (settled && round > 0) break;
    IdentifyResult next = rounds.without(a, b, 0.0);
    if (!next.error.empty()) { f.ok = false; break; }
    r = std::move(next);
  }
  if (!f.ok) {
    r0.gravity.note = "none: the travel does not separate G cos(q - q0) from each direction's friction";
    return r0;
  }
  const double G = std::hypot(a, b);
  // Delta method from (a, b) to (G, q0), with the last round's covariance.
  const double ca = a / G, cb = b / G;
  const double var_G = ca * ca * f.cov[0][0] + 2 * ca * cb * f.cov[0][1] + cb * cb * f.cov[1][1];
  const double var_q = (cb * cb * f.cov[0][0] - 2 * ca * cb * f.cov[0][1] + ca * ca * f.cov[1][1]) / (G * G);
  const double G_se = std::sqrt(std::max(var_G, 0.0));
  const double coulomb = 0.5 * (std::fabs(r0.estimate.pos.coulomb_N) + std::fabs(r0.estimate.neg.coulomb_N));
  if (automatic && !(G >= kGravityMinZ * G_se && G >= kGravityMinShareOfCoulomb * coulomb)) {
    std::ostringstream o;
    const Rounded g = round_to_se(G, G_se);  // the digits its error justifies
    o << "none: G cos(q - q0) came out at " << g.value << " +- " << g.se << ", under " << kGravityMinZ
      << " standard errors or a tenth of the Coulomb friction";
    r0.gravity.note = o.str();
    return r0;
  }
  r.gravity = {GravityTerm::angle, G, G_se, std::atan2(b, a), std::sqrt(std::max(var_q, 0.0)),
               "G cos(q - q0) fitted to the friction fit's residual (50 ms block means, beside each direction's level "
               "and slope and the mass), taken off the force and the friction fitted again until G settles"};
  return r;
}

}  // namespace

ModelLoad gravity_load(const GravityFit& g) {
  ModelLoad load;
  if (g.form == GravityTerm::constant) load.offset_N = g.G;
  if (g.form == GravityTerm::angle) {
    load.gravity_N = g.G;
    load.gravity_angle0_rad = g.angle0_rad;
  }
  return load;
}

const char* gravity_name(GravityTerm g) {
  switch (g) {
    case GravityTerm::none: return "none";
    case GravityTerm::constant: return "constant";
    case GravityTerm::angle: return "angle";
    case GravityTerm::automatic: return "auto";
  }
  return "?";
}

bool gravity_from_name(const std::string& name, GravityTerm& g) {
  for (GravityTerm t : {GravityTerm::none, GravityTerm::constant, GravityTerm::angle, GravityTerm::automatic})
    if (name == gravity_name(t)) { g = t; return true; }
  return false;
}

IdentifyResult identify_with_gravity(Signals prepared, const IdentifyOptions& opt, const std::string& source,
                                     const std::vector<std::size_t>& run_starts) {
  IdentifyOptions base = opt;
  base.gravity = GravityTerm::none;
  IdentifyResult r0 = identify_prepared(prepared, base, source, run_starts);
  if (!r0.error.empty() || opt.gravity == GravityTerm::none) return r0;
  const Rounds rounds{prepared, base, source, run_starts};
  if (opt.gravity == GravityTerm::constant) return with_constant(rounds, std::move(r0));
  const bool rotary = opt.units.position == "rad";
  if (rotary && !prepared.has_position) {  // an angle integrated from the velocity has no zero: cos(q - q0) has no q
    if (opt.gravity == GravityTerm::angle) r0.error = kGravityAngleNeedsPosition;
    else r0.gravity.note = "none: the log has no position, so the arm's angle is unknown";
    return r0;
  }
  if (!rotary) {
    r0.gravity.note = "";  // automatic (the default) on a linear axis: nothing to say on every linear log
    if (opt.gravity == GravityTerm::angle) r0.error = "--gravity angle needs a rotary axis (--axis rotary, position in rad)";
    return r0;
  }
  return with_angle(rounds, std::move(r0), opt.gravity == GravityTerm::automatic);
}

}  // namespace feedid::host
