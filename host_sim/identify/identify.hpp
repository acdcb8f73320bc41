// The host identification pipeline: condition a trace (derive velocity when
// it is missing), choose the core's configuration from the data, stream the
// samples through the double-precision core, solve, and report. Host only.
#pragma once
#include <array>
#include <cstdint>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "feedid/feedid.hpp"
#include "io/trace.hpp"
#include "io/units.hpp"
#include "model/drive_model.hpp"
#include "signals/condition.hpp"
#include "signals/force_outliers.hpp"

namespace feedid::host {

using Core = feedid::Estimator<double>;
/// The core as the drive builds it (FEEDID_PAPER_METHOD=0): the bands
/// method alone, without the paper method's per-section sums; 1.8 times
/// faster per sample on the host, and its estimate the same to rounding.
/// The searches, which solve by the bands method, run it.
using BandsCore = feedid::Estimator<double, Core::bands, Core::candidates, false>;

/// The velocity the core is fed.
enum class VelocitySource {
  /// The zero-phase derivative of position (logged, or integrated from a
  /// velocity-only log) at a cut-off chosen from the data: the most
  /// accurate parameters (docs/method.md).
  position,
  /// The drive's velocity column where it is a position difference, else
  /// the backward difference of position: no filter rounds a start or a
  /// reversal, which the diagnosis reads sample by sample. Without both
  /// columns, as `position`.
  column,
  /// The velocity column as it is, its lag behind the motion as stated
  /// (velocity_lag_s, 0 if not): signals the diagnosis has aligned already.
  given,
};

/// A load that is not friction and does not reverse with the motion
/// (gravity.hpp). Unmodelled, it shifts each direction's Coulomb term by
/// opposite amounts: arms that carry gravity came out with Coulomb friction
/// of -327 to -2230 N m.
enum class GravityTerm {
  none,       ///< no such term
  constant,   ///< G: a vertical linear axis; assumes Coulomb friction the same both ways
  angle,      ///< G cos(q - q0): a rotary arm, q in rad
  automatic,  ///< angle where the axis is rotary and the data show it; else none
};

/// The gravity term fitted and taken off the force before the friction fit.
struct GravityFit {
  GravityTerm form = GravityTerm::none;  ///< what was kept
  double G = 0.0, G_se = 0.0;            ///< force unit
  double angle0_rad = 0.0, angle0_se_rad = 0.0;  ///< angle form: where the load pulls hardest in +
  std::string note;                      ///< how it was found, or why none was kept
};

struct IdentifyOptions {
  feedid::Method method = feedid::Method::bands;
  /// Cut-off (Hz) of the zero-phase Butterworth applied to position (logged,
  /// or integrated from a velocity-only log) before central differences:
  /// the velocity the core sees.
  double velocity_filter_hz = 0.0;  ///< 0: chosen from the data (choose_velocity_filter)
  /// Weigh the Stribeck law against Coulomb + viscous after each solve
  /// (select_friction_models). The lag and velocity searches leave it off:
  /// a law that switches from one candidate to the next makes their cost jump.
  bool select_friction_model = true;
  /// Where the core's velocity comes from (VelocitySource).
  VelocitySource velocity_source = VelocitySource::position;
  /// Spread position and velocity values that the log held for several
  /// rows linearly between their updates (held_values.hpp). Holds are
  /// detected and reported either way. The diagnosis spreads (its backward
  /// differences of a held position are mostly the holds' sawtooth);
  /// identify does not yet: on the SysId logs it moved the roller's lag
  /// search to -22 ms and its mass below zero (docs/sysid.md).
  bool spread_held_values = false;
  /// +1 or -1 states what the logged force is multiplied by; 0 finds it
  /// from the work the force does on the motion (force_sign.hpp).
  int force_sign = 0;
  /// Force/velocity pairing: "auto" estimates the lag from the data
  /// (identify/timing_search.hpp); a named convention (held-backward, held-instant,
  /// trapezoid) or force_lag_s states it.
  std::string alignment = "auto";
  /// How far the logged force lags the logged velocity (s); NaN: from `alignment`.
  double force_lag_s = std::numeric_limits<double>::quiet_NaN();
  /// The stated force_lag_s's standard error (s) where it was estimated on
  /// another stretch of the same log (monitor's and the streamed identify's
  /// head; with_conventions_of): the standard errors then carry the lag's
  /// uncertainty as they do where identify estimated it. 0: stated exactly.
  double force_lag_se_s = 0.0;
  /// force_lag_s or a named alignment was stated by the user
  /// (--force-lag-s, --alignment), not carried from a search
  /// (with_conventions_of clears it): the lag is searched too,
  /// and identify_warnings says where the data put it elsewhere. A wrong
  /// stated lag goes into m and sigma with status ok. Costs the search.
  bool check_stated_lag = false;
  /// How far the logged velocity lags the motion (s), e.g. a drive's filter;
  /// NaN: estimated against position when there is a position column.
  double velocity_lag_s = std::numeric_limits<double>::quiet_NaN();
  /// Keep an estimated lag to what logging conventions explain: the force's
  /// own delay (its lag plus the velocity's) between a held command (-1/2
  /// period) and a period mean (+1/2), plus kLagAccuracy. The diagnosis sets
  /// it, so that a physical delay beyond the conventions stays in the
  /// residual for its `delay` candidate instead of vanishing into the lag.
  bool lag_within_conventions = false;
  /// A gravity term to fit and take off the force first (gravity.hpp).
  /// automatic: an arm's weight where the axis is rotary and the data tell
  /// it from friction; nothing on a linear axis, where a constant load and
  /// asymmetric Coulomb friction look alike.
  GravityTerm gravity = GravityTerm::automatic;
  /// Overrides of the automatic choices (0 = from the data).
  double velocity_min_m_s = 0.0;
  double velocity_max_m_s = 0.0;
  double velocity_resolution_m_s = 0.0;
  /// Widen the core's standard errors by the jackknife and the lag's
  /// uncertainty (uncertainty.hpp): two more passes over the data.
  bool honest_standard_errors = true;
  /// Labels only (units.hpp): the arithmetic is the same for any units.
  Units units;
  std::function<void(double)> progress;  ///< fraction done, optional
};

/// Which friction law a direction's figures come from (model selection,
/// docs/method.md "Model selection").
struct FrictionModel {
  bool stribeck = false;     ///< the Stribeck law was kept (else Coulomb + viscous)
  std::string reason;        ///< why, for the summary and the JSON
  double bic_gain = 0.0;     ///< BIC(Coulomb + viscous) - BIC(Stribeck); > 0 favours Stribeck
  bool refitted = false;     ///< Fc and sigma are the Coulomb + viscous refit (the jackknife refits likewise)
};

/// Coulomb + viscous in both directions, pooled, when the directions agree
/// within 2 standard errors (inverse-variance means).
struct SymmetricFriction {
  bool agree = false;
  double coulomb_N = 0.0, coulomb_se = 0.0, viscous_Ns_m = 0.0, viscous_se = 0.0;
  /// The pooled Fc and sigma by the core's rule (friction_term_uncertain): known to a quarter of their value.
  bool coulomb_identified() const { return agree && !feedid::analysis::friction_term_uncertain(coulomb_N, coulomb_se); }
  bool viscous_identified() const { return agree && !feedid::analysis::friction_term_uncertain(viscous_Ns_m, viscous_se); }
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
  Units units;  ///< of the input, for every label (IdentifyOptions::units)
  Signals signals;
  std::vector<Rejection> first_rejections;  ///< at most 10
  std::vector<FrictionPoint> friction_curve[2];  ///< [pos, neg]
  std::array<FrictionModel, 2> friction_model;   ///< [pos, neg]: which law, and why
  /// The core's mass from its acceleration windows, before the block refit
  /// (equal to estimate.mass_kg when the refit did not run).
  double mass_from_windows_kg = 0.0;
  double lag_se_periods = 0.0;   ///< the lag's uncertainty the timing terms use (0: stated lag)
  int jackknife_chunks = 0;      ///< leave-one-out solves behind the standard errors (0: the core's own)
  std::array<double, 9> se_model{}, se_jackknife{}, se_timing{}, se_cutoff{};  ///< m, sigma+, Fc+, Fs+, vs+, sigma-, ...
  double residual_rms_N = 0.0;   ///< RMS of the force residual over triangle-weighted pairs of residual_block_s blocks
  double residual_block_s = 0.01;  ///< block_length_s of the signals
  std::size_t rows_skipped = 0, rows_repeated = 0;  ///< what the reader left out (Trace)
  std::vector<std::string> skipped_rows;            ///< the first few, with file:line and why
  double time_origin_s = 0.0;                       ///< what the times count from (Trace::time_origin_s)
  /// Forces beyond the limit read from the data, bridged by their neighbours
  /// (force_outliers.hpp).
  ForceOutliers force_outliers;
  std::vector<TraceRun> runs;                       ///< pooled recordings (empty for one file)
  std::vector<feedid::Diagnostics> run_diagnostics; ///< the core's counters per run (parallel to runs)
  double duration_s = 0.0;
  /// Samples pushed through a core by this identification, searches and
  /// standard errors included, over the trace's samples: the number of
  /// full passes of the core it cost (core_samples_pushed()).
  double core_passes = 0.0;
  /// Streamed (identify_stream.hpp): conventions from the head, the core's
  /// own standard errors, no jackknife or block refit.
  bool streamed = false;
  GravityFit gravity;  ///< form none unless IdentifyOptions::gravity asked for one
};

/// Velocity (measured or derived) and the pairing convention for a trace.
Signals prepare_signals(const Trace& trace, const IdentifyOptions& opt);

/// `o` with the conventions prepare_signals() found on `found` stated: the
/// force sign and lag, the velocity column's lag, and the velocity cut-off
/// (or the column, where it won): what later parts of the same log (the
/// streamed identify's chunks, monitor's epochs) take without searching.
IdentifyOptions with_conventions_of(const Signals& found, IdentifyOptions o);

/// The head of a log its conventions are found on, where later parts take
/// them (s): on a 10 s monitor epoch of a 4 kHz log the force lag came out
/// 0.6 period off (2 of its standard errors) and every later epoch's mass
/// 0.2 % low; on the first minute it was within one of its 0.06 period.
constexpr double kConventionsHead_s = 60.0;

/// Length of the blocks behind the block residual and the block-pair mass
/// (s): 10 ms, or 8 samples where that is longer (a 200 Hz log has two
/// samples in 10 ms, and its block mass was noise).
double block_length_s(const Signals& s);

/// Sets s.v to the zero-phase derivative of s.x at cut-off fc_hz (at most
/// 0.4 of the rate; filters.hpp), stretch by stretch between time gaps.
void derive_velocity(Signals& s, double fc_hz);

/// Sets s.rival_velocities: the velocity at each of
/// s.velocity_filter_rivals_hz, derived from s.x as derive_velocity does.
void derive_rival_velocities(Signals& s);

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
  o.force_lag_samples = To(c.force_lag_samples);
  return o;
}

