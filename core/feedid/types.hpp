// Public value types of the identification core: configuration, sample,
// status codes, estimate and diagnostics. Freestanding; no allocation.
// The model (NOTES.md):  u = m*a + F(v)
//   F(v) = +(Fc+ + Fs+ exp(-(v/vs+)^2)) + sigma+ v   for v > 0
//   F(v) = -(Fc- + Fs- exp(-(|v|/vs-)^2)) + sigma- v  for v < 0
#pragma once

#include <stdint.h>

#include "feedid/force_pairing.hpp"

namespace feedid {

/// Every call returns one of these. docs/reference.md lists the remedies.
enum class Status : uint8_t {
  ok = 0,
  not_initialized,               ///< push/solve before a successful init()
  invalid_config,                ///< init(): a field is out of range (see config_error())
  rejected_not_finite,           ///< sample has NaN/Inf in dt, velocity, position or force
  rejected_time_not_increasing,  ///< dt <= 0
  rejected_out_of_range,         ///< |v| > max_speed_m_s or |u| > max_force_N
  rejected_velocity_jump,        ///< |dv| > max_acceleration_m_s2*dt + 4*velocity_resolution
  insufficient_data,             ///< solve(): nothing identifiable yet (see estimate flags)
  numerical_error,               ///< solve(): a running sum or the result is not finite (a singular fit sets flag_fit_failed instead)
  method_not_built,              ///< solve(Method::paper) on an Estimator built without it (FEEDID_PAPER_METHOD=0)
};

inline const char* status_name(Status s) {
  switch (s) {
    case Status::ok: return "ok";
    case Status::not_initialized: return "not_initialized";
    case Status::invalid_config: return "invalid_config";
    case Status::rejected_not_finite: return "rejected_not_finite";
    case Status::rejected_time_not_increasing: return "rejected_time_not_increasing";
    case Status::rejected_out_of_range: return "rejected_out_of_range";
    case Status::rejected_velocity_jump: return "rejected_velocity_jump";
    case Status::insufficient_data: return "insufficient_data";
    case Status::numerical_error: return "numerical_error";
    case Status::method_not_built: return "method_not_built";
  }
  return "unknown";
}

/// How solve() turns the statistics into parameters (docs/method.md).
enum class Method : uint8_t {
  /// Velocity-band friction curve with residual-inertia correction, mass from
  /// differentiation-free windows, vs by bounded golden-section search.
  bands = 0,
  /// The seed paper literally: one point per rest-to-rest section; mass from
  /// integral(u a) = m integral(a^2), friction from integral(u) over sections,
  /// vs from a fixed bank of candidates.
  paper = 1,
};

enum class VelocitySource : uint8_t {
  measured = 0,       ///< use Sample::velocity_m_s
  from_position = 1,  ///< backward difference of Sample::position_m
};

template <typename T> struct Config {
  /// Lowest band edge (m/s). Below it the axis counts as at rest: stiction is
  /// not described by F(v), so those samples never enter the friction sums.
  /// Set it to 2-3x the velocity resolution.
  T velocity_min_m_s = T(1e-4);
  /// Top band edge (m/s); faster samples share the top band (where F is linear).
  T velocity_max_m_s = T(0.5);
  /// Quantum or noise level of the reported velocity (m/s); 0 if unknown. A
  /// Stribeck velocity below 3x this is flagged instead of reported as known.
  T velocity_resolution_m_s = T(0);
  /// A section opens when |v| rises above this (m/s); 0 means 2*velocity_min.
  T section_enter_m_s = T(0);
  /// Consecutive samples with |v| < velocity_min that close a section.
  uint16_t rest_samples = 3;
  /// Sections shorter than this (s) do not count as sections for the paper method.
  T min_section_s = T(0.02);
  /// Sums are folded at least this often (s), so float running sums stay accurate;
  /// a longer section is split (it then no longer counts for the paper method).
  T max_fold_s = T(10.0);
  /// Length of the windows of the differentiation-free mass equation (s).
  T mass_window_s = T(0.02);
  /// An interval enters the friction bands only if its velocity change is at
  /// most this fraction of its speed, or at most 2x velocity_resolution
  /// (quasi-steady); all intervals enter the mass windows. Larger admits more
  /// data from fast accelerations.
  T max_step_speed_ratio = T(0.25);
  /// Plausibility limits; a sample beyond them is rejected and counted.
  T max_acceleration_m_s2 = T(200);
  T max_speed_m_s = T(20);
  T max_force_N = T(1e6);
  /// A time step above this (s) breaks continuity: no integral spans the gap.
  T max_gap_s = T(0.1);
  /// Search range of the Stribeck velocity (m/s); 0 means velocity_min/2 and
  /// velocity_max/4.
  T stribeck_min_m_s = T(0);
  T stribeck_max_m_s = T(0);
  /// Bound on the golden-section steps per direction and outer iteration.
  uint16_t max_vs_iterations = 40;
  VelocitySource velocity_source = VelocitySource::measured;
  /// How many sample periods the logged force lags the logged velocity, in
  /// [-5, 0] (force_pairing.hpp; negative: it leads). -1 is a held command
  /// against a backward-difference velocity; each period of a velocity
  /// filter's delay subtracts one. Measure it once with the host tool
  /// (`feedid identify` reports input.force_lag_s) and set it here.
  T force_lag_samples = force_lag_of<T>(ForceAlignment::held_force_backward_velocity);
};

/// One sample as the servo loop has it. Time enters as the step since the
/// previous sample: absolute time in float loses resolution within minutes.
template <typename T> struct Sample {
  T dt_s = T(0);          ///< time since the previous sample (s); ignored for the first
  T position_m = T(0);    ///< load-side position (m); used only with from_position
  T velocity_m_s = T(0);  ///< load-side velocity (m/s); ignored with from_position
  T force_N = T(0);       ///< drive force on the load side (N)
};

/// Bits of DirectionEstimate::flags / Estimate::mass_flags. A set bit means
/// the value it concerns is not identifiable from this data (docs/reference.md).
enum Flag : uint32_t {
  flag_no_data = 1u << 0,              ///< direction never seen, or too few velocity bands
  flag_stribeck_below_resolution = 1u << 1,  ///< vs < 3x velocity resolution / band floor
  flag_stribeck_at_search_bound = 1u << 2,   ///< best vs at the edge of the search range
  flag_stribeck_uncertain = 1u << 3,   ///< rel. std error of vs or Fs > 25 %, or Fs <= 0
  flag_no_low_speed_data = 1u << 4,    ///< no data where the curve bends (within 3x of vs, both sides) or below vs
  flag_no_acceleration = 1u << 5,      ///< mass: too little velocity change to see inertia
  flag_not_physical = 1u << 6,         ///< a magnitude came out negative
  flag_fit_failed = 1u << 7,           ///< normal equations singular
  flag_coulomb_uncertain = 1u << 8,    ///< rel. std error of Fc > 25 %: the data do not fix the force at zero speed
  flag_viscous_uncertain = 1u << 9,    ///< rel. std error of sigma > 25 %: the speeds logged do not fix the slope
  /// Friction falls across every speed logged (Coulomb + viscous gave a
  /// positive level and a negative slope): the data end inside a Stribeck
  /// fall they do not place, so neither the viscous rise nor the level the
  /// fall settles to (Fc) is in them; sigma is held at its bound 0.
  flag_friction_still_falling = 1u << 10,
};

/// Flags that make Fs and vs of a direction unusable (the rest may be fine).
constexpr uint32_t stribeck_flags = flag_stribeck_below_resolution | flag_stribeck_at_search_bound |
                                    flag_stribeck_uncertain | flag_no_low_speed_data;

template <typename T> struct DirectionEstimate {
  T viscous_Ns_m = T(0);            ///< sigma (N s/m)
  T coulomb_N = T(0);               ///< Fc (N)
  T breakaway_N = T(0);             ///< Fs (N); static friction is Fc + Fs
  T stribeck_velocity_m_s = T(0);   ///< vs (m/s)
  T viscous_se = T(0), coulomb_se = T(0), breakaway_se = T(0), stribeck_velocity_se = T(0);
  T friction_r2 = T(0);       ///< R^2 of the friction curve over velocity bands (time weighted)
  T friction_rms_N = T(0);    ///< RMS of band-mean friction minus model (N)
  T time_in_bands_s = T(0);   ///< time spent moving this way above velocity_min (s)
  uint32_t bands_used = 0;
  uint32_t sections = 0;      ///< complete rest-to-rest sections seen
  uint32_t flags = 0;         ///< Flag bits
  bool friction_identified() const { return (flags & (flag_no_data | flag_fit_failed)) == 0; }
  bool stribeck_identified() const { return friction_identified() && (flags & stribeck_flags) == 0; }
  /// Fc itself, beyond the fit: known to better than a quarter of its value.
  bool coulomb_identified() const {
    return friction_identified() && (flags & (flag_coulomb_uncertain | flag_friction_still_falling)) == 0;
  }
  /// sigma itself, beyond the fit: known to better than a quarter of its value.
  bool viscous_identified() const {
    return friction_identified() && (flags & (flag_viscous_uncertain | flag_friction_still_falling)) == 0;
  }
};

template <typename T> struct Estimate {
  Method method = Method::bands;
  T mass_kg = T(0);
  T mass_se_kg = T(0);
  uint32_t mass_flags = 0;
  DirectionEstimate<T> pos{};
  DirectionEstimate<T> neg{};
  T force_noise_N = T(0);   ///< white force noise seen in the data (N), from second differences
  bool mass_identified() const { return mass_flags == 0; }
};

/// Counters for what happened to the stream (never reset by solve()).
struct Diagnostics {
  uint64_t samples_accepted = 0;
  uint64_t samples_rejected = 0;
  uint64_t rejected_not_finite = 0;
  uint64_t rejected_time_not_increasing = 0;
  uint64_t rejected_out_of_range = 0;
  uint64_t rejected_velocity_jump = 0;
  uint32_t continuity_breaks = 0;    ///< gaps longer than max_gap_s
  uint32_t sections_complete[2] = {0, 0};  ///< [pos, neg] rest-to-rest sections
  uint32_t sections_short = 0;       ///< opened and closed within min_section_s
  uint32_t sections_split = 0;       ///< folded early (max_fold_s, a gap, or a solve() while it was open)
  uint32_t mass_windows = 0;
  uint32_t folds = 0;
};

}  // namespace feedid
