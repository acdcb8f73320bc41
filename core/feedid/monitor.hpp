// Friction health: change alarms from the estimates of successive epochs of
// ordinary motion. Freestanding, fixed memory, no heap.
//
// The estimator identifies one epoch at a time (init, push the epoch's
// samples, solve); the monitor compares each epoch's parameters with a
// reference, the pooled estimate of the first `reference_epochs` epochs,
// and raises an alarm when a two-sided CUSUM of the standardised
// differences crosses its threshold:
//
//   z = (theta_epoch - theta_ref) / max(c sqrt(se_epoch^2 + se_ref^2), f |theta_ref|)
//   S+ = max(0, S+ + z - k),  S- = max(0, S- - z - k),  alarm at S > h
//
// c >= 1 is the reference epochs' own over-dispersion (their chi-square per
// degree of freedom, rooted): if the epochs scatter more than their
// standard errors say, every z is scaled down by it, so the false-alarm rate
// holds on data whose standard errors are optimistic. f (1 %) is the
// smallest change worth a standard deviation. Each z is clipped at
// k + 0.6 h, so no single epoch can raise an alarm and two strong ones can;
// and the run that crossed must itself show a change beyond the floor and
// two standard errors. A parameter an
// epoch's motion cannot carry (flagged not identifiable) is skipped in that
// epoch: neither compared nor accumulated. After an alarm the parameter
// takes a new reference from the next epochs.
//
// Persistence: what enters the reference and the CUSUM is not each epoch
// but the median of the last three epochs that carried the parameter (with
// that epoch's standard error). One epoch that went astray, however small
// its standard error, is never the median of three: it can neither raise
// an alarm nor pull a reference, a run's mean or the CUSUM away from a real
// change (a fit that came out Coulomb 81 N +- 0.02 N between epochs of 58
// and 66 N hid a 12.5 % step, issue 32). A step is followed from the second
// epoch after it.
//
//   feedid::ChangeMonitor<float> health;
//   if (health.init(feedid::MonitorConfig<float>{}) != feedid::Status::ok) ...
//   // each epoch: axis.init(cfg); push its samples; axis.solve();
//   int fresh = 0;
//   health.update(axis.estimate(), t_start_s, t_end_s, fresh);
//   for (int i = health.alarm_count() - fresh; i < health.alarm_count(); ++i) report(health.alarm(i));
#pragma once

#include <stdint.h>

#include "feedid/types.hpp"
#include "feedid_port/math.hpp"