/// Samples the force may lead the motion by in a lag search (a positive lag
/// of whole samples: timing_search.hpp, kForceLagMax).
constexpr int kForceLead = 3;

/// Force at ages -kForceLead .. history-1 of the pairing rule's chain
/// (force_pairing.hpp), age a at index a + kForceLead.
using ForceAges = std::array<double, feedid::ForcePairing<double>::history + kForceLead>;

/// The forces the pairing rule can tap for the interval ending at sample k
/// (age 0 is u[k], age -1 u[k+1]); taps before `first` (the start of the
/// chain, Signals::stretch_start) take u[first], taps after `last` (its
/// end) u[last]. first < k <= last.
ForceAges force_ages(const std::vector<double>& u, std::size_t k, std::size_t first, std::size_t last);

/// Force for the interval ending at sample k of a force column, by the
/// core's pairing rule (force_pairing.hpp); taps before `first` (the start
/// of the chain, Signals::stretch_start) take u[first]. k > first.
double paired_force(const std::vector<double>& u, const feedid::ForcePairing<double>& p, std::size_t k,
                    std::size_t first = 0);

/// The core configuration the data calls for (docs/reference.md explains each choice).
feedid::Config<double> auto_config(const Signals& s, const IdentifyOptions& opt);

/// Bridges the trace's force outliers, prepares its signals (prepare_signals:
/// the one conditioning, the velocity cut-off and the force lag) and
/// identifies them (identify_prepared).
IdentifyResult identify(const Trace& trace, const IdentifyOptions& opt);

