#include "validate.hpp"

#include <cmath>
#include <stdexcept>

#include "signals/filters.hpp"
#include "identify/identify.hpp"

namespace feedid::host {
namespace {

std::vector<double> column(const Trace& tr, double TraceSample::*field) {
  std::vector<double> out;
  out.reserve(tr.samples.size());
  for (const auto& s : tr.samples) out.push_back(s.*field);
  return out;
}

double sample_rate(const std::vector<double>& t) {
  return static_cast<double>(t.size() - 1) / (t.back() - t.front());
}

/// The force with the sign that makes it do positive net work on the motion
/// (force_sign.hpp), as identify orients it: a model identified on a
/// reversed log predicts the force the right way round.
void orient_force(const Trace& trace, const std::vector<double>& t, std::vector<double>& u, ForceSign& sign) {
  const double gap_s = max_step_s(median_step(t));
  const std::vector<double> x = trace.has_position ? column(trace, &TraceSample::x_m)
                                                   : integrate_velocity(column(trace, &TraceSample::v_m_s), t, gap_s);
  sign = find_force_sign(t, x, u, gap_s);
  if (sign.sign < 0)
    for (double& f : u) f = -f;
}

/// The trace with a wrapped position run on (position_wrap.hpp), as
/// identify reads it.
Trace unwrapped(const Trace& logged, PositionWrap& wrap) {
  Trace trace = logged;
  if (!trace.has_position) return trace;
  const std::vector<double> t = column(trace, &TraceSample::t_s);
  std::vector<double> x = column(trace, &TraceSample::x_m);
  wrap = unwrap_position(t, x, max_step_s(median_step(t)));
  for (std::size_t k = 0; wrap.found() && k < x.size(); ++k) trace.samples[k].x_m = x[k];
  return trace;
}

/// A relative error ||u - u_hat|| / ||u|| needs a measured force to be
/// relative to and finite sums; without them it printed "-nan %" and exited 0.
void check_relative_error(double error_squares, double force_squares, const std::string& source) {
  if (!std::isfinite(error_squares) || !std::isfinite(force_squares))
    throw std::invalid_argument(source + ": the " + (std::isfinite(force_squares) ? "predicted" : "measured") +
                                " force is not finite: no relative error to form (a model parameter that is not a "
                                "finite number?)");
  if (!(force_squares > 0.0))
    throw std::invalid_argument(source + ": the measured force is zero on every sample compared: no relative error "
                                         "to form (is --force the force column?)");
}

}  // namespace

void protocol_derivatives(const Trace& trace, double filter_hz, std::vector<double>& v, std::vector<double>& a) {
  const std::vector<double> t = column(trace, &TraceSample::t_s);
  const double fs = sample_rate(t);
  const double fc = std::min(filter_hz, 0.4 * fs);
  if (trace.has_position) {
    v = central_difference(filtfilt_butter4(column(trace, &TraceSample::x_m), fc, fs), t);
  } else {
    v = filtfilt_butter4(column(trace, &TraceSample::v_m_s), fc, fs);
  }
  a = central_difference(v, t);
}

ValidateResult validate(const DriveParams& model, const Trace& logged, const ValidateOptions& opt) {
  if (opt.decimate < 1) throw std::invalid_argument("--decimate must be >= 1");
  if (opt.drop_first < 0) throw std::invalid_argument("--drop-first must be >= 0");
  ValidateResult r;
  r.units = opt.units;
  // The force outliers bridged as identify bridges them (force_outliers.hpp):
  // one row of 1e12 would be all of ||u||.
  const Trace trace = unwrapped(bridge_force_outliers(logged, opt.units.force, r.force_outliers), r.position_wrap);
  const std::size_t n = trace.samples.size();
  if (n < static_cast<std::size_t>(opt.drop_first) + 10u * static_cast<std::size_t>(opt.decimate))
    throw std::invalid_argument(logged.source + ": trace too short to validate: " + std::to_string(n) + " samples");
  r.velocity_origin = trace.has_position ? "position, zero-phase Butterworth + central differences"
                                         : "velocity column, zero-phase Butterworth; acceleration by central differences";
  std::vector<double> v, a;
  protocol_derivatives(trace, opt.filter_hz, v, a);
  std::vector<double> u = column(trace, &TraceSample::u_N);
  const std::vector<double> t = column(trace, &TraceSample::t_s);
  orient_force(trace, t, u, r.force_sign);
  std::vector<double> u_hat(n);
  for (std::size_t k = 0; k < n; ++k) u_hat[k] = predict_force(model, v[k], a[k]);

  // Every sample (after the dropped start), no decimation.
  double e2 = 0.0, u2 = 0.0;
  for (std::size_t k = static_cast<std::size_t>(opt.drop_first); k < n; ++k) {
    e2 += (u[k] - u_hat[k]) * (u[k] - u_hat[k]);
    u2 += u[k] * u[k];
  }
  check_relative_error(e2, u2, trace.source);
  r.relative_error_full_pct = 100.0 * std::sqrt(e2 / u2);

  // Protocol: each column low-passed (anti-alias, zero phase, at 0.8 of the
  // new Nyquist frequency, like MATLAB decimate's default) and every n-th
  // sample kept. Measured and predicted force are treated alike.
  std::vector<double> uf = u, uhf = u_hat;
  if (opt.decimate > 1) {
    const double fs = sample_rate(t);
    const double fc = 0.8 * 0.5 * fs / opt.decimate;
    uf = filtfilt_butter4(u, fc, fs);
    uhf = filtfilt_butter4(u_hat, fc, fs);
  }
  e2 = u2 = 0.0;
  for (std::size_t k = static_cast<std::size_t>(opt.drop_first); k < n; k += static_cast<std::size_t>(opt.decimate)) {
    const double e = uf[k] - uhf[k];
    e2 += e * e;
    u2 += uf[k] * uf[k];
    r.t.push_back(t[k]);
    r.u.push_back(uf[k]);
    r.u_hat.push_back(uhf[k]);
    r.v.push_back(v[k]);
  }
  r.samples_used = r.t.size();
  check_relative_error(e2, u2, trace.source);
  r.relative_error_pct = 100.0 * std::sqrt(e2 / u2);
  r.error_norm_N = std::sqrt(e2);
  r.rms_error_N = std::sqrt(e2 / static_cast<double>(r.samples_used));
  return r;
}

nlohmann::json to_json(const ValidateResult& r, const DriveParams& model, const ValidateOptions& opt) {
  return {{"relative_error_pct", r.relative_error_pct},
          {"relative_error_full_rate_pct", r.relative_error_full_pct},
          {"rms_error_N", r.rms_error_N},
          {"error_norm_N", r.error_norm_N},
          {"samples_used", r.samples_used},
          {"protocol",
           {{"position_filter", "zero-phase 4th-order Butterworth"},
            {"filter_hz", opt.filter_hz},
            {"derivatives", "central differences"},
            {"drop_first", opt.drop_first},
            {"decimate", opt.decimate},
            {"anti_alias", "zero-phase 4th-order Butterworth at 0.8 x new Nyquist"}}},
          {"velocity", r.velocity_origin},
          {"force_outlier_rows", r.force_outliers.rows},
          {"force_outlier_limit", r.force_outliers.limit},
          {"force_sign", r.force_sign.sign},
          {"force_sign_origin", r.force_sign.describe()},
          {"position_unwraps", r.position_wrap.wraps},
          {"model", model_json(model, r.units)},
          {"units", units_json(r.units)}};
}

}  // namespace feedid::host
