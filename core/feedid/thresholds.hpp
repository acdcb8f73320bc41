// The thresholds behind the core's judgements, named once. Every rule that
// flags a parameter, or decides what counts as evidence, reads them here;
// the host applies the same rules through feedid/analysis.hpp, and
// docs/reference.md ("Thresholds") is checked against these values by
// tests/core/thresholds_test.cpp. Pure constants: freestanding.
#pragma once

namespace feedid::thresholds {

/// A Coulomb force, viscous coefficient, break-away excess or Stribeck
/// velocity whose standard error exceeds this fraction of its value is
/// flagged not identifiable (flag_coulomb_uncertain, flag_viscous_uncertain,
/// flag_stribeck_uncertain): a quarter leaves the
/// sign and the order of magnitude certain at about 4 standard errors.
constexpr double kFrictionRelativeSe = 0.25;

/// A mass whose standard error exceeds this fraction of it is flagged
/// (flag_no_acceleration): a feed-forward gain off by more than 10 % is
/// worse than none on a stiff loop.
constexpr double kMassRelativeSe = 0.1;

/// A velocity band with less time than this (s) carries too few samples to
/// count as a point of the friction curve.
constexpr double kMinBandTime_s = 2e-3;

/// Points of the coarse log(vs) grid of the Stribeck search; host tools
/// that search vs use the same grid.
constexpr int kStribeckGridPoints = 24;

/// The Stribeck search range when Config leaves it open: from this fraction
/// of velocity_min (a dip below the slowest band is still placed by the
/// bands above it) to this fraction of velocity_max (a vs near top speed is
/// a viscous curve, not a dip).
constexpr double kStribeckLowOfVelocityMin = 0.5;
constexpr double kStribeckHighOfVelocityMax = 0.25;

/// A Stribeck velocity below this many velocity resolutions (or
/// kStribeckFloorOfVelocityMin times velocity_min, whichever is higher) is
/// below what the data resolves (flag_stribeck_below_resolution).
constexpr double kStribeckFloorResolutions = 3.0;
constexpr double kStribeckFloorOfVelocityMin = 1.5;

/// Evidence of the Stribeck bend (flag_no_low_speed_data): at least this
/// much time (s) in at least kStribeckSlowBands bands below vs.
constexpr double kStribeckSlowTime_s = 0.02;
constexpr int kStribeckSlowBands = 2;

}  // namespace feedid::thresholds