/// Identifies signals prepared already (prepare_signals, or a selection of
/// them: select_samples) without conditioning them again: the core's pass,
/// the block mass, the standard errors, and opt.gravity's term (gravity.hpp;
/// its rounds take the load off these signals, not off a trace). `source`
/// names them in errors; run_starts: the first sample of each pooled
/// recording, for the per-run counters. Diagnose's identification folds
/// come here, not through a rebuilt trace (issue 29).
IdentifyResult identify_prepared(Signals prepared, const IdentifyOptions& opt, const std::string& source,
                                 const std::vector<std::size_t>& run_starts = {});

/// Replaces the core's mass (from its acceleration windows, whose raw
/// end velocities carry quantisation noise that attenuates m: -0.7 % at
/// 8 kHz and 100 nm) by block_mass() on triangle-weighted pairs of 10 ms
/// blocks, with its jackknife and the timing term as its standard error. Friction is
/// held at the core's. Host only: the firmware keeps the windows' mass.
struct BlockPair;
/// `pairs`: block_pairs of r.signals under r.estimate's friction at
/// r.config's velocity_min_m_s and r.residual_block_s.
void refit_mass_on_blocks(IdentifyResult& r, const std::vector<BlockPair>& pairs);
/// "estimated", "option", "convention" or the reason a held force was assumed.
const char* lag_origin_name(Signals::LagOrigin o);

