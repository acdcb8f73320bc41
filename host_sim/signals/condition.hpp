// Conditioning of a logged trace into the signals every command works on:
// one time base (the median step, and the gap rule that splits the trace
// into stretches no filter, difference or integral crosses), a wrapped
// position run on, held values found (and spread if asked), the force's
// sign, a velocity column checked against the position, and a
// velocity-only log integrated to a position. identify, validate and
// diagnose all start from it, so a pooled, cut or unevenly logged trace
// means the same to each (issue 29). Data only: no velocity filter is
// chosen and no force lag estimated here (identify does that). Host only.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "feedid/feedid.hpp"
#include "io/trace.hpp"
#include "signals/filters.hpp"
#include "signals/force_sign.hpp"
#include "signals/position_wrap.hpp"

namespace feedid::host {

/// A force lag search's outcome (identify/timing_search.hpp, estimate_force_lag).
struct LagEstimate {
  double lag_samples = 0.0;  ///< force lag behind the velocity (periods)
  double se_samples = 0.0;   ///< its standard error (periods)
  int evaluations = 0;       ///< identifications run for the search
  bool ok = false;           ///< false: no motion to judge timing by (lag left at 0)
  /// The share of a shift's block residual that refitting the friction and
  /// mass takes back (0: none, the motion separates the lag; near 1: only
  /// the reversals tell it, as on a single tone). NaN where not measured.
  double absorbed_by_refit = std::numeric_limits<double>::quiet_NaN();
};

/// The signals as the core sees them, one entry per sample.
struct Signals {
  /// Why the trace gives no signals to work with (no rate, no motion
  /// column, a time unit to state, a force lag beyond any logging), naming
  /// the trace; empty when it does (io/outcome.hpp). Every stage that takes
  /// signals passes it on as its own result's error.
  std::string error;
  std::vector<double> t, x, v, u;
  std::string velocity_origin;        ///< "measured" or how it was derived
  std::string position_origin = "measured";  ///< or how x was made (no position column)
  PositionWrap position_wrap;  ///< jumps of a wrapped position taken out (position_wrap.hpp)
  /// What the logged force was multiplied by so that it does positive net
  /// work on the motion, and why (force_sign.hpp).
  ForceSign force_sign;
  /// Rows each logged value of position and of the velocity column stood
  /// for (held_values.hpp; 1: updated every row), and whether they were
  /// spread linearly between their updates (ConditionOptions::spread_held_values).
  int position_hold_rows = 1, velocity_hold_rows = 1;
  bool held_values_spread = false;
  double velocity_filter_hz = 0.0;            ///< cut-off of the derived velocity (Hz); 0: given as is
  std::string velocity_filter_origin;         ///< stated, or how it was chosen
  /// Cut-offs the block residual could not tell from the chosen one (Hz;
  /// FilterChoice::rivals_hz); the parameters' spread over them is a term
  /// of their standard errors.
  std::vector<double> velocity_filter_rivals_hz;
  /// The velocity at each of those cut-offs, sample by sample, derived as
  /// v was (identify.hpp, derive_rival_velocities): derived once, so the
  /// standard errors' rival passes and a selection of the samples
  /// (select_samples: diagnose's folds) read the same columns.
  std::vector<std::vector<double>> rival_velocities;
  /// Lag of the force behind the velocity as the core pairs them (sample
  /// periods, in [-5, 0]): force_lag_s / dt less velocity_delay_samples.
  double force_lag_samples = -1.0;
  int velocity_delay_samples = 0;     ///< whole samples v and x were delayed by (a positive lag)
  double force_lag_s = 0.0;           ///< force lag behind the logged velocity (s)
  /// Lag of v (what the core sees) behind the motion, before any whole-sample
  /// delay of the alignment (periods; NaN unknown).
  double core_velocity_lag = 0.0;
  double force_lag_se_s = 0.0;        ///< its standard error (s); 0 when stated exactly
  /// Where the lag came from; only an estimated one adds a timing term to the standard errors.
  enum class LagOrigin { estimated, option, convention, assumed } force_lag_origin = LagOrigin::convention;
  std::string force_convention;       ///< nearest named convention of the force log
  LagEstimate lag_search;             ///< the search behind an estimated lag (before any clamp)
  /// Beside a stated lag (IdentifyOptions::check_stated_lag): the lag a
  /// search found, in force_lag_s's frame, and what tells how far to trust
  /// it. Of the searches on the candidate velocities (the derivative of
  /// position, the column), the one nearest the stated lag.
  struct SearchedLag {
    double lag_s = std::numeric_limits<double>::quiet_NaN();  ///< NaN: no search ran beside
    double se_s = std::numeric_limits<double>::quiet_NaN();
    bool at_range_end = false;  ///< the search stopped at an end of its range: the lag may lie further
    double absorbed_by_refit = std::numeric_limits<double>::quiet_NaN();  ///< LagEstimate's
  } searched_force_lag;
  /// Part of the estimated lag beyond the conventions, left out when
  /// IdentifyOptions::lag_within_conventions (periods; 0 otherwise).
  double lag_beyond_conventions = 0.0;
  double velocity_lag_s = std::numeric_limits<double>::quiet_NaN();  ///< velocity lag behind position (s)
  feedid::ForcePairing<double> pairing() const {
    feedid::ForcePairing<double> p;
    (void)p.init(force_lag_samples);
    return p;
  }
  bool has_position = false;          ///< x is a logged position (not zeros)
  /// The velocity column is logged and used (velocity_column_agrees, or
  /// there is no position to check it against).
  bool has_velocity_column = false;
  /// The velocity column over the position's derivative (velocity_column_gain; NaN: not checked).
  double velocity_column_gain = std::numeric_limits<double>::quiet_NaN();
  double sample_rate_hz = 0.0;        ///< from the median time step (> 0: condition refuses a trace without one)
  double period_s() const { return 1.0 / sample_rate_hz; }
  /// Rate at which the position carries news (Hz): the log rate over the
  /// rows each value is held for (held_values.hpp).
  double position_update_rate_hz() const { return sample_rate_hz / std::max(1, position_hold_rows); }
  /// Longest step within one stretch of samples (s; filters.hpp,
  /// max_step_s), and the core's max_gap_s (auto_config), so that no
  /// integral in the core crosses a gap either.
  double max_step_s() const { return host::max_step_s(period_s()); }
  /// Whether the step into sample k (k >= 1) is such a gap.
  bool gap_before(std::size_t k) const { return t[k] - t[k - 1] > max_step_s(); }
  /// When a duration summed from time steps reaches length_s. Block
  /// lengths are whole numbers of periods (10 ms at 1 or 4 kHz), where a
  /// sum of evenly stamped steps lands on the length and its last bits
  /// decided: with EMPS PULSES' stamps moved by 1000 s, the blocks closed
  /// a sample later here and there, the force lag moved by 1.5 standard
  /// errors and the chosen cut-off from 100 to 400 Hz. A millionth of a
  /// period decides such a tie one way (the whole count) and no other sum;
  /// so do four units in the last place of the stamps, where those are
  /// coarser: stamps of Unix time (1.7e9 s) are rounded to 2.4e-7 s, and a
  /// sum of steps is the difference of two of them.
  /// Not yet diagnose's blocks: all 5 samples long at 1 kHz, they named a
  /// compliance at their own rate (docs/status.md, "Time origin").
  /// Worked out once per pass: `const auto full = s.reached_at(block_s);`,
  /// then `full.by(tau)` at every sample.
  struct LengthReached {
    double at_s;  ///< the least duration that reaches the length (s)
    bool by(double duration_s) const { return duration_s >= at_s; }
  };
  LengthReached reached_at(double length_s) const { return {length_s - length_tie_s()}; }
  double length_tie_s() const {
    const double stamp = t.empty() ? 0.0 : std::max(std::fabs(t.front()), std::fabs(t.back()));
    return std::max(1e-6 * period_s(), 4.0 * std::numeric_limits<double>::epsilon() * stamp);
  }
  /// First sample of the stretch that holds sample k, looked for at most
  /// `reach` samples back (the force pairing needs only its few taps).
  std::size_t stretch_start(std::size_t k, std::size_t reach = feedid::ForcePairing<double>::history) const {
    std::size_t i = k;
    while (i > 0 && k - i < reach && !gap_before(i)) --i;
    return i;
  }
  /// Stretches whose uneven stamps were taken to the slots of the log's
  /// clock, on which the motion is smoother (condition.cpp, regularise_stamps).
  std::size_t stretches_on_clock_slots = 0;
  double position_quantum_m = 0.0;    ///< smallest position step seen (0 if none)
  /// Sample noise of a velocity column that was integrated and derived
  /// again (no position logged), kept for the velocity resolution (m/s).
  double column_velocity_noise_m_s = 0.0;
};

/// The slowest median time step (s) taken as seconds when the time
/// column's unit is not stated (Trace::time_unit_stated): servo drives log
/// at 100 Hz or more (the 200 Hz SysId logs are the slowest seen), and a
/// 1 kHz log stamped in ms reads as 1 Hz. Slower unstated logs are refused.
constexpr double kSlowestUnstatedStep_s = 0.05;

/// What the conditioning is told rather than finds.
struct ConditionOptions {
  /// Spread position and velocity values that the log held for several rows
  /// linearly between their updates (held_values.hpp); holds are detected
  /// and reported either way.
  bool spread_held_values = false;
  /// +1 or -1 states what the logged force is multiplied by; 0 finds it
  /// from the work the force does on the motion (force_sign.hpp).
  int force_sign = 0;
  /// The velocity column is taken as the caller gives it, not checked
  /// against the position's derivative (VelocitySource::given).
  bool velocity_column_given = false;
};

/// The trace's columns on one time base, as every command sees them:
/// t, x (logged and unwrapped, or integrated from the velocity column),
/// v (the velocity column as logged, held values spread if asked), u
/// (oriented), the rate from the median step, the encoder quantum, holds,
/// and whether the velocity column agrees with the position. `error` for a
/// trace without a rate or without motion columns, naming the trace.
Signals condition(const Trace& trace, const ConditionOptions& opt);

/// Why condition() refuses the whole log whatever stretch of it is read
/// (a time column read as seconds for want of a stated unit that steps
/// slower than any drive logs), or empty. monitor asks it once, so that
/// such a log stops the run with the remedy instead of leaving every
/// epoch unidentified.
std::string log_refusal(const Trace& trace);

/// The samples of s where keep[k] is non-zero, with s's conventions and
/// provenance: what was left out between two kept samples is a gap in
/// time (Signals::gap_before), so no filter, integral or force tap spans
/// it, provided it lasts longer than Signals::max_step_s; a shorter hole
/// is bridged, as conditioning bridges dropped rows. Diagnose's
/// identification folds (seconds each; identify_prepared).
Signals select_samples(const Signals& s, const std::vector<char>& keep);

/// Half-open sample ranges [first, second) between the gaps of s
/// (Signals::gap_before), in order: the stretches no filter or difference
/// may span.
std::vector<std::pair<std::size_t, std::size_t>> stretches(const Signals& s);

/// The q-quantile of |v| (0 for an empty v).
double quantile_abs(std::vector<double> v, double q);

/// White-noise level of a velocity from its second differences (m/s);
/// differences across a gap in time (held-out folds cut out, another run)
/// are not noise.
double velocity_noise(const std::vector<double>& v, const std::vector<double>& t, double dt);

}  // namespace feedid::host
