#include "force_sign.hpp"

#include <cmath>
#include <cstdio>

namespace feedid::host {
namespace {

/// Force times travel and travel, per direction of the step.
struct TravelWork {
  double work[2] = {0.0, 0.0};    ///< sum u dx over steps with dx > 0, dx < 0
  double travel[2] = {0.0, 0.0};  ///< sum |dx| over the same steps
};

TravelWork travel_work(const std::vector<double>& t, const std::vector<double>& x, const std::vector<double>& u,
                       double max_step_s) {
  TravelWork w;
  for (std::size_t k = 1; k < t.size() && k < x.size() && k < u.size(); ++k) {
    const double dx = x[k] - x[k - 1];
    if (t[k] - t[k - 1] > max_step_s || dx == 0.0 || !std::isfinite(u[k] * dx)) continue;
    const int d = dx > 0 ? 0 : 1;
    w.work[d] += u[k] * dx;
    w.travel[d] += std::fabs(dx);
  }
  return w;
}

}  // namespace

ForceSign find_force_sign(const std::vector<double>& t, const std::vector<double>& x, const std::vector<double>& u,
                          double max_step_s) {
  const TravelWork w = travel_work(t, x, u, max_step_s);
  const double total = w.travel[0] + w.travel[1];
  ForceSign f;
  if (!(total > 0.0)) return f;  // no motion: as logged, ratio NaN
  f.both_directions = w.travel[0] >= 0.1 * total && w.travel[1] >= 0.1 * total;
  if (f.both_directions) {
    const double f_pos = w.work[0] / w.travel[0], f_neg = -w.work[1] / w.travel[1];
    const double magnitude = std::fabs(f_pos) + std::fabs(f_neg);
    if (!(magnitude > 0.0)) return f;
    f.ratio = (f_pos - f_neg) / magnitude;
  } else {
    const double absolute = std::fabs(w.work[0]) + std::fabs(w.work[1]);
    if (!(absolute > 0.0)) return f;
    f.ratio = (w.work[0] + w.work[1]) / absolute;
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
                    ? "mean force over positive travel less that over negative travel: %+.0f %% of their magnitudes"
                    : "net work on the motion, which went one way only: %+.0f %% of its absolute work",
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