namespace feedid {

/// What the monitor tracks: m, then per direction sigma, Fc, Fs, vs.
enum class Tracked : uint8_t { mass = 0, viscous, coulomb, breakaway, stribeck_velocity };
constexpr int kTrackedCount = 9;  ///< m + 2 directions x 4
inline const char* tracked_name(Tracked p) {
  switch (p) {
    case Tracked::mass: return "m";
    case Tracked::viscous: return "sigma";
    case Tracked::coulomb: return "fc";
    case Tracked::breakaway: return "fs";
    case Tracked::stribeck_velocity: return "vs";
  }
  return "?";
}

/// An epoch's value and standard error of tracked index i (0: m; 1 + 4 d +
/// {0 sigma, 1 Fc, 2 Fs, 3 vs}, d = 0 pos, 1 neg); false when the epoch
/// cannot carry it: flagged, negative, or without a standard error. The
/// monitor compares only what this accepts, and reports say so with it.
template <typename T> bool tracked_value(const Estimate<T>& e, int i, T& value, T& se) {
  if (i == 0) {
    value = e.mass_kg;
    se = e.mass_se_kg;
    return e.mass_identified() && se > T(0);
  }
  const DirectionEstimate<T>& d = i <= 4 ? e.pos : e.neg;
  const int k = (i - 1) % 4;
  // A negative magnitude is a fit the epoch's motion could not pin down.
  const bool physical = (d.flags & flag_not_physical) == 0;
  const bool stribeck = physical && d.stribeck_identified();
  const bool coulomb = physical && d.coulomb_identified(), viscous = physical && d.viscous_identified();
  const T v[4] = {d.viscous_Ns_m, d.coulomb_N, d.breakaway_N, d.stribeck_velocity_m_s};
  const T s[4] = {d.viscous_se, d.coulomb_se, d.breakaway_se, d.stribeck_velocity_se};
  value = v[k];
  se = s[k];
  const bool carried = k == 0 ? viscous : k == 1 ? coulomb : stribeck;
  return carried && se > T(0) && port::is_finite(value) && port::is_finite(se);
}

template <typename T> struct MonitorConfig {
  /// Medians (of three carrying epochs) pooled into a reference (3 ..
  /// kMaxReferenceEpochs): 4 medians take six carrying epochs, as six epochs
  /// did before the medians.
  int reference_epochs = 4;
  T allowance = T(1);        ///< CUSUM k: shifts below k standard deviations are not pursued
  T threshold = T(6);        ///< CUSUM h (docs/monitor.md gives its false-alarm rate)
  /// Floor of each difference's standard deviation, as a share of the
  /// reference: changes well below it (a motion-dependent bias of a few
  /// tenths of a percent) are not what an alarm is for.
  T relative_floor = T(0.01);
  /// Length of an epoch (s): each is identified alone (HealthTracker, `feedid monitor --epoch-s`).
  T epoch_s = T(10);
  /// Alarm on the break-away force and the Stribeck velocity too. Off by
  /// default: read off the few slow bands an epoch of ordinary motion
  /// visits, they scatter from epoch to epoch beyond their standard errors
  /// (100 simulated machine-hours, docs/monitor.md: 20 alarms on Fs and vs
  /// in 75 change-free hours, none on m, sigma or Fc).
  bool watch_stribeck = false;
};

template <typename T> struct ChangeAlarm {
  Tracked parameter = Tracked::mass;
  int8_t direction = 0;  ///< +1 pos, -1 neg, 0 for the mass
  T t_s = T(0);          ///< start of the first epoch of the run that crossed: when it changed
  T raised_t_s = T(0);   ///< end of the epoch that crossed: when the alarm was raised
  T change = T(0);       ///< mean of that run's epochs minus the reference
  T change_se = T(0);
  T reference = T(0);
};

template <typename T, int MaxAlarms = 16> class ChangeMonitor {
 public:
  static constexpr int kMaxReferenceEpochs = 16;  ///< a bound on the reference period, not storage

  /// Invalid_config unless 3 <= reference_epochs <= 16, allowance >= 0,
  /// threshold > 0, relative_floor >= 0 and epoch_s > 0, all finite. Clears every track and alarm.
  Status init(const MonitorConfig<T>& c) {
    const bool ok = c.reference_epochs >= 3 && c.reference_epochs <= kMaxReferenceEpochs && port::is_finite(c.allowance) &&
                    c.allowance >= T(0) && port::is_finite(c.threshold) && c.threshold > T(0) &&
                    port::is_finite(c.relative_floor) && c.relative_floor >= T(0) && port::is_finite(c.epoch_s) &&
                    c.epoch_s > T(0);
    if (!ok) return Status::invalid_config;
    cfg_ = c;
    for (Track& t : tracks_) t = Track{};
    alarms_ = 0;
    initialized_ = true;
    return Status::ok;
  }

  /// One epoch's estimate over [t_start_s, t_end_s]. `fresh`: alarms it
  /// raised (the newest entries of alarm()). Not_initialized before init().
  Status update(const Estimate<T>& e, T t_start_s, T t_end_s, int& fresh) {
    fresh = 0;
    if (!initialized_) return Status::not_initialized;
    for (int i = 0; i < kTrackedCount; ++i) {
      T value, se;
      if (!watched(i) || !tracked_value(e, i, value, se)) continue;
      if (step(tracks_[i], value, se, t_start_s) && alarms_ < MaxAlarms) {
        alarm_[alarms_] = make_alarm(i);
        alarm_[alarms_++].raised_t_s = t_end_s;
        ++fresh;
        tracks_[i] = Track{};  // a fresh reference from the next epochs
      }
    }
    return Status::ok;
  }

  int alarm_count() const { return alarms_; }
  const ChangeAlarm<T>& alarm(int i) const { return alarm_[i]; }
  /// The reference of a tracked index (0: m; 1 + 4 d + {0 sigma, 1 Fc, 2 Fs, 3 vs}); false until it is set.
  bool reference(int i, T& value, T& se) const {
    const Track& t = tracks_[i];
    if (!t.referenced) return false;
    value = t.ref;
    se = t.ref_se;
    return true;
  }
  /// Whether tracked index i is compared (Fs and vs only where watch_stribeck asks).
  bool watched(int i) const {
    const Tracked p = parameter_of(i);
    return cfg_.watch_stribeck || (p != Tracked::breakaway && p != Tracked::stribeck_velocity);
  }
  static Tracked parameter_of(int i) { return i == 0 ? Tracked::mass : static_cast<Tracked>(1 + (i - 1) % 4); }
  static int8_t direction_of(int i) { return i == 0 ? 0 : (i <= 4 ? 1 : -1); }

 private:
  struct Run {  // epochs since the CUSUM last left zero on one side
    T t0 = T(0), w = T(0), wx = T(0);
  };
  /// The last three epochs that carried a parameter (ring, newest at
  /// `head`; the counters live in Track's flag word, 216 B for nine tracks).
  struct Window {
    T x[3] = {T(0), T(0), T(0)}, se[3] = {T(0), T(0), T(0)}, t0[3] = {T(0), T(0), T(0)};
    void push(T xi, T sei, T ti, uint8_t& n, uint8_t& head) {
      head = static_cast<uint8_t>((head + 1) % 3);
      x[head] = xi, se[head] = sei, t0[head] = ti;
      if (n < 3) ++n;
    }
    /// Index of the median value (n == 3).
    int median() const {
      if ((x[0] <= x[1]) == (x[1] <= x[2])) return 1;
      if ((x[1] <= x[0]) == (x[0] <= x[2])) return 0;
      return 2;
    }
  };
  struct Track {
    Window window;
    int ref_n = 0;
    bool referenced = false;
    int8_t last_side = 0;  ///< which side crossed
    uint8_t window_n = 0, window_head = 0;
    // The reference epochs as inverse-variance sums about the first one's
    // value (the shift keeps the float sum of squares from cancelling).
    T shift = T(0), sw = T(0), swx = T(0), swxx = T(0);
    T ref = T(0), ref_se = T(0), scale = T(1);
    T up = T(0), down = T(0);
    Run run_up, run_down;
  };

  /// The median of the last three carrying epochs; then the reference
  /// first, then the CUSUM. True when it crosses.
  bool step(Track& t, T x_epoch, T se_epoch, T t_epoch) {
    t.window.push(x_epoch, se_epoch, t_epoch, t.window_n, t.window_head);
    if (t.window_n < 3) return false;
    const int mi = t.window.median();
    const T x = t.window.x[mi], se = t.window.se[mi];
    if (!t.referenced) {
      if (t.ref_n == 0) t.shift = x;
      const T w = T(1) / (se * se), d = x - t.shift;
      t.sw += w;
      t.swx += w * d;
      t.swxx += w * d * d;
      if (++t.ref_n == cfg_.reference_epochs) set_reference(t);
      return false;
    }
    const T s = port::max(t.scale * port::sqrt(se * se + t.ref_se * t.ref_se), cfg_.relative_floor * port::abs(t.ref));
    // Clipped: one epoch alone cannot cross the threshold (z - k <= 0.6 h),
    // so an alarm needs at least two epochs that agree (an epoch whose fit
    // went astray with too small a standard error is not enough), and two
    // strong ones do (1.2 h).
    const T z_max = cfg_.allowance + T(0.6) * cfg_.threshold;
    const T z = port::clamp((x - t.ref) / s, -z_max, z_max);
    advance(t.up, t.run_up, z - cfg_.allowance, x, se, run_start(t, s, 1));
    advance(t.down, t.run_down, -z - cfg_.allowance, x, se, run_start(t, s, -1));
    return crossed(t, t.up, t.run_up, 1) || crossed(t, t.down, t.run_down, -1);
  }

  /// A side above the threshold is an alarm only if the run it accumulated
  /// shows a change itself: its pooled mean beyond the floor and two of its
  /// standard errors from the reference. Two stray epochs a few epochs
  /// apart can push the sum over while the run's mean has not moved (a
  /// sine log: sigma- "changed" by 0.27 +- 0.15 N s/m of 720); such a run
  /// is dropped and the side starts again.
  bool crossed(Track& t, T& cusum, Run& run, int8_t side) const {
    if (!(cusum > cfg_.threshold)) return false;
    const T change = run.wx / run.w - t.ref;
    const T change_se = t.scale * port::sqrt(T(1) / run.w + t.ref_se * t.ref_se);
    if (port::abs(change) > port::max(T(2) * change_se, cfg_.relative_floor * port::abs(t.ref))) {
      t.last_side = side;
      return true;
    }
    cusum = T(0);
    return false;
  }

  /// When a run on `side` that starts now began: the earliest epoch in the
  /// window beyond the allowance on that side (the median lags a step by an
  /// epoch), else the newest.
  T run_start(const Track& t, T s, int side) const {
    T start = t.window.t0[t.window_head];
    for (int i = 0; i < 3; ++i)
      if (T(side) * (t.window.x[i] - t.ref) / s > cfg_.allowance && t.window.t0[i] < start) start = t.window.t0[i];
    return start;
  }

  static void advance(T& cusum, Run& run, T increment, T x, T se, T t0) {
    if (cusum <= T(0)) run = Run{t0, T(0), T(0)};  // a fresh run starts with this epoch
    cusum = port::max(T(0), cusum + increment);
    const T w = T(1) / (se * se);
    run.w += w;
    run.wx += w * x;
  }

  /// Inverse-variance mean of the reference epochs, and their
  /// over-dispersion: sum w (x - ref)^2 = sum w d^2 - (sum w d)^2 / sum w.
  void set_reference(Track& t) const {
    const T mean_d = t.swx / t.sw;
    t.ref = t.shift + mean_d;
    t.ref_se = port::sqrt(T(1) / t.sw);
    const T chi2 = port::max(T(0), t.swxx - mean_d * t.swx);
    t.scale = port::max(T(1), port::sqrt(chi2 / T(t.ref_n - 1)));
    t.referenced = true;
  }

  ChangeAlarm<T> make_alarm(int i) const {
    const Track& t = tracks_[i];
    const Run& r = t.last_side > 0 ? t.run_up : t.run_down;
    ChangeAlarm<T> a;
    a.parameter = parameter_of(i);
    a.direction = direction_of(i);
    a.t_s = r.t0;
    a.change = r.wx / r.w - t.ref;
    a.change_se = t.scale * port::sqrt(T(1) / r.w + t.ref_se * t.ref_se);
    a.reference = t.ref;
    return a;
  }

  MonitorConfig<T> cfg_{};
  Track tracks_[kTrackedCount]{};
  ChangeAlarm<T> alarm_[MaxAlarms]{};
  int alarms_ = 0;
  bool initialized_ = false;
};

}  // namespace feedid
