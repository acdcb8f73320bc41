// The force lag and the velocity cut-off found from the data: each is the
// choice whose identified model leaves the least residual over short blocks
// of motion (NOTES.md, "Logging conventions"; docs/method.md). They run the
// core, so they live in identify/, above the signals they choose for.
// Host only.
#pragma once
#include <cmath>
#include <limits>
#include <vector>

#include "identify/identify.hpp"
#include "signals/alignment.hpp"

namespace feedid::host {

/// Searched range of the force lag behind the core's velocity (sample periods):
/// held force (-1/2) less a velocity-only log's filter delay, up to a period
/// mean (+1/2) and a physical delay beyond it that the diagnosis names.
constexpr double kForceLagMin = -5.0;
constexpr double kForceLagMax = 3.0;
static_assert(kForceLagMax <= kForceLead, "the lag search leads the force by whole samples the blocks' taps hold");

/// Whether a search's lag stopped at an end of that range (the force may
/// lag further: identify warns).
inline bool at_range_end(const LagEstimate& e) {
  return std::fabs(e.lag_samples - kForceLagMin) < 1e-9 || std::fabs(e.lag_samples - kForceLagMax) < 1e-9;
}

/// Share of a shift's block residual that refitting friction and mass
/// takes back (LagEstimate::absorbed_by_refit) from which the held
/// friction's lag is not trusted and every lag is refitted: the held
/// search assumes friction does not absorb a shift (the ladder: 0.03,
/// EMPS: 0.01), and where it absorbs half (a tone with the force beyond
/// the range) the refits had a local least far from the truth.
constexpr double kLagRefitEveryLag = 0.25;

/// The same share from which the lag rests on the reversals alone, which
/// identify warns of: then m and sigma, which trade against the lag on the
/// rest of the motion, rest on the friction law at low speed there (a
/// single tone: 0.999; two tones: 0.6).
constexpr double kLagToldByReversals = 0.9;


/// The lag that minimises the residual of the identified model over short
/// blocks of motion (the inertia identity integral(u - F) = m dv is exact only
/// for the right pairing; a wrong one leaves about lag * (change of force)
/// in every block). Grid over [kForceLagMin, kForceLagMax], then a parabola
/// through the best point and its neighbours; the standard error from its
/// curvature and the block residual variance. The friction is the core's
/// at the pairing s has (once more at the best lag if that is over a
/// period away) and held over the grid, the mass refitted on the blocks at
/// each lag; the blocks are observed once per whole delay of the motion
/// (BlockPair): one or two passes of the core, not one per lag. `cfg` is
/// the core configuration for the trace (its lag is ignored).
///
/// `shared`: friction to hold that another search on the same trace
/// identified (one held friction for the derived velocity's search and the
/// logged column's); where it is ok the search runs no identification of
/// its own unless the grid's best lies at an end of the range. Where it is
/// not, and this search settles inside the range, the friction it held is
/// left there for the next search.
struct HeldFriction {
  bool ok = false;
  DriveParams params;
  /// What the search that identified it learnt from its refits
  /// (LagEstimate::absorbed_by_refit, and the refits' error of the lag,
  /// periods): a search holding it has no refits of its own, and the
  /// motion that confounds one lag confounds the other.
  double absorbed_by_refit = std::numeric_limits<double>::quiet_NaN();
  double refit_se_samples = 0.0;
};
LagEstimate estimate_force_lag(const Signals& s, const feedid::Config<double>& cfg, HeldFriction* shared = nullptr);

/// Cut-off of the core's velocity (the zero-phase derivative of position)
/// before one is chosen, and the lowest tried (Hz; lower on a slow or a held
/// log: lowest_velocity_filter_hz).
constexpr double kProvisionalVelocityFilter_hz = 300.0;
constexpr double kLowestVelocityFilter_hz = 100.0;

/// The lowest cut-off tried (Hz): kLowestVelocityFilter_hz, or 0.1 of the
/// rate the position is updated at (Signals::position_update_rate_hz) on a
/// slow log or one whose position is held for several rows.
double lowest_velocity_filter_hz(const Signals& s);

struct FilterChoice {
  double cutoff_hz = 0.0;
  int candidates = 0;  ///< cut-offs tried
  double block_ssr = std::numeric_limits<double>::infinity();  ///< at the chosen one (N^2)
  double least_block_ssr = std::numeric_limits<double>::infinity();  ///< the least of all tried (N^2)
  /// The other cut-offs whose block residual is within one standard error
  /// (delete-one-chunk jackknife of the difference) of the least: the data
  /// cannot tell them from the choice.
  std::vector<double> rivals_hz;
  /// With keep_velocities: the velocity derived at cutoff_hz, then at each
  /// rival, where the scan still held it (empty where it did not): the
  /// same bits as deriving it again from the same position.
  std::vector<std::vector<double>> velocities;
};

/// The cut-off, from lowest_velocity_filter_hz up to 0.4 of the rate in
/// half octaves, whose identified model leaves the least block
/// residual (the measure the lag search minimises) on `s` as aligned, or
/// the smoothest within one standard error of it (the one-standard-error
/// rule: on a 200 Hz SysId log three cut-offs were within a standard
/// error, and the least of them by chance halved the mass). A coarse encoder on a heavy axis
/// wants smoothing (the counts' noise enters m * dv at every band
/// crossing: Fs 10 % off at 1 kHz cut-off on a 400 kg, 100 nm, 4 kHz
/// axis); a fine one does not (vs 3 % off at 300 Hz on a 40 kg, 5 nm one,
/// where the filter rounds the Stribeck dip). The residual is least where
/// the parameters are best in both. cfg fixes the band edges for all.
/// Where the residual cannot tell cut-offs apart (FilterChoice::rivals_hz),
/// the spread of the parameters over them enters their standard errors
/// (uncertainty.hpp).
/// keep_velocities: hand the chosen and the rival cut-offs' velocities back
/// (FilterChoice::velocities) instead of dropping them; only the
/// candidates still within a standard error of the least are held.
/// `s` is the scan's own: each candidate's velocity is derived into it
/// (pass a copy, or move in a signal set not needed after).
FilterChoice choose_velocity_filter(Signals s, const feedid::Config<double>& cfg, bool keep_velocities = false);

/// Most samples the cut-off scan identifies on: 2^20, 131 s at 8 kHz,
/// more than any trace the method's coverage, the blind benchmark and the
/// monitor's head were validated on (at most 90 s at 8 kHz), so none of
/// them changes; a longer log is scanned on kJackknifeChunks stretches
/// spread over it (scan_selection), each chunk of the scan's jackknife
/// one of them. The scan identified at every cut-off on every sample: on
/// 10 minutes at 8 kHz it was a quarter of identify's time.
constexpr std::size_t kScanSamplesMax = std::size_t{1} << 20;

/// The samples the cut-off scan (and the velocity column's score against
/// it) runs on: all of s up to kScanSamplesMax, else kJackknifeChunks
/// equal stretches spread evenly over it, kScanSamplesMax or half of s in
/// all, whichever is less.
std::vector<char> scan_selection(const Signals& s);

/// Sum of squared 10 ms block residuals (N^2) of the model the core
/// identifies on `s` as paired, at cfg's band edges: the measure the lag
/// search and the velocity choice minimise. Infinite if nothing identifies.
double block_fit_ssr(const Signals& s, const feedid::Config<double>& cfg);

}  // namespace feedid::host
