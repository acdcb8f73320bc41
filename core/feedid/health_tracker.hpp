// Friction health on the drive: one axis's epoch estimator and change
// monitor together, in fixed memory (docs/monitor.md, docs/firmware.md).
//
// One task pushes every sample into the current epoch and, when the
// epoch's time is complete, closes it: the epoch is solved on its own, its
// parameters go to the ChangeMonitor (compared with the reference, CUSUM,
// alarm), and the next epoch starts from a fresh estimator. Each epoch is
// identified alone, so an estimate never mixes motion from before and after
// a change; the reference is the monitor's.
//
// push() and close_epoch() must run in the same task: close_epoch() solves
// and re-initialises the estimator push() writes to. On a drive the servo
// interrupt hands its samples to that task through a queue
// (feedid_port/spsc_queue.hpp, as port/cortex_m/main.cpp does), which
// holds the samples that arrive during the close (0.2-0.26 M instructions
// measured on the M4, docs/firmware.md).
//
// Time is summed with compensation (Sum), so an epoch's clock stays exact to
// float rounding for any length; with T = float the reported times resolve
// ~1e-7 of the uptime (about 2 s after 194 days).
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
/// within 8 KiB (the firmware check prints the figure: docs/firmware.md). An epoch of ordinary motion visits a few speeds,
/// which 24 log-spaced bands separate as well as 32 (docs/monitor.md).
template <typename T, int Bands = 24, int Candidates = 16, int MaxAlarms = 16> class HealthTracker {
 public:
  using Axis = Estimator<T, Bands, Candidates>;
  using Monitor = ChangeMonitor<T, MaxAlarms>;

  /// Checks both configurations (ChangeMonitor::init, which also checks
  /// epoch_s, then Estimator::init); config_error() names what was wrong. On
  /// error nothing is usable (push and close_epoch return not_initialized)
  /// and the monitor keeps its alarms. Context: task.
  [[nodiscard]] Status init(const Config<T>& axis_cfg, const MonitorConfig<T>& monitor_cfg) {
    initialized_ = false;
    Monitor fresh;
    if (fresh.init(monitor_cfg) != Status::ok) {
      config_error_ = "MonitorConfig: reference_epochs 3..16, allowance >= 0, threshold > 0, relative_floor >= 0, "
                      "epoch_s > 0, all finite";
      return Status::invalid_config;
    }
    const Status st = axis_.init(axis_cfg);
    config_error_ = axis_.config_error();
    if (st != Status::ok) return st;
    monitor_ = fresh;
    axis_cfg_ = axis_cfg;
    epoch_s_ = monitor_cfg.epoch_s;
    epoch_start_s_ = elapsed_s_ = Sum<T>{};
    epochs_ = 0;
    last_epoch_ = Estimate<T>{};
    initialized_ = true;
    return Status::ok;
  }
  /// What init() rejected, or nullptr.
  const char* config_error() const { return config_error_; }

  /// One servo sample into the current epoch: Estimator::push, whose
  /// rejections change nothing but its counters. The epoch's clock advances
  /// by every finite positive dt, rejected samples' included (time passed),
  /// but by no more than the estimator's max_gap_s: a longer step is a gap
  /// to the estimator, its length says nothing about friction, and a
  /// corrupt one (1e30 s) would end the epoch at once and leave the clock
  /// where no later step moves it. Nor by more than epoch_s: one step can
  /// at most complete an epoch, so that however large a max_gap_s the
  /// configuration allows, the clock stays finite. An epoch is epoch_s of
  /// data. Context: servo task.
  [[nodiscard]] Status push(const Sample<T>& s) {
    if (!initialized_) return Status::not_initialized;
    if (port::is_finite(s.dt_s) && s.dt_s > T(0)) elapsed_s_.add(port::min(s.dt_s, port::min(axis_cfg_.max_gap_s, epoch_s_)));
    return axis_.push(s);
  }

  /// True once the current epoch has lasted epoch_s.
  bool epoch_complete() const { return initialized_ && elapsed_s_.get() >= epoch_s_; }

  /// Solves the current epoch, hands its estimate to the monitor (`fresh`:
  /// alarms it raised) and starts the next epoch. Returns the solve's
  /// status; an epoch that did not solve is not compared. Bounded work: one
  /// solve() and one ChangeMonitor::update(). Context: background task.
  [[nodiscard]] Status close_epoch(int& fresh) {
    fresh = 0;
    if (!initialized_) return Status::not_initialized;
    const Status solved = axis_.solve();
    last_epoch_ = axis_.estimate();
    const T start_s = epoch_start_s_.get();
    const T end_s = start_s + elapsed_s_.get();
    if (solved == Status::ok) (void)monitor_.update(last_epoch_, start_s, end_s, fresh);
    ++epochs_;
    epoch_start_s_.add(elapsed_s_.get());
    elapsed_s_ = Sum<T>{};
    (void)axis_.init(axis_cfg_);  // checked in init()
    return solved;
  }

  const Monitor& monitor() const { return monitor_; }
  /// The last closed epoch's estimate (flags say what it could carry).
  const Estimate<T>& last_epoch() const { return last_epoch_; }
  int epochs() const { return epochs_; }
  /// Time since init() (s): the start of the current epoch plus its clock.
  T time_s() const { return epoch_start_s_.get() + elapsed_s_.get(); }

 private:
  Axis axis_{};
  Monitor monitor_{};
  Config<T> axis_cfg_{};
  Estimate<T> last_epoch_{};
  T epoch_s_ = T(0);
  Sum<T> epoch_start_s_{}, elapsed_s_{};  ///< compensated: exact to rounding over any length
  int epochs_ = 0;
  const char* config_error_ = nullptr;
  bool initialized_ = false;
};

}  // namespace feedid
