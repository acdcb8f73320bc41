// The host identification pipeline: condition a trace (derive velocity when
// it is missing), choose the core's configuration from the data, stream the
// samples through the double-precision core, solve, and report. Host only.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "drive_sim.hpp"
#include "feedid/feedid.hpp"
#include "trace.hpp"

namespace feedid::host {

using Core = feedid::Estimator<double, 32, 16>;

struct IdentifyOptions {
  feedid::Method method = feedid::Method::bands;
  /// Cut-off (Hz) of the zero-phase Butterworth applied to position before
  /// central differences, when the trace has no velocity column.
  double velocity_filter_hz = 100.0;
  /// Force/velocity pairing; "auto": held_force_backward_velocity for a
  /// measured velocity column, held_force_instant_velocity for a derived one.
  std::string alignment = "auto";
  /// Overrides of the automatic choices (0 = from the data).
  double velocity_min_m_s = 0.0;
  double velocity_max_m_s = 0.0;
  double velocity_resolution_m_s = 0.0;
  std::function<void(double)> progress;  ///< fraction done, optional
};

/// The signals as the core sees them, one entry per sample.
struct Signals {
  std::vector<double> t, x, v, u;
  std::string velocity_origin;        ///< "measured" or how it was derived
  feedid::ForceAlignment alignment{};
  double sample_rate_hz = 0.0;        ///< from the median time step
  double position_quantum_m = 0.0;    ///< smallest position step seen (0 if none)
};

/// One velocity band of the measured friction curve (inertia removed).
struct FrictionPoint {
  double speed_m_s;     ///< time-weighted mean |v| in the band
  double friction_N;    ///< mean friction magnitude in the band
  double time_s;        ///< time spent in the band
};

struct Rejection {
  std::size_t sample = 0;  ///< 0-based sample index
  feedid::Status status{};
};

struct IdentifyResult {
  feedid::Status status = feedid::Status::not_initialized;
  std::string error;                      ///< set when the trace cannot be identified
  feedid::Estimate<double> estimate{};
  feedid::Diagnostics diagnostics{};
  feedid::Config<double> config{};
  Signals signals;
  std::vector<Rejection> first_rejections;  ///< at most 10
  std::vector<FrictionPoint> friction_curve[2];  ///< [pos, neg]
  double residual_rms_N = 0.0;   ///< RMS of the force residual over residual_block_s blocks
  double residual_block_s = 0.01;
  double duration_s = 0.0;
};

/// Velocity (measured or derived) and the pairing convention for a trace.
Signals prepare_signals(const Trace& trace, const IdentifyOptions& opt);

/// The same configuration in another precision, field by field (float on
/// target, double on host; a force limit beyond float's range is clamped).
template <typename To, typename From> feedid::Config<To> config_as(const feedid::Config<From>& c) {
  feedid::Config<To> o;
  o.velocity_min_m_s = To(c.velocity_min_m_s);
  o.velocity_max_m_s = To(c.velocity_max_m_s);
  o.velocity_resolution_m_s = To(c.velocity_resolution_m_s);
  o.section_enter_m_s = To(c.section_enter_m_s);
  o.rest_samples = c.rest_samples;
  o.min_section_s = To(c.min_section_s);
  o.max_fold_s = To(c.max_fold_s);
  o.mass_window_s = To(c.mass_window_s);
  o.max_step_speed_ratio = To(c.max_step_speed_ratio);
  o.max_acceleration_m_s2 = To(c.max_acceleration_m_s2);
  o.max_speed_m_s = To(c.max_speed_m_s);
  o.max_force_N = To(c.max_force_N < From(1e30) ? c.max_force_N : From(1e30));
  o.max_gap_s = To(c.max_gap_s);
  o.stribeck_min_m_s = To(c.stribeck_min_m_s);
  o.stribeck_max_m_s = To(c.stribeck_max_m_s);
  o.max_vs_iterations = c.max_vs_iterations;
  o.velocity_source = c.velocity_source;
  o.force_alignment = c.force_alignment;
  return o;
}

/// Force for the interval ending at sample k, with the core's pairing rule
/// (Config::force_alignment); k >= 1.
double interval_force(const Signals& s, std::size_t k);

/// The core configuration the data calls for (docs/reference.md explains each choice).
feedid::Config<double> auto_config(const Signals& s, const IdentifyOptions& opt);

IdentifyResult identify(const Trace& trace, const IdentifyOptions& opt);

/// The identified model as simulator parameters (same equations, one place).
DriveParams to_drive_params(const feedid::Estimate<double>& e);

/// Force the model predicts for velocity v and acceleration a (N).
double predict_force(const DriveParams& p, double v_m_s, double a_m_s2);

/// Names of the set bits of a flag word, e.g. ["stribeck_uncertain"].
std::vector<std::string> flag_names(uint32_t flags);

nlohmann::json to_json(const IdentifyResult& r);
/// The model part alone: {"m":..,"pos":{..},"neg":{..}} (also the truth format).
nlohmann::json model_json(const DriveParams& p);
/// Reads a model written by to_json or model_json; throws std::runtime_error naming the key.
DriveParams model_from_json(const nlohmann::json& j);
std::string summary(const IdentifyResult& r, const DriveParams* truth = nullptr);

}  // namespace feedid::host