/// What one pass of the core over prepared signals gives.
struct CoreRun {
  feedid::Status status = feedid::Status::not_initialized;
  feedid::Estimate<double> estimate{};
  feedid::Diagnostics diagnostics{};
  std::vector<Rejection> first_rejections;  ///< at most 10
  std::unique_ptr<Core> core;               ///< the solved core (statistics for plots)
  std::array<FrictionModel, 2> friction_model;  ///< [pos, neg], applied to estimate
  /// The core's counters just before each of run_starts was pushed, then after the solve.
  std::vector<feedid::Diagnostics> counters_at;
};

/// r.friction_curve from a solved core: per band with time, mean speed and
/// mean friction with r.estimate's inertia removed.
void fill_friction_curve(const Core& core, IdentifyResult& r);

/// Model selection on a solved core, per direction: keeps the Stribeck law
/// only where it is physical (Fc, sigma >= 0) and pays for its two extra
/// parameters in the Bayesian information criterion over the band points;
/// otherwise replaces Fc, sigma and their standard errors by the Coulomb +
/// viscous fit, sets Fs = vs = 0 (no dip) and flags the Stribeck pair.
/// C: Core or BandsCore.
template <typename C>
std::array<FrictionModel, 2> select_friction_models(const C& core, feedid::Estimate<double>& e);
extern template std::array<FrictionModel, 2> select_friction_models(const Core&, feedid::Estimate<double>&);
extern template std::array<FrictionModel, 2> select_friction_models(const BandsCore&, feedid::Estimate<double>&);
/// Direction d's Coulomb + viscous law refitted on the bands (Fs = vs = 0),
/// with its standard errors and flags; false when the bands cannot carry it.
/// Model selection's fallback, and the jackknife's for a direction it chose.
/// Stats: the statistics of Core or BandsCore.
template <typename Stats>
bool refit_coulomb_viscous(const Stats& st, int d, double mass, feedid::DirectionEstimate<double>& de);
extern template bool refit_coulomb_viscous(const Core::Stats&, int, double, feedid::DirectionEstimate<double>&);
extern template bool refit_coulomb_viscous(const BandsCore::Stats&, int, double, feedid::DirectionEstimate<double>&);

/// The symmetric model, where both directions fell back to Coulomb + viscous and agree.
SymmetricFriction symmetric_friction(const IdentifyResult& r);
/// Streams samples [begin, end) of the signals through a new core with `cfg`
/// (its force lag as given) and solves.
CoreRun run_core(const Signals& s, const feedid::Config<double>& cfg, const IdentifyOptions& opt,
                 std::size_t begin = 0, std::size_t end = static_cast<std::size_t>(-1),
                 const std::vector<std::size_t>& run_starts = {});

