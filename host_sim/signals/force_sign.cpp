#include "force_sign.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace feedid::host {
namespace {

/// A force over a step of travel |dx| (the weight of the force in a mean over travel).
struct ForceOverTravel {
  double force = 0.0;
  double travel = 0.0;
};

/// Forces over the steps that move, per direction ([0]: dx > 0, [1]: dx < 0).
struct TravelForces {
  std::vector<ForceOverTravel> of[2];
  double travel[2] = {0.0, 0.0};
};

TravelForces travel_forces(const std::vector<double>& t, const std::vector<double>& x, const std::vector<double>& u,
                           double max_step_s) {
  TravelForces w;
  for (std::size_t k = 1; k < t.size() && k < x.size() && k < u.size(); ++k) {
    const double dx = x[k] - x[k - 1];
    if (t[k] - t[k - 1] > max_step_s || dx == 0.0 || !std::isfinite(u[k] * dx)) continue;
    const int d = dx > 0 ? 0 : 1;
    w.of[d].push_back({u[k], std::fabs(dx)});
    w.travel[d] += std::fabs(dx);
  }
  return w;
}

/// The force at which the travel, summed in order of force, passes
/// `travel` (< the total): weighted quickselect, reordering f.
double force_at_travel(std::vector<ForceOverTravel>& f, double travel) {
  auto first = f.begin(), last = f.end();
  const auto by_force = [](const ForceOverTravel& a, const ForceOverTravel& b) { return a.force < b.force; };
  while (last - first > 1) {
    const auto mid = first + (last - first) / 2;
    std::nth_element(first, mid, last, by_force);
    double lower = 0.0;
    for (auto it = first; it != mid; ++it) lower += it->travel;
    if (lower > travel) {
      last = mid;
    } else {
      travel -= lower;
      first = mid;
    }
  }
  return first->force;
}

/// The travel-weighted mean of the forces with kSignTrimmedShare of the
/// travel cut off at either end of their range (a step straddling a cut
/// counts with the part inside). The two cut forces are selected, not
/// sorted for: a sort of every moving sample was a twentieth of identify.
double trimmed_mean(std::vector<ForceOverTravel> f) {
  if (f.empty()) return 0.0;
  double total = 0.0;
  for (const auto& s : f) total += s.travel;
  const double lo = kSignTrimmedShare * total, hi = (1.0 - kSignTrimmedShare) * total;
  const double f_lo = force_at_travel(f, lo), f_hi = force_at_travel(f, hi);
  // Forces strictly between the cuts lie wholly inside; each cut force's
  // steps (ties included) span [travel below it, that plus their own].
  double sum = 0.0, kept = 0.0, below_lo = 0.0, at_lo = 0.0, below_hi = 0.0, at_hi = 0.0;
  for (const auto& s : f) {
    if (s.force < f_lo) below_lo += s.travel;
    else if (s.force == f_lo) at_lo += s.travel;
    if (s.force < f_hi) below_hi += s.travel;
    else if (s.force == f_hi) at_hi += s.travel;
    if (s.force > f_lo && s.force < f_hi) {
      sum += s.force * s.travel;
      kept += s.travel;
    }
  }
  auto add_cut = [&](double force, double below, double at) {
    const double inside = std::min(below + at, hi) - std::max(below, lo);
    if (inside > 0.0) {
      sum += force * inside;
      kept += inside;
    }
  };
  add_cut(f_lo, below_lo, at_lo);
  if (f_hi != f_lo) add_cut(f_hi, below_hi, at_hi);
  return kept > 0.0 ? sum / kept : 0.0;
}

/// The forces of both directions along the motion (u sign(dx)), or their magnitudes.
std::vector<ForceOverTravel> along_motion(const TravelForces& w, bool magnitude) {
  std::vector<ForceOverTravel> out;
  for (int d = 0; d < 2; ++d)
    for (const auto& s : w.of[d]) out.push_back({magnitude ? std::fabs(s.force) : (d == 0 ? s.force : -s.force), s.travel});
  return out;
}

}  // namespace

ForceSign find_force_sign(const std::vector<double>& t, const std::vector<double>& x, const std::vector<double>& u,
                          double max_step_s) {
  const TravelForces w = travel_forces(t, x, u, max_step_s);
  const double total = w.travel[0] + w.travel[1];
  ForceSign f;
  if (!(total > 0.0)) return f;  // no motion: as logged, ratio NaN
  f.both_directions = w.travel[0] >= 0.1 * total && w.travel[1] >= 0.1 * total;
  if (f.both_directions) {
    const double f_pos = trimmed_mean(w.of[0]), f_neg = trimmed_mean(w.of[1]);
    const double magnitude = std::fabs(f_pos) + std::fabs(f_neg);
    if (!(magnitude > 0.0)) return f;
    f.ratio = (f_pos - f_neg) / magnitude;
  } else {
    // Forces along the motion and their magnitudes share the travel
    // weights, and u sign(dx) <= |u| sample by sample, so their trimmed
    // means keep that order: the ratio is in [-1, 1].
    const double magnitude = trimmed_mean(along_motion(w, true));
    if (!(magnitude > 0.0)) return f;
    f.ratio = trimmed_mean(along_motion(w, false)) / magnitude;
  }
  f.conclusive = std::fabs(f.ratio) > kConclusiveSignRatio;
  f.sign = f.ratio < -kConclusiveSignRatio ? -1 : 1;
  return f;
}

ForceSign stated_force_sign(int sign) {
  ForceSign f;
  f.sign = sign < 0 ? -1 : 1;
  f.conclusive = f.stated = true;
  return f;
}

std::string ForceSign::describe() const {
  if (stated) return sign < 0 ? "negated, as stated" : "as logged, as stated";
  if (!std::isfinite(ratio)) return "as logged (no motion to check its sign by)";
  char evidence[160];
  std::snprintf(evidence, sizeof evidence, both_directions
                    ? "interquartile mean force over positive travel less that over negative travel: %+.0f %% of "
                      "their magnitudes"
                    : "interquartile mean force along the motion, which went one way only: %+.0f %% of that of its "
                      "magnitude",
                100.0 * ratio);
  char buf[400];
  if (sign < 0)
    std::snprintf(buf, sizeof buf, "negated: as logged it pushes against the motion (%s)", evidence);
  else if (conclusive)
    std::snprintf(buf, sizeof buf, "as logged (%s)", evidence);
  else
    std::snprintf(buf, sizeof buf,
                  "as logged, sign unconfirmed (%s: an offset such as gravity, or little motion); if the friction "
                  "comes out negative, the force is logged with the opposite sign (--force-scale -1)", evidence);
  return buf;
}

}  // namespace feedid::host
