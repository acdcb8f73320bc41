// The core's analysis steps that host tools reuse, as a documented public
// API: the host refits, widens standard errors and searches alongside the
// core, and must judge with the core's own rules rather than copies of
// them. Everything here is the core's code (feedid/solve.hpp), named in one
// place; the host never reaches into feedid::detail. Freestanding.
#pragma once

#include "feedid/solve.hpp"
#include "feedid/thresholds.hpp"

namespace feedid::analysis {

/// One direction's friction curve as band points: the band's force integral
/// with the inertia m*dv removed, against its time, speed and second moment.
using detail::FrictionPoints;
/// FrictionPoints<T, Bands> friction_points(stats, direction 0|1, mass_kg).
using detail::friction_points;
/// add_friction_point(points, time_s, speed integral, speed^2 integral, friction impulse): one band point.
using detail::add_friction_point;
/// Stribeck law at a fixed vs fitted on band points: theta = (sigma, Fc, Fs),
/// the residual sum of squares, optionally the inverse normal matrix. False
/// when the points cannot carry it.
using detail::fit_friction_at;
/// Coulomb + viscous law fitted on band points: theta = (sigma, Fc, 0).
using detail::fit_coulomb_viscous_at;
/// The physical bound on that fit: a falling curve's slope is held at 0 and
/// flagged (flag_friction_still_falling); returns the flags it sets.
using detail::hold_falling_friction;

/// The flags that turn a standard error into "not identifiable"
/// (thresholds::kFrictionRelativeSe, kMassRelativeSe); apply them again
/// after widening a standard error.
using detail::coulomb_uncertainty_flags;
using detail::friction_term_uncertain;
using detail::mass_uncertainty_flags;
using detail::stribeck_uncertainty_flags;
using detail::viscous_uncertainty_flags;

/// Bands with less time than this (s) are not points of the friction curve.
using detail::min_band_time_s;

/// The Stribeck velocity search range of a configuration (m/s), and its
/// i-th of `count` log-spaced candidates.
using detail::stribeck_candidate;
using detail::stribeck_hi;
using detail::stribeck_lo;

/// The solve steps from statistics to an estimate, as Estimator::solve()
/// runs them; host tools that keep their own statistics (a jackknife, the
/// batch oracle) solve with exactly these.
using detail::solve_bands;
using detail::solve_paper;

}  // namespace feedid::analysis
