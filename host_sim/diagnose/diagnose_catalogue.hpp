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

/// The distinct edges of candidates ps (EffectModel::edges_of), ascending,
/// and where each edge is among them: its column in the edges' columns.
struct EdgeSet {
  std::vector<int> edges;
  EdgeSet(const std::function<std::pair<int, int>(double)>& edges_of, const std::vector<double>& ps);
  Eigen::Index index(int edge) const;
};

struct EffectModel {
  std::string kind;
  std::vector<double> grid;  ///< values of the nonlinear parameter (empty: none)
  bool continuous = false;   ///< refine between grid points by Brent's steps in log (golden sections and parabolas)
  /// Family sizes (docs/diagnosis.md, "Families"): the nonlinear parameter
  /// is searched at the first; then every size is fitted at that parameter
  /// and the one with the least size-penalised error (choose_size in
  /// diagnose.cpp) is kept. A size is the effect's own: harmonics of a
  /// ripple, elements of presliding, spline spans of position friction.
  std::vector<int> sizes = {1};
  /// How a continuous parameter is searched again at a larger size chosen:
  /// not, where the larger size aliases it (a ripple's harmonics fit a
  /// multiple of its period alike); near the first size's best, where the
  /// larger size shapes the same term (a compliance's second damping moves
  /// its frequency within the basin the first found: the 2 grid points
  /// either side of the one nearest the first's best, not all 50, saved
  /// 8 % of the work of `diagnose --model` on EMPS PULSES with the same
  /// result; a best on the window's edge searches the whole grid after
  /// all); over the whole grid, where it is another term whose
  /// parameter can lie anywhere (a drift split by direction: one side's
  /// 12 s drift fitted shared at 2.9 s).
  enum class SearchAgain { no, near_first, whole_grid };
  SearchAgain search_again_at_size = SearchAgain::whole_grid;
  /// Columns per unit of size where each size's columns are the first ones
  /// of any larger size's, to the bit (a ripple's harmonics: 2, presliding's
  /// elements and a compliance's dampings: 1), so that the largest size is
  /// drawn once for all; 0 where they are not (thermal drift's split by
  /// direction, position friction's spans).
  int columns_per_size = 0;
  /// Columns for a parameter value and size, drawn as asked: coarse
  /// segments serve the grid search, and a search draws the identification
  /// observations alone.
  std::function<Mat(double, int, Observations::Draw)> columns;
  /// The same at several parameter values, where drawing them together is
  /// cheaper than one by one (a compliance's filters step side by side);
  /// empty: one by one. The same bits as `columns`.
  std::function<std::vector<Mat>(const std::vector<double>&, int, Observations::Draw)> columns_at_many;
  /// Where every column of the search (at the first size) is the
  /// difference of two of a few shared columns, the edges: a position
  /// range's is the share of each segment below its upper edge less the
  /// share below its lower one. Then a search scores its candidates from
  /// the edges' products (ColumnBank::Edges), a few edge columns drawn
  /// instead of a column per candidate (position friction's 209 ranges:
  /// 21 edges). edges_of(p): p's lower and upper edge; edge_columns: the
  /// edges' columns, drawn as asked. Empty: not such a family.
  std::function<std::pair<int, int>(double)> edges_of = {};
  std::function<Mat(const std::vector<int>&, Observations::Draw)> edge_columns = {};
  /// The grid needs fine segments too (a resonance above the coarse segments' rate).
  bool fine_grid = false;
  /// Whether the columns its search draws are kept across the selection's
  /// steps and pair trials (SearchColumns in diagnose.cpp), and from which
  /// draw on: those that cost a transcendental or a filter step per
  /// segment (a ripple's sincos, presliding's exps, a compliance's
  /// resonance) from the first, within SearchColumns' budgets; cheap ones
  /// are drawn again instead of holding memory. From the second: kept
  /// only once a later step has asked for them again.
  enum class Keep { never, from_second_draw, from_first_draw };
  Keep keep_columns = Keep::never;
  std::function<nlohmann::json(double, int, const Vec& coef, double mass_kg)> parameters;
  /// More values to try around the best grid value (discrete parameters).
  std::function<std::vector<double>(double)> refine = {};
  /// "" if the fitted parameters are physical for a drive of mass_kg, else why not.
  std::function<std::string(const nlohmann::json&, double mass_kg)> implausible = {};
  /// A change of friction with speed or time: it stands in for a base whose
  /// friction law the run does not settle (base_friction_unsettled), and is
  /// not named beside one.
  bool friction_with_speed_or_time = false;
};

/// Extent of the trace the grids are laid over.
struct TraceExtent {
  double x_lo = 0.0, travel = 0.0;  ///< m
  double t0 = 0.0, duration = 0.0;  ///< s
  double sample_rate_hz = 0.0;
  /// Trace time each recording starts (the trace's start first; more when
  /// runs are pooled, each after a made-up gap) and the longest one's length.
  std::vector<double> run_starts;
  double longest_run_s = 0.0;
};
/// run_starts: where pooled recordings start on the trace's clock (the first may be left out).
TraceExtent trace_extent(const Observations& obs, const std::vector<double>& run_starts = {});

/// Which run (index into TraceExtent::run_starts) time t lies in.
std::size_t run_of(const std::vector<double>& run_starts, double t);

/// Friction the base model measures, fitted without any effect, per run and
/// direction (index 2 run + 0 for positive motion, + 1 for negative; both
/// as magnitudes against the motion).
struct MeasuredFriction {
  std::vector<double> coulomb_N, viscous_Ns_m;
};

/// Every catalogue effect, in effect_kinds() order. A delay is physical only
/// when the timing search found lag beyond the logging conventions.
/// The thermal drift is physical only while it keeps the measured friction positive.
std::vector<EffectModel> effect_catalogue(const Observations& obs, const TraceExtent& e, double lag_beyond_conventions_s,
                                          const MeasuredFriction& friction);

}  // namespace feedid::host::diag