/// A core of type C (Core or BandsCore) that samples [begin, end) of the
/// signals were streamed through with `cfg` (its force lag as given), then
/// solved by `method`: an identification of the searches and the standard
/// errors, which need no counters and no model selection.
template <typename C>
struct SolvedCore {
  feedid::Status status = feedid::Status::not_initialized;
  feedid::Estimate<double> estimate{};
  std::unique_ptr<C> core;
};
template <typename C>
SolvedCore<C> solve_core(const Signals& s, const feedid::Config<double>& cfg, feedid::Method method,
                         std::size_t begin = 0, std::size_t end = static_cast<std::size_t>(-1));
extern template SolvedCore<Core> solve_core(const Signals&, const feedid::Config<double>&, feedid::Method, std::size_t, std::size_t);
extern template SolvedCore<BandsCore> solve_core(const Signals&, const feedid::Config<double>&, feedid::Method, std::size_t, std::size_t);

/// Samples run_core or solve_core has pushed through a core on this thread so far: the
/// difference over a call is that call's cost in core passes times the
/// trace's length (IdentifyResult::core_passes).
std::uint64_t core_samples_pushed();

/// Contiguous stretches of every delete-one jackknife (parameters, the
/// block mass, the force lag), of equal sample counts: chunk c holds the
/// samples from chunk_begin(c, n) up to chunk_begin(c + 1, n). By samples,
/// not time: one row stamped years ahead (or a long pause between pooled
/// runs) put every block in one chunk of time, and the mass's standard
/// error on EMPS fell from 0.12 to 0.028 kg with status ok.
constexpr int kJackknifeChunks = 10;
constexpr std::size_t chunk_begin(int c, std::size_t n) {
  return n * static_cast<std::size_t>(c) / static_cast<std::size_t>(kJackknifeChunks);
}

/// The jackknife chunk (0 .. kJackknifeChunks-1) that sample k of n falls in.
int chunk_of(std::size_t k, std::size_t n);

/// Standard error from delete-one estimates theta_-i:
/// sqrt((g-1)/g sum (theta_-i - mean)^2); NaN for fewer than two.
double jackknife_se(const std::vector<double>& leave_one_out);

/// The largest force delay (lag behind velocity plus the velocity's own
/// lag, periods) a logging convention explains: a period mean's +1/2 plus
/// the lag search's accuracy (held commands sit at -1/2, symmetric).
double convention_force_delay_limit();

/// Mean force residual [integral w (u - F) dt - m integral w dv] / integral w
/// over pairs of adjacent blocks of about block_s under a triangular weight
/// w (no derivative, no raw velocity sample; identify.cpp, for_each_block).
struct BlockResidual {
  double sum_squares = 0.0;  ///< N^2
  std::size_t blocks = 0;
  std::array<double, kJackknifeChunks> chunk_sum_squares{};  ///< the same per jackknife chunk
  double rms() const { return blocks > 0 ? std::sqrt(sum_squares / static_cast<double>(blocks)) : 0.0; }
};
BlockResidual block_residual(const Signals& s, const DriveParams& p, double v_min, double block_s);

/// One observation of the block rule, kept so that the residual and the
/// mass can be formed at any pairing of the force without another pass:
/// the triangle-weighted integrals of the friction model and of the force
/// at each age, the velocity change and the weight's area.
struct BlockPair {
  double friction = 0.0;  ///< integral w F(v) dt (N s)
  ForceAges force{};      ///< integral w u(age) dt per age (N s)
  double dv = 0.0;        ///< integral w dv (m/s)
  double area = 0.0;      ///< integral w (s)
  int chunk = 0;          ///< chunk_of its end
  /// integral w (u - F) dt with the force paired by p and led by `lead`
  /// whole samples (a delay of the motion by as many; N s).
  double impulse(const feedid::ForcePairing<double>& p, int lead = 0) const;
};
/// The block rule's observations of s with friction p (blocks above v_min, of block_s).
std::vector<BlockPair> block_pairs(const Signals& s, const DriveParams& p, double v_min, double block_s);
/// The same residual from kept observations, the force paired by `pairing`.
BlockResidual block_residual(const std::vector<BlockPair>& pairs, const feedid::ForcePairing<double>& pairing,
                             double mass_kg, int lead = 0);

/// Mass fitted on the same blocks, friction held at p: sum(impulse dv) /
/// sum(dv^2), with a delete-one jackknife over the jackknife chunks.
struct BlockMass {
  bool ok = false;
  double mass_kg = 0.0;
  double mass_se_kg = 0.0;
};
BlockMass block_mass(const Signals& s, const DriveParams& p, double v_min, double block_s);
BlockMass block_mass(const std::vector<BlockPair>& pairs, const feedid::ForcePairing<double>& pairing, int lead = 0);

