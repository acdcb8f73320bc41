// Friction health on the drive: one axis's epoch estimator and change
// monitor together, in fixed memory (docs/monitor.md, docs/firmware.md).
//
// The servo task pushes every sample into the current epoch; when the
// epoch's time is complete, the background task closes it: the epoch is
// solved on its own, its parameters go to the ChangeMonitor (compared with
// the reference, CUSUM, alarm), and the next epoch starts from a fresh
// estimator. Each epoch is identified alone, so an estimate never mixes
// motion from before and after a change; the reference is the monitor's.
//
//   feedid::HealthTracker<float> health;
//   if (health.init(axis_config, feedid::MonitorConfig<float>{}) != feedid::Status::ok) ...
//   (void)health.push(sample);               // each servo period
//   if (health.epoch_complete()) {           // background task
//     int fresh = 0;
//     (void)health.close_epoch(fresh);
//     for (int i = health.monitor().alarm_count() - fresh; i < health.monitor().alarm_count(); ++i) ...
//   }
#pragma once

#include "feedid/estimator.hpp"
#include "feedid/monitor.hpp"

namespace feedid {

/// Bands: 24 by default, not the identification default of 32, so that one
/// axis's tracking state in float (estimator, monitor, last epoch) stays
/// within 8 KiB (7.8 KiB). An epoch of ordinary motion visits a few speeds,
/// which 24 log-spaced bands separate as well as 32 (docs/monitor.md).
template <typename T, int Bands = 24, int Candidates = 16, int MaxAlarms = 16> class HealthTracker {
 public:
  using Axis = Estimator<T, Bands, Candidates>;
  using Monitor = ChangeMonitor<T, MaxAlarms>;

  /// Checks both configurations (Estimator::init, ChangeMonitor::init, which
  /// also checks epoch_s). On error nothing is usable: push and close_epoch
  /// return not_initialized. Context: task.
  [[nodiscard]] Status init(const Config<T>& axis_cfg, const MonitorConfig<T>& monitor_cfg) {
    initialized_ = false;
    Status st = monitor_.init(monitor_cfg);
    if (st != Status::ok) return st;
    st = axis_.init(axis_cfg);
    if (st != Status::ok) return st;
    axis_cfg_ = axis_cfg;
    epoch_s_ = monitor_cfg.epoch_s;
    epoch_start_s_ = elapsed_s_ = T(0);
    epochs_ = 0;
    last_epoch_ = Estimate<T>{};
    initialized_ = true;
    return Status::ok;
  }

  /// One servo sample into the current epoch: Estimator::push, whose
  /// rejections change nothing but its counters. The epoch's clock advances
  /// by every finite positive dt, rejected samples' included (time passed).
  /// Context: servo task.
  [[nodiscard]] Status push(const Sample<T>& s) {
    if (!initialized_) return Status::not_initialized;
    if (port::is_finite(s.dt_s) && s.dt_s > T(0)) elapsed_s_ += s.dt_s;
    return axis_.push(s);
  }

  /// True once the current epoch has lasted epoch_s.
  bool epoch_complete() const { return initialized_ && elapsed_s_ >= epoch_s_; }

  /// Solves the current epoch, hands its estimate to the monitor (`fresh`:
  /// alarms it raised) and starts the next epoch. Returns the solve's
  /// status; an epoch that did not solve is not compared. Bounded work: one
  /// solve() and one ChangeMonitor::update(). Context: background task.
  [[nodiscard]] Status close_epoch(int& fresh) {
    fresh = 0;
    if (!initialized_) return Status::not_initialized;
    const Status solved = axis_.solve();
    last_epoch_ = axis_.estimate();
    // The clock within an epoch stays small, so its float sum keeps its
    // resolution; the epoch start takes one rounding per epoch.
    const T end_s = epoch_start_s_ + elapsed_s_;
    if (solved == Status::ok) (void)monitor_.update(last_epoch_, epoch_start_s_, end_s, fresh);
    ++epochs_;
    epoch_start_s_ = end_s;
    elapsed_s_ = T(0);
    (void)axis_.init(axis_cfg_);  // checked in init()
    return solved;
  }

  const Monitor& monitor() const { return monitor_; }
  /// The last closed epoch's estimate (flags say what it could carry).
  const Estimate<T>& last_epoch() const { return last_epoch_; }
  int epochs() const { return epochs_; }
  /// Time since init() (s): the start of the current epoch plus its clock.
  T time_s() const { return epoch_start_s_ + elapsed_s_; }

 private:
  Axis axis_{};
  Monitor monitor_{};
  Config<T> axis_cfg_{};
  Estimate<T> last_epoch_{};
  T epoch_s_ = T(0), epoch_start_s_ = T(0), elapsed_s_ = T(0);
  int epochs_ = 0;
  bool initialized_ = false;
};

}  // namespace feedid
