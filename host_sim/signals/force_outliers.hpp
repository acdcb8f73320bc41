// Force rows no drive can have logged: a corrupt row, a unit slip, a
// sentinel value. One row of 1e4 N in the EMPS log (peak 152 N) moved the
// negative Coulomb force by nine of its standard errors; a fixed limit
// (1e9 N) both let that row through and dropped 40 % of a log kept in a
// unit of 3e7. The limit is read from the data instead: it scales with the
// force's unit, so a scaled log identifies as the scaled result. Host only.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/trace.hpp"

namespace feedid::host {

/// Quantile of |force| over the moving samples that scales the limit. A
/// drive's largest force is its acceleration peak, and the peaks of the
/// logs at hand lie close above it (the largest |force| over this quantile:
/// 1.01 EMPS, 1.42 EMPS pulses, at most 1.26 on the twenty SysId logs and
/// 1.05 on the simulator's ladder, sine and production programs); it is
/// moved only by outliers holding more than a thousandth of the samples.
constexpr double kForceScaleQuantile = 0.999;
/// The limit over that quantile: a margin of seven over the largest ratio
/// seen, for acceleration peaks rarer than the quantile; corrupt rows lie
/// orders of magnitude beyond (1e4 and 1e12 in EMPS, limit 1505 N).
constexpr double kForceOutlierFactor = 10.0;
/// Outlier rows named in messages (the rest are counted).
constexpr std::size_t kNamedOutliers = 5;

/// The largest |u| a sample may carry (in u's unit): kForceOutlierFactor
/// times the kForceScaleQuantile quantile of |u| over the samples where x
/// changed from the sample before (all samples if it never does: forces at
/// rest, however long the axis waits, say nothing of its peaks). The
/// largest finite double when that quantile is 0: a force of zeros has no
/// scale to call anything an outlier by. Non-finite forces are left to the
/// readers, which reject them.
double force_outlier_limit(const std::vector<double>& x, const std::vector<double>& u);

/// A clipped force: rows piled up exactly on the largest (or smallest)
/// value, where an unclipped force passes its peak in a row or two. At
/// least kSaturationMinRows rows on the level, and over kSaturationPileUp
/// times as many as lie within kSaturationBand of it below (or within
/// three of the force's steps, for a coarsely quantised force).
constexpr std::size_t kSaturationMinRows = 5;
constexpr std::size_t kSaturationSpikes = 3;  ///< rows beyond a level that do not hide it (outliers)
constexpr double kSaturationPileUp = 4.0;
constexpr double kSaturationBand = 0.02;

/// The clip levels found, and the rows left out for them.
struct ForceSaturation {
  double level_hi = 0.0, level_lo = 0.0;  ///< the levels (u's unit); meaningful where found_*
  bool found_hi = false, found_lo = false;
  std::size_t rows = 0;           ///< rows on a level
  std::size_t rows_left_out = 0;  ///< with the rows around them that make each a gap
  bool found() const { return found_hi || found_lo; }
  std::string describe(const std::string& force_unit) const;
  /// {"level_hi", "level_lo" (null where none), "rows", "rows_left_out"}, or null if no clip.
  nlohmann::json to_json() const;
};

/// A position row no drive can have logged: a step to it and a step back,
/// each beyond kForceOutlierFactor times the 0.999 quantile of the log's
/// position steps, between neighbours that agree within that limit. One
/// row 1 m off in EMPS made its velocity noise 4 m/s and nothing could be
/// identified. The row's position becomes the straight line between its
/// neighbours; its force stays.
struct PositionSpikes {
  double limit_m = 0.0;            ///< the step limit (the position's unit)
  std::size_t rows = 0;            ///< rows bridged
  std::vector<std::string> first;  ///< the first kNamedOutliers: file, time and position
  std::string describe(const std::string& position_unit) const;
};

/// The trace with its position spikes bridged (the rule above). Taken by
/// value and bridged in place: bridge_force_outliers moves the trace
/// through its stages instead of copying it at each.
Trace bridge_position_spikes(Trace logged, PositionSpikes& found);

/// Force rows beyond the limit, and what became of them.
struct ForceOutliers {
  ForceSaturation saturation;  ///< clipped rows, left out before the limit is read
  PositionSpikes position_spikes;  ///< position rows bridged before anything else
  double limit = 0.0;       ///< force_outlier_limit of the trace as logged (its force unit)
  std::size_t rows = 0;     ///< forces beyond it
  std::size_t unbridged = 0;  ///< of those, with no good force within their stretch to bridge them by
  std::vector<std::string> first;  ///< the first kNamedOutliers: file, time and force
  /// One line for notes and the summary: the count, the limit and how it was found.
  std::string describe(const std::string& force_unit) const;
};

/// The trace with each force beyond force_outlier_limit (on the position,
/// or the velocity's running sum where no position is logged) replaced by
/// the straight line in time between the nearest good forces either side
/// within its stretch of samples (the one side's force at a stretch's end).
/// Only the force is bad: the row's position and velocity stay, so the
/// velocity is derived on the uniform grid as ever (leaving the row out
/// moved EMPS's mass by half its standard error through the filter on
/// position), and the force sign, the lag search, the velocity cut-off and
/// the core all see the same force. This is the core's own rule for a force
/// beyond max_force_N, whose next sample bridges the rejected one; a force
/// with no good one in its stretch is left for the core to reject.
/// Clipped rows (ForceSaturation) are left out first, whole: a clipped
/// force is not the force that moved the axis (clipped at +-100 N, EMPS's
/// mass came out 10.5 % low with status ok), and bridging would put a
/// guess in its place. Each clipped stretch is widened until it is a gap
/// (Signals::gap_before), so no integral, filter or section spans it.
Trace bridge_force_outliers(const Trace& logged, const std::string& force_unit, ForceOutliers& found);

/// The trace without its clipped rows (the rule above); `found` says what was left out.
/// `known`: levels found earlier in the same log (a stream's earlier
/// chunks), left out here too where this part alone does not show them;
/// `min_level`: a level of smaller magnitude is no clip (a part of a log
/// that holds one force at rest, its largest, is not clipped).
Trace leave_out_force_saturation(Trace logged, ForceSaturation& found, const ForceSaturation& known = {},
                                 double min_level = 0.0);

}  // namespace feedid::host
