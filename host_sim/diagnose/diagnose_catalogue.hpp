// The catalogue of unmodelled effects (NOTES.md): for each, the regressor
// columns it adds to the base model for a value of its nonlinear parameter,
// the grid that parameter is searched on, and how its fitted numbers are
// named. One builder per effect in diagnose_catalogue.cpp. Host only.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "diagnose_blocks.hpp"

namespace feedid::host::diag {

struct EffectModel {
  std::string kind;
  std::vector<double> grid;  ///< values of the nonlinear parameter (empty: none)
  bool continuous = false;   ///< refine between grid points by golden-section search in log
  /// Columns for a parameter value; coarse segments serve the grid search.
  std::function<Mat(double, Observations::Resolution)> columns;
  /// The grid needs fine segments too (a resonance above the coarse segments' rate).
  bool fine_grid = false;
  std::function<nlohmann::json(double, const Vec& coef, double mass_kg)> parameters;
  /// More values to try around the best grid value (discrete parameters).
  std::function<std::vector<double>(double)> refine = {};
  /// "" if the fitted parameters are physical for a drive of mass_kg, else why not.
  std::function<std::string(const nlohmann::json&, double mass_kg)> implausible = {};
};

/// Extent of the trace the grids are laid over.
struct TraceExtent {
  double x_lo = 0.0, travel = 0.0;  ///< m
  double t0 = 0.0, duration = 0.0;  ///< s
  double sample_rate_hz = 0.0;
};
TraceExtent trace_extent(const Observations& obs);

/// Every catalogue effect, in effect_kinds() order. A delay is physical only
/// when the timing search found lag beyond the logging conventions.
std::vector<EffectModel> effect_catalogue(const Observations& obs, const TraceExtent& e, double lag_beyond_conventions_s);

}  // namespace feedid::host::diag
