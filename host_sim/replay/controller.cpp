// The controller file and the gains a logged command reveals (controller.hpp).
#include "controller.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>

#include "model/drive_model.hpp"

namespace feedid::host {
namespace {

/// Records the reader's first refusal (outcome.hpp); the reader returns at
/// its next check, and what a helper returned after it is never used.
void refuse(Controller& c, const std::string& what) {
  if (c.error.empty()) c.error = c.source + ": " + what;
}

double required_number(const nlohmann::json& j, const char* key, Controller& c) {
  const nlohmann::json* v = j.contains(key) ? &j.at(key) : nullptr;
  if (!v) refuse(c, std::string("missing key '") + key + "'");
  else if (!v->is_number() || !std::isfinite(v->get<double>())) refuse(c, std::string("'") + key + "' must be a finite number");
  else return v->get<double>();
  return std::numeric_limits<double>::quiet_NaN();
}

/// A gain the file states, or none (to be fitted from the logged command).
/// `why_positive`: for kp and kv, why 0 is no loop (a replay with it ran
/// and reported nonsense figures); empty for ki, where 0 is no integral.
std::optional<double> optional_gain(const nlohmann::json& j, const char* key, Controller& c,
                                    const char* why_positive = "") {
  if (!j.contains(key) || j.at(key).is_null()) return std::nullopt;
  const double g = required_number(j, key, c);
  if (*why_positive && !(g > 0.0)) refuse(c, std::string("'") + key + "' must be > 0 (" + why_positive + ")");
  else if (g < 0.0) refuse(c, std::string("'") + key + "' must be >= 0");
  return g;
}

std::string column_name(const nlohmann::json& j, const char* key, bool required, Controller& c) {
  if (!j.contains(key) || (!required && j.at(key).is_null())) {
    if (required) refuse(c, std::string("missing key '") + key + "' (the column of the logged position reference)");
    return "";
  }
  if (!j.at(key).is_string() || j.at(key).get<std::string>().empty()) {
    refuse(c, std::string("'") + key + "' must be a column name (a non-empty string)");
    return "";
  }
  return j.at(key).get<std::string>();
}

std::vector<double> fir_taps(const nlohmann::json& j, Controller& c) {
  if (!j.contains("position_fir")) {
    refuse(c, "missing key 'position_fir' (e.g. [1] for none, [0.5, 0.5])");
    return {1.0};
  }
  const nlohmann::json& a = j.at("position_fir");
  if (!a.is_array() || a.empty()) {
    refuse(c, "'position_fir' must be a non-empty array of numbers");
    return {1.0};
  }
  std::vector<double> taps;
  double sum = 0.0;
  for (const auto& v : a) {
    if (!v.is_number() || !std::isfinite(v.get<double>())) {
      refuse(c, "'position_fir' must hold finite numbers");
      return {1.0};
    }
    taps.push_back(v.get<double>());
    sum += taps.back();
  }
  // A position filter passes a standing position unchanged.
  if (std::fabs(sum - 1.0) > 1e-6) refuse(c, "'position_fir' taps must sum to 1 (they sum to " + std::to_string(sum) + ")");
  return taps;
}

}  // namespace

const char* law_name(ControlLaw law) { return law == ControlLaw::p_pi ? "p_pi" : "pd"; }

Controller controller_from_json(const nlohmann::json& j, const std::string& source) {
  Controller c;
  c.source = source;
  if (!j.is_object()) {
    refuse(c, "a controller file must be a JSON object");
    return c;
  }
  if (j.contains("law")) {
    const nlohmann::json& l = j.at("law");
    if (l == "pd") c.law = ControlLaw::pd;
    else if (l == "p_pi") c.law = ControlLaw::p_pi;
    else refuse(c, "'law' must be \"pd\" or \"p_pi\", not " + l.dump());
  }
  c.kp = optional_gain(j, "kp", c, "with kp 0 the loop does not hold the position");
  c.kv = optional_gain(j, "kv", c, "with kv 0 the loop commands no force");
  c.ki = optional_gain(j, "ki", c);
  c.drive_gain = required_number(j, "drive_gain", c);
  if (!(c.drive_gain > 0.0)) refuse(c, "'drive_gain' must be > 0 (force per command unit)");
  c.saturation = required_number(j, "saturation", c);
  if (!(c.saturation > 0.0)) refuse(c, "'saturation' must be > 0 (the command limit)");
  c.position_fir = fir_taps(j, c);
  const double d = required_number(j, "delay_samples", c);
  if (!(d >= 0.0 && d == std::floor(d) && d <= 1000.0)) refuse(c, "'delay_samples' must be a whole number of samples, 0 to 1000");
  else c.delay_samples = static_cast<int>(d);
  c.reference = column_name(j, "reference", true, c);
  c.extra_command = column_name(j, "extra_command", false, c);
  if (!c.error.empty()) return c;
  static const std::set<std::string> known = {"law", "kp", "kv", "ki", "drive_gain", "saturation", "position_fir",
                                              "delay_samples", "reference", "extra_command", "comment"};
  for (const auto& [key, value] : j.items())
    if (!known.count(key)) c.warnings.push_back(source + ": unknown key '" + key + "' (ignored)");
  if (c.law == ControlLaw::pd && c.ki && *c.ki != 0.0)
    c.warnings.push_back(source + ": 'ki' is ignored under law \"pd\" (\"p_pi\" has an integral gain)");
  return c;
}

Controller read_controller_file(const std::string& path) {
  return read_json_file_as<Controller>(path, controller_from_json);
}

double VelocityEstimate::next(double q) {
  if (!started_) std::fill(q_.begin(), q_.end(), q);  // at rest before the first sample
  for (std::size_t i = q_.size() - 1; i > 0; --i) q_[i] = q_[i - 1];
  q_[0] = q;
  double qf = 0.0;
  for (std::size_t i = 0; i < fir_.size(); ++i) qf += fir_[i] * q_[i];
  const double dq = started_ ? (qf - qf_prev_) / dt_ : 0.0;
  started_ = true;
  qf_prev_ = qf;
  return dq;
}

bool needs_fit(const Controller& c) { return !c.kp || !c.kv || (c.law == ControlLaw::p_pi && !c.ki); }

Outcome<Gains> resolve_gains(const Controller& c, const GainFit& fit, std::vector<std::string>& notes) {
  if (!fit.error.empty()) return refused<Gains>(fit.error);
  Gains g;
  g.kp = c.kp ? *c.kp : fit.value.kp;
  g.kv = c.kv ? *c.kv : fit.value.kv;
  g.ki = c.law == ControlLaw::pd ? 0.0 : (c.ki ? *c.ki : fit.value.ki);
  // A fitted integral gain below 0 by less than two of its standard errors
  // is no gain the log shows (EMPS's P loop fitted as p_pi: ki -0.0011 +-
  // 0.0009): the loop has none, and the sign test below is for the others.
  if (c.law == ControlLaw::p_pi && !c.ki && g.ki < 0.0 && -g.ki <= 2.0 * fit.se.ki) {
    notes.push_back(c.source + ": the fitted ki " + std::to_string(g.ki) + " +- " + std::to_string(fit.se.ki) +
                    " is 0 within two standard errors: the loop is replayed with ki 0");
    g.ki = 0.0;
  }
  // A loop that pushes with the error is no position loop: the log's
  // command does not follow the law (a force of the other sign, another
  // reference column), and a replay with such gains would only diverge.
  const bool fitted_wrong = (!c.kp && !(g.kp > 0.0)) || (!c.kv && !(g.kv > 0.0)) ||
                            (c.law == ControlLaw::p_pi && !c.ki && g.ki < 0.0);
  if (fitted_wrong)
    return refused<Gains>(c.source + ": the gains fitted from the logged command are not those of a position "
                          "loop (kp " + std::to_string(g.kp) + ", kv " + std::to_string(g.kv) + ", ki " +
                          std::to_string(g.ki) + "): is the force's sign that of the command, and '" +
                          c.reference + "' the position reference?");
  return {g, ""};
}

namespace {

/// The loop's gains and the extra command's gain from the regression's
/// coefficients: b0 = kv kp, b1 = -kv (b2 = ki kp, b3 = -ki, b4 = ki I0 for
/// p_pi), then the extra command's gain.
struct LoopGains {
  double kp = 0.0, kv = 0.0, ki = 0.0, extra = 0.0;
};
LoopGains gains_of(const Eigen::VectorXd& b, bool pi, int p_loop, bool has_extra) {
  LoopGains g;
  g.kv = -b(1);
  g.kp = b(0) / g.kv;
  if (pi) g.ki = -b(3);
  if (has_extra) g.extra = b(p_loop);
  return g;
}

/// Standard errors by a delete-one-block jackknife over 20 contiguous
/// blocks of the fitted samples: the residual of a logged command is
/// correlated from sample to sample (quantised position, unmodelled
/// filters), and the white-noise formula then claims digits the log does
/// not hold (on EMPS it gave kv +- 0.008, the jackknife +- 0.019).
LoopGains jackknife_se(const Eigen::MatrixXd& A, const Eigen::VectorXd& y, bool pi, int p_loop, bool has_extra) {
  constexpr Eigen::Index kBlocks = 20;
  const Eigen::Index n = A.rows();
  const Eigen::MatrixXd AtA = A.transpose() * A;
  const Eigen::VectorXd Aty = A.transpose() * y;
  std::vector<LoopGains> out;
  for (Eigen::Index i = 0; i < kBlocks; ++i) {
    const Eigen::Index first = i * n / kBlocks, rows = (i + 1) * n / kBlocks - first;
    const auto Ab = A.middleRows(first, rows);
    const Eigen::MatrixXd M = AtA - Ab.transpose() * Ab;
    const Eigen::VectorXd v = Aty - Ab.transpose() * y.segment(first, rows);
    out.push_back(gains_of(M.ldlt().solve(v), pi, p_loop, has_extra));
  }
  auto spread = [&](double LoopGains::*g) {
    double mean = 0.0, ss = 0.0;
    for (const LoopGains& o : out) mean += o.*g / kBlocks;
    for (const LoopGains& o : out) ss += (o.*g - mean) * (o.*g - mean);
    return std::sqrt((kBlocks - 1.0) / kBlocks * ss);
  };
  return {spread(&LoopGains::kp), spread(&LoopGains::kv), spread(&LoopGains::ki), spread(&LoopGains::extra)};
}

/// The fit at one lag: the logged command at k against the regressors at k - lag.
GainFit fit_at_lag(const Controller& c, const std::vector<double>& t, const std::vector<double>& x,
                   const std::vector<double>& u, const std::vector<double>& reference,
                   const std::vector<double>& extra, int lag) {
  const std::size_t n = t.size();
  const double dt = (t.back() - t.front()) / static_cast<double>(n - 1);
  const bool pi = c.law == ControlLaw::p_pi, has_extra = !extra.empty();
  const int p_loop = pi ? 5 : 2, p = p_loop + (has_extra ? 1 : 0);
  // Regressors from the measured position: e = r - q, dq, and their integrals.
  std::vector<std::array<double, 6>> rows(n);
  VelocityEstimate vel(c.position_fir, dt);
  double E = 0.0, D = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double e = reference[k] - x[k], dq = vel.next(x[k]);
    rows[k] = {e, dq, E, D, 1.0, 0.0};  // the integrals of the errors before k, as the law uses them
    E += e * dt;
    D += dq * dt;
  }
  std::vector<std::size_t> used;
  const auto L = static_cast<std::size_t>(lag);
  for (std::size_t k = L + 1; k < n; ++k) {
    const double cmd = u[k] / c.drive_gain - (extra.empty() ? 0.0 : extra[k]);
    if (std::isfinite(cmd) && std::fabs(cmd) < 0.95 * c.saturation) used.push_back(k);
  }
  GainFit f;
  if (used.size() < static_cast<std::size_t>(10 * p)) {
    f.error = c.source + ": only " + std::to_string(used.size()) +
              " unsaturated samples to identify the missing gains from the logged command";
    return f;
  }
  Eigen::MatrixXd A(used.size(), p);
  Eigen::VectorXd y(used.size());
  for (std::size_t i = 0; i < used.size(); ++i) {
    const std::size_t k = used[i];
    for (int j = 0; j < p_loop; ++j) A(static_cast<Eigen::Index>(i), j) = rows[k - L][static_cast<std::size_t>(j)];
    // The extra command enters at k, after the delay, with its own gain.
    if (has_extra) A(static_cast<Eigen::Index>(i), p_loop) = extra[k];
    y(static_cast<Eigen::Index>(i)) = u[k] / c.drive_gain;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < p) {
    f.error = c.source + ": the log does not move enough to identify the missing gains "
                         "(the reference error and the velocity are not independent)";
    return f;
  }
  const Eigen::VectorXd b = qr.solve(y);
  const Eigen::VectorXd res = y - A * b;
  f.done = true;
  f.lag_samples = lag;
  f.samples = used.size();
  f.rms_residual = std::sqrt(res.squaredNorm() / static_cast<double>(used.size()));
  f.rms_command = std::sqrt(y.squaredNorm() / static_cast<double>(used.size()));
  const LoopGains full = gains_of(b, pi, p_loop, has_extra);
  const LoopGains se = jackknife_se(A, y, pi, p_loop, has_extra);
  f.value = {full.kp, full.kv, full.ki};
  f.se = {se.kp, se.kv, se.ki};
  if (has_extra) {
    f.extra_gain = full.extra;
    f.extra_gain_se = se.extra;
  }
  return f;
}

}  // namespace

GainFit fit_gains(const Controller& c, const std::vector<double>& t, const std::vector<double>& x,
                  const std::vector<double>& u, const std::vector<double>& reference,
                  const std::vector<double>& extra) {
  GainFit best = fit_at_lag(c, t, x, u, reference, extra, 0);
  if (c.delay_samples > 0 && best.error.empty()) {
    const GainFit delayed = fit_at_lag(c, t, x, u, reference, extra, c.delay_samples);
    if (delayed.error.empty() && delayed.rms_residual < best.rms_residual) best = delayed;
  }
  return best;
}

}  // namespace feedid::host
