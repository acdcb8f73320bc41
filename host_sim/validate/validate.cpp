#include "validate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "signals/condition.hpp"
#include "signals/filters.hpp"
#include "identify/identify.hpp"

namespace feedid::host {
namespace {

/// One stretch between gaps on the grid the protocol runs on: its own
/// samples when evenly logged, else its own clock at its median rate with
/// every column read onto it (filters.hpp, clock_grid): the force is
/// compared at the samples, so the grid must not drift off them.
struct ProtocolStretch {
  std::vector<double> t, x, v_column, u;
  double rate_hz = 0.0;
  bool resampled = false;
};

ProtocolStretch stretch_on_grid(const Signals& s, std::size_t first, std::size_t end) {
  auto part = [&](const std::vector<double>& y) {
    return std::vector<double>(y.begin() + static_cast<std::ptrdiff_t>(first), y.begin() + static_cast<std::ptrdiff_t>(end));
  };
  ProtocolStretch p{part(s.t), part(s.x), part(s.v), part(s.u), 0.0, false};
  p.rate_hz = 1.0 / median_step(p.t);
  const std::vector<double> grid = clock_grid(p.t, p.rate_hz);
  if (grid.empty()) return p;
  p.x = resample(p.t, p.x, grid);
  p.v_column = resample(p.t, p.v_column, grid);
  p.u = resample(p.t, p.u, grid);
  p.t = grid;
  p.resampled = true;
  return p;
}

/// Velocity and acceleration of one stretch as the EMPS protocol obtains
/// them: the position low-passed by a zero-phase 4th-order Butterworth,
/// then central differences (twice for acceleration). Without a position
/// column the velocity column is filtered and differentiated once.
void protocol_derivatives(const ProtocolStretch& p, bool has_position, double filter_hz, std::vector<double>& v,
                          std::vector<double>& a) {
  const double fc = applied_cutoff_hz(filter_hz, p.rate_hz);
  v = has_position ? central_difference(filtfilt_butter4(p.x, fc, p.rate_hz), p.t)
                   : filtfilt_butter4(p.v_column, fc, p.rate_hz);
  a = central_difference(v, p.t);
}

/// Speed below which a stretch's sample is at standstill (m/s): a millionth
/// of its top speed, or the speed the rounding of its logged positions
/// makes (64 units in the last place of the largest per period), if more.
/// At standstill the filtered position's difference is rounding, and its
/// sign put +-Fc in the prediction: moving the position's origin by 0.5 m
/// moved a production run's full-rate error from 26.8 to 28.0 %. A
/// millionth of the top speed is far inside any Stribeck dip, where the
/// model cannot tell static friction anyway; F(0) = 0 there.
double standstill_speed(const std::vector<double>& v, const std::vector<double>& x, double rate_hz) {
  double v_top = 0.0, x_top = 0.0;
  for (const double s : v) v_top = std::max(v_top, std::fabs(s));
  for (const double p : x) x_top = std::max(x_top, std::fabs(p));
  return std::max(1e-6 * v_top, 64.0 * std::numeric_limits<double>::epsilon() * x_top * rate_hz);
}

/// Sums of squares of the error and of the force, over every stretch.
struct ErrorSums {
  double error = 0.0, force = 0.0;
  void add(double u, double u_hat) {
    error += (u - u_hat) * (u - u_hat);
    force += u * u;
  }
  /// 100 ||u - u_hat|| / ||u||, or an error naming why when there is no
  /// measured force to be relative to or a sum is not finite (it printed
  /// "-nan %" and exited 0).
  Outcome<double> relative_pct(const std::string& source) const {
    if (!std::isfinite(error) || !std::isfinite(force))
      return refused<double>(source + ": the " + (std::isfinite(force) ? "predicted" : "measured") +
                             " force is not finite: no relative error to form (a model parameter that is not a "
                             "finite number?)");
    if (!(force > 0.0))
      return refused<double>(source + ": the measured force is zero on every sample compared: no relative error "
                                      "to form (is --force the force column?)");
    return {100.0 * std::sqrt(error / force), ""};
  }
};

/// Adds one stretch to the sums and the decimated series: every sample
/// after the first drop_first (the filter's edge, as at the start of the
/// protocol), and the protocol's decimated samples.
void score_stretch(const DriveParams& model, const ProtocolStretch& p, bool has_position, const ValidateOptions& opt,
                   ErrorSums& full, ErrorSums& decimated, ValidateResult& r) {
  const std::size_t n = p.t.size(), first = static_cast<std::size_t>(opt.drop_first);
  if (n <= first || n < 3) return;  // nothing left after the filter's edge
  std::vector<double> v, a;
  protocol_derivatives(p, has_position, opt.filter_hz, v, a);
  const double fc = applied_cutoff_hz(opt.filter_hz, p.rate_hz);
  r.filter_applied_hz = r.filter_applied_hz > 0.0 ? std::min(r.filter_applied_hz, fc) : fc;
  r.filter_requested_hz = opt.filter_hz;
  const double still = has_position ? standstill_speed(v, p.x, p.rate_hz) : standstill_speed(v, {}, p.rate_hz);
  std::vector<double> u_hat(n);
  // validate() refuses an arm's load without x
  for (std::size_t k = 0; k < n; ++k)
    u_hat[k] = predict_force(model, std::fabs(v[k]) < still ? 0.0 : v[k], a[k]) + opt.load.at(has_position ? p.x[k] : 0.0);
  for (std::size_t k = first; k < n; ++k) full.add(p.u[k], u_hat[k]);
  // Protocol: each column low-passed (anti-alias, zero phase, at 0.8 of the
  // new Nyquist frequency, like MATLAB decimate's default) and every n-th
  // sample kept. Measured and predicted force are treated alike.
  std::vector<double> uf = p.u, uhf = u_hat;
  if (opt.decimate > 1) {
    const double fc = 0.8 * 0.5 * p.rate_hz / opt.decimate;
    uf = filtfilt_butter4(p.u, fc, p.rate_hz);
    uhf = filtfilt_butter4(u_hat, fc, p.rate_hz);
  }
  for (std::size_t k = first; k < n; k += static_cast<std::size_t>(opt.decimate)) {
    decimated.add(uf[k], uhf[k]);
    r.t.push_back(p.t[k]);
    r.u.push_back(uf[k]);
    r.u_hat.push_back(uhf[k]);
    r.v.push_back(v[k]);
  }
  ++r.stretches_scored;
  if (p.resampled) ++r.stretches_resampled;
}

}  // namespace

namespace {
/// Why the options or the trace's length leave nothing to validate, or empty.
std::string validate_refusal(const Trace& logged, const ValidateOptions& opt) {
  const std::size_t n = logged.samples.size();
  if (opt.decimate < 1) return "--decimate must be >= 1";
  if (opt.drop_first < 0) return "--drop-first must be >= 0";
  if (n < static_cast<std::size_t>(opt.drop_first) + 10u * static_cast<std::size_t>(opt.decimate))
    return logged.source + ": trace too short to validate: " + std::to_string(n) + " samples";
  return opt.load.refusal(logged.source, logged.has_position);
}
}  // namespace

ValidateResult validate(const DriveParams& model, const Trace& logged, const ValidateOptions& opt) {
  ValidateResult r;
  r.units = opt.units;
  r.time_origin_s = logged.time_origin_s;
  r.error = validate_refusal(logged, opt);
  if (!r.error.empty()) return r;
  // The force outliers bridged, and the time base, gaps, wrap and force
  // sign, as identify has them (force_outliers.hpp, condition.hpp): one
  // row of 1e12 would be all of ||u||.
  const Signals s = condition(bridge_force_outliers(logged, opt.units.force, r.force_outliers), ConditionOptions{});
  r.error = s.error;
  if (!r.error.empty()) return r;
  r.force_sign = s.force_sign;
  r.position_wrap = s.position_wrap;
  r.stretches_on_clock_slots = s.stretches_on_clock_slots;
  r.velocity_origin = logged.has_position ? "position, zero-phase Butterworth + central differences"
                                          : "velocity column, zero-phase Butterworth; acceleration by central differences";
  ErrorSums full, decimated;
  const auto parts = stretches(s);
  for (const auto& [first, end] : parts)
    score_stretch(model, stretch_on_grid(s, first, end), logged.has_position, opt, full, decimated, r);
  r.stretches = parts.size();
  r.samples_used = r.t.size();
  if (r.samples_used == 0) {
    r.error = logged.source + ": no stretch between time gaps is longer than --drop-first (" +
              std::to_string(opt.drop_first) + " samples): nothing to validate on";
    return r;
  }
  const Outcome<double> full_pct = full.relative_pct(logged.source), pct = decimated.relative_pct(logged.source);
  r.error = pct.ok() ? full_pct.error : pct.error;
  if (!r.error.empty()) return r;
  r.relative_error_full_pct = full_pct.value;
  r.relative_error_pct = pct.value;
  r.error_norm_N = std::sqrt(decimated.error);
  r.rms_error_N = std::sqrt(decimated.error / static_cast<double>(r.samples_used));
  return r;
}

std::string ValidateResult::filter_note() const { return cutoff_note(filter_requested_hz, filter_applied_hz, "the position was"); }

nlohmann::json to_json(const ValidateResult& r, const DriveParams& model, const ValidateOptions& opt) {
  nlohmann::json j = {{"relative_error_pct", r.relative_error_pct},
          {"relative_error_full_rate_pct", r.relative_error_full_pct},
          {"rms_error_N", r.rms_error_N},
          {"error_norm_N", r.error_norm_N},
          {"samples_used", r.samples_used},
          {"time_origin_s", r.time_origin_s},
          {"protocol",
           {{"position_filter", "zero-phase 4th-order Butterworth"},
            {"filter_hz", r.filter_applied_hz > 0.0 ? r.filter_applied_hz : opt.filter_hz},
            {"filter_requested_hz", opt.filter_hz},
            {"derivatives", "central differences"},
            {"drop_first", opt.drop_first},
            {"decimate", opt.decimate},
            {"anti_alias", "zero-phase 4th-order Butterworth at 0.8 x new Nyquist"}}},
          {"velocity", r.velocity_origin},
          {"stretches", r.stretches},
          {"stretches_scored", r.stretches_scored},
          {"stretches_resampled", r.stretches_resampled},
          {"stretches_on_clock_slots", r.stretches_on_clock_slots},
          {"force_outlier_rows", r.force_outliers.rows},
          {"force_outlier_limit", r.force_outliers.limit},
          {"force_saturation", r.force_outliers.saturation.to_json()},
          {"force_sign", r.force_sign.sign},
          {"force_sign_origin", r.force_sign.describe()},
          {"position_unwraps", r.position_wrap.wraps},
          {"model", model_json(model, r.units)},
          {"units", units_json(r.units)}};
  // Only a model with a load states it (the keys of one without are unchanged).
  if (opt.load.any()) put_load(j["model"], opt.load);
  return j;
}

}  // namespace feedid::host