/// One observation of the block rule at a single pairing of the force:
/// what a search needs that forms the residual at one lag only. The same
/// sums as a BlockPair's impulse at that pairing, from three force taps
/// per sample instead of integrals of eleven (issue 29).
struct PairedBlock {
  double impulse = 0.0;  ///< integral w (u - F) dt (N s)
  double dv = 0.0;       ///< integral w dv (m/s)
  double area = 0.0;     ///< integral w (s)
  int chunk = 0;         ///< chunk_of its end
};
/// The block rule's observations of s at its own pairing (s.pairing()).
std::vector<PairedBlock> paired_blocks(const Signals& s, const DriveParams& p, double v_min, double block_s);
/// Kept observations taken at one pairing, the force led by `lead` samples.
std::vector<PairedBlock> at_pairing(const std::vector<BlockPair>& pairs, const feedid::ForcePairing<double>& pairing,
                                    int lead = 0);
BlockResidual block_residual(const std::vector<PairedBlock>& blocks, double mass_kg);
BlockMass block_mass(const std::vector<PairedBlock>& blocks);




/// The parameters of a solved result that are not physical
/// (non_physical_parameters); empty when physical or not solved (status
/// not ok: nothing to judge).
std::string not_physical(const IdentifyResult& r);

/// The result's status as the JSON and the summary say it: the core's
/// status name, or "not_physical" where the core solved but the model is
/// not physical, so that no output says "ok" beside a model every command
/// refuses.
std::string status_word(const IdentifyResult& r);

/// The likeliest cause of a model that is not physical, in words; empty
/// when it is physical. Every term negative: the force's sign. One
/// direction's Coulomb force negative beyond two standard errors while the
/// other's is positive: a constant load force F0 (gravity on an inclined
/// or vertical axis, a counterweight, cable drag, a sensor offset) adds to
/// one direction's Coulomb force and takes from the other's, so that
/// F0 = (Fc+ - Fc-)/2 and the Coulomb force is (Fc+ + Fc-)/2. Within its
/// standard error of zero: the data do not resolve it.
std::string not_physical_cause(const IdentifyResult& r);

/// SysId's gains (V = kS sgn(v) + kV v + kA a + kG) from the two
/// directions, for a force in volts: kS the mean Coulomb force, kV the mean
/// viscous coefficient, kA the mass, kG the constant load (half the
/// difference of the Coulomb forces: an elevator's gravity). Standard
/// errors from the directions' (independent sections). Where only one
/// direction's friction is identified (a SysId test that moves one way),
/// kS and kV are that direction's and kG is NaN: it needs both.
struct SysIdGains {
  double kS = 0.0, kS_se = 0.0, kV = 0.0, kV_se = 0.0, kA = 0.0, kA_se = 0.0, kG = 0.0, kG_se = 0.0;
  std::string direction;  ///< "positive" or "negative" where only that one moved; empty for both
};
SysIdGains sysid_gains(const IdentifyResult& r);

/// Magnitudes no feed drive has, in SI units (a linear axis: m outside
/// 0.01 kg to 1e5 kg, a speed beyond 20 m/s, a Coulomb force beyond 1e6 N;
/// a rotary one: an inertia outside 1e-8 to 1e4 kg m^2, beyond 2000 rad/s):
/// a position in counts or a force in amps left unscaled makes them with
/// status ok (a mass of 1.4e-7 kg). One warning each, naming the likely
/// missing scale; none for a force labelled in another unit (V, A).
std::vector<std::string> implausible_magnitudes(const IdentifyResult& r);

/// What identify warns of: implausible_magnitudes, an estimated force lag
/// that only the reversals tell (kLagToldByReversals), and one at an end of
/// the range searched (kForceLagMin, kForceLagMax), which a longer delay
/// would put there with m and sigma off by many standard errors.
std::vector<std::string> identify_warnings(const IdentifyResult& r);

nlohmann::json to_json(const IdentifyResult& r);
std::string summary(const IdentifyResult& r, const DriveParams* truth = nullptr);

}  // namespace feedid::host
