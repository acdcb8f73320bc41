// The streaming identifier of one axis: init(config), push(sample) at the
// servo rate, solve() when asked, then estimate(). Fixed memory (Bands and
// Candidates are compile-time), no heap, no exceptions, no globals: one
// instance per axis. docs/method.md derives what is accumulated and why.
#pragma once

#include "feedid/solve.hpp"
#include "feedid/statistics.hpp"
#include "feedid/types.hpp"
#include "feedid_port/math.hpp"

namespace feedid {

template <typename T, int Bands = 32, int Candidates = 16> class Estimator {
 public:
  using Stats = Statistics<T, Bands, Candidates>;
  using Layout = BandLayout<T, Bands>;
  static constexpr int bands = Bands;
  static constexpr int candidates = Candidates;

  /// Checks every field, then resets all state. On error the estimator stays
  /// unusable (push/solve return not_initialized) and config_error() names
  /// the field. Context: task.
  [[nodiscard]] Status init(const Config<T>& cfg) {
    reset();
    config_error_ = check(cfg);
    if (config_error_) return Status::invalid_config;
    cfg_ = cfg;
    if (!(cfg_.section_enter_m_s > T(0))) cfg_.section_enter_m_s = T(2) * cfg_.velocity_min_m_s;
    layout_.init(cfg_.velocity_min_m_s, cfg_.velocity_max_m_s);
    const T lo = detail::stribeck_lo(cfg_), hi = detail::stribeck_hi(cfg_);
    for (int i = 0; i < Candidates; ++i)
      stats_.vs_candidate[i] = lo * port::exp(port::log(hi / lo) * T(i) / T(Candidates - 1));
    initialized_ = true;
    return Status::ok;
  }

  /// Takes one sample. A rejected sample changes nothing but the rejection
  /// counters: it never reaches a sum, and the next good sample bridges it.
  /// Cost: constant, a few dozen flops and one binary search; no loop over
  /// past data. Context: servo task or ISR (see port/ for the ISR hand-off).
  [[nodiscard]] Status push(const Sample<T>& s) {
    if (!initialized_) return Status::not_initialized;
    const Status verdict = vet(s);
    if (verdict != Status::ok) return reject(verdict, s);
    ++diag_.samples_accepted;

    const bool from_position = cfg_.velocity_source == VelocitySource::from_position;
    const T dt = s.dt_s + skipped_dt_;
    // No integral may span a gap, nor a rejected sample whose time step was
    // itself unknown (NaN dt): the elapsed time is then not known.
    if ((has_prev_ || has_x_prev_) && (dt > cfg_.max_gap_s || time_lost_)) {
      ++diag_.continuity_breaks;
      break_continuity();
      has_prev_ = has_x_prev_ = false;
    }
    time_lost_ = false;
    if (!has_prev_) {
      skipped_dt_ = T(0);
      if (from_position && !has_x_prev_) {  // velocity needs a second position
        has_x_prev_ = true;
        x_prev_ = s.position_m;
        return Status::ok;
      }
      start_from(s, from_position ? (s.position_m - x_prev_) / dt : s.velocity_m_s);
      return Status::ok;
    }
    const T v = velocity_of(s);
    skipped_dt_ = T(0);
    open_section_if_moving(v);
    accumulate_interval(dt, interval_force(s.force_N), T(0.5) * (v_prev_ + v), v - v_prev_, v);
    accumulate_noise(s.force_N);
    close_section_if_resting(v);
    fold_if_due();
    x_prev_ = s.position_m;
    v_prev_ = v;
    u_prev_ = s.force_N;
    return Status::ok;
  }

  /// Folds the open section and window (the section then no longer counts
  /// for the paper method) and computes the estimate. Bounded work: about
  /// 4 x 2 x (24 + max_vs_iterations) friction fits of Bands points.
  /// Context: task, never the ISR.
  [[nodiscard]] Status solve(Method method = Method::bands) {
    if (!initialized_) return Status::not_initialized;
    close_window();
    if (section_open_) mark_split();
    fold(0);
    fold(1);
    Estimate<T> e;
    e.method = method;
    const Status st = method == Method::paper ? detail::solve_paper(stats_, cfg_, e)
                                              : detail::solve_bands(stats_, layout_, cfg_, e);
    estimate_ = e;
    return st;
  }

  const Estimate<T>& estimate() const { return estimate_; }
  const Diagnostics& diagnostics() const { return diag_; }
  /// The sufficient statistics (folded part); for host-side plots and checks.
  const Stats& statistics() const { return stats_; }
  const Layout& layout() const { return layout_; }
  const Config<T>& config() const { return cfg_; }
  /// Name of the offending field after init() returned invalid_config.
  const char* config_error() const { return config_error_; }

 private:
  // Partial sums of the current fold period, one set per direction; plain
  // sums of at most max_fold_s of samples (accurate in float).
  struct Pending {
    T time[Bands], speed[Bands], speed2[Bands], force[Bands], dvel[Bands];
    T duration;
  };
  // The open section's own integrals, for the paper method only.
  struct PaperSection {
    T time[Bands], speed[Bands], speed2[Bands];
    T force;
  };
  struct Window {
    T time[Bands], speed[Bands], speed2[Bands];
    T force, tau, v_start, v_end;
    int dir, lo, hi, intervals;
    bool active;
  };

  /// Back to the state of a fresh object, in place: `*this = Estimator{}`
  /// would build a whole temporary (8 KB for float) on the caller's stack.
  /// All members are trivially copyable and zero bytes mean 0 / false.
  void reset() {
    zero(stats_);
    zero(pending_);
    zero(window_);
    zero(paper_);
    zero(diag_);
    zero(layout_);
    estimate_ = Estimate<T>{};
    cfg_ = Config<T>{};
    config_error_ = nullptr;
    initialized_ = has_prev_ = has_x_prev_ = rest_seen_ = time_lost_ = false;
    x_prev_ = v_prev_ = u_prev_ = u_prev2_ = skipped_dt_ = T(0);
    u_history_ = 0;
    section_open_ = section_from_rest_ = split_counted_ = false;
    section_dir_ = 0;
    below_count_ = 0;
    section_time_ = section_ua_ = section_aa_ = T(0);
    noise_d2_ = stats_interval_time_ = T(0);
    noise_count_ = stats_interval_count_ = 0;
  }
  template <typename U> static void zero(U& obj) { __builtin_memset(static_cast<void*>(&obj), 0, sizeof obj); }

  static const char* check(const Config<T>& c) {
    auto pos = [](T x) { return port::is_finite(x) && x > T(0); };
    auto nonneg = [](T x) { return port::is_finite(x) && x >= T(0); };
    if (!pos(c.velocity_min_m_s)) return "velocity_min_m_s must be > 0";
    if (!pos(c.velocity_max_m_s) || !(c.velocity_max_m_s > T(4) * c.velocity_min_m_s))
      return "velocity_max_m_s must be > 4 * velocity_min_m_s";
    if (!nonneg(c.velocity_resolution_m_s)) return "velocity_resolution_m_s must be >= 0";
    if (!nonneg(c.section_enter_m_s)) return "section_enter_m_s must be >= 0";
    if (c.rest_samples < 1) return "rest_samples must be >= 1";
    if (!nonneg(c.min_section_s)) return "min_section_s must be >= 0";
    if (!pos(c.max_fold_s)) return "max_fold_s must be > 0";
    if (!pos(c.mass_window_s)) return "mass_window_s must be > 0";
    if (!pos(c.max_acceleration_m_s2)) return "max_acceleration_m_s2 must be > 0";
    if (!pos(c.max_speed_m_s)) return "max_speed_m_s must be > 0";
    if (!pos(c.max_force_N)) return "max_force_N must be > 0";
    if (!pos(c.max_gap_s)) return "max_gap_s must be > 0";
    if (!pos(c.max_step_speed_ratio)) return "max_step_speed_ratio must be > 0";
    if (!nonneg(c.stribeck_min_m_s) || !nonneg(c.stribeck_max_m_s)) return "stribeck_min/max_m_s must be >= 0";
    const T lo = detail::stribeck_lo(c), hi = detail::stribeck_hi(c);
    if (!(hi > T(2) * lo)) return "stribeck_max_m_s must be > 2 * stribeck_min_m_s";
    if (c.max_vs_iterations < 1 || c.max_vs_iterations > 200) return "max_vs_iterations must be 1..200";
    if (c.velocity_source != VelocitySource::measured && c.velocity_source != VelocitySource::from_position)
      return "velocity_source is not a known value";
    if (static_cast<int>(c.force_alignment) > 2) return "force_alignment is not a known value";
    return nullptr;
  }

  T velocity_of(const Sample<T>& s) const {
    if (cfg_.velocity_source == VelocitySource::measured) return s.velocity_m_s;
    return has_x_prev_ ? (s.position_m - x_prev_) / (s.dt_s + skipped_dt_) : T(0);
  }

  Status vet(const Sample<T>& s) const {
    const bool need_x = cfg_.velocity_source == VelocitySource::from_position;
    if (!port::is_finite(s.dt_s) || !port::is_finite(s.force_N) ||
        (need_x ? !port::is_finite(s.position_m) : !port::is_finite(s.velocity_m_s)))
      return Status::rejected_not_finite;
    if ((has_prev_ || has_x_prev_) && !(s.dt_s > T(0))) return Status::rejected_time_not_increasing;
    // After a gap (or unknown elapsed time) the sample restarts the chain:
    // no velocity is formed across it, so none is range- or jump-checked.
    const T dt = s.dt_s + skipped_dt_;
    const bool continues = (has_prev_ || has_x_prev_) && dt <= cfg_.max_gap_s && !time_lost_;
    const bool from_position = cfg_.velocity_source == VelocitySource::from_position;
    if (from_position && !continues) {
      if (port::abs(s.force_N) > cfg_.max_force_N) return Status::rejected_out_of_range;
      return Status::ok;
    }
    const T v = velocity_of(s);
    if (!port::is_finite(v)) return Status::rejected_not_finite;
    if (port::abs(v) > cfg_.max_speed_m_s || port::abs(s.force_N) > cfg_.max_force_N)
      return Status::rejected_out_of_range;
    if (has_prev_ && continues) {
      const T allowed = cfg_.max_acceleration_m_s2 * dt + T(4) * cfg_.velocity_resolution_m_s;
      if (port::abs(v - v_prev_) > allowed) return Status::rejected_velocity_jump;
    }
    return Status::ok;
  }

  Status reject(Status why, const Sample<T>& s) {
    ++diag_.samples_rejected;
    switch (why) {
      case Status::rejected_not_finite: ++diag_.rejected_not_finite; break;
      case Status::rejected_time_not_increasing: ++diag_.rejected_time_not_increasing; break;
      case Status::rejected_out_of_range: ++diag_.rejected_out_of_range; break;
      default: ++diag_.rejected_velocity_jump; break;
    }
    // Time still passed: the next good sample's interval spans this one.
    if ((has_prev_ || has_x_prev_) && port::is_finite(s.dt_s) && s.dt_s > T(0)) skipped_dt_ += s.dt_s;
    if (!port::is_finite(s.dt_s)) time_lost_ = true;
    return why;
  }

  void start_from(const Sample<T>& s, T v) {
    has_prev_ = has_x_prev_ = true;
    x_prev_ = s.position_m;
    v_prev_ = v;
    u_prev_ = s.force_N;
    u_history_ = 1;
    section_open_ = false;
    below_count_ = 0;
    // A section opened before the axis was seen at rest did not start at rest.
    rest_seen_ = port::abs(v) < cfg_.velocity_min_m_s;
  }

  void break_continuity() {
    close_window();
    if (section_open_) { mark_split(); section_open_ = false; }
    fold(0);
    fold(1);
  }

  // --- sections: hysteresis on velocity ---------------------------------
  // Open when |v| >= section_enter (2*velocity_min by default) from rest;
  // close after rest_samples consecutive samples below velocity_min, or at a
  // reversal beyond section_enter. Jitter of a few quanta around zero never
  // reaches section_enter, so it opens no sections.
  // A reversal passes through zero velocity, so it ends one section and
  // starts the next as rest does (the end points' inertia term is ~0).
  void open_section_if_moving(T v) {
    if (section_open_) {
      if (T(section_dir_sign()) * v <= -cfg_.section_enter_m_s) {
        close_section();
        open_section(v > T(0) ? 0 : 1, true);
      }
      return;
    }
    if (port::abs(v) < cfg_.velocity_min_m_s) rest_seen_ = true;
    if (port::abs(v) >= cfg_.section_enter_m_s) open_section(v > T(0) ? 0 : 1, rest_seen_);
  }

  void open_section(int dir, bool from_rest) {
    section_open_ = true;
    section_dir_ = dir;
    section_from_rest_ = from_rest;
    section_time_ = T(0);
    section_ua_ = T(0);
    section_aa_ = T(0);
    below_count_ = 0;
    split_counted_ = false;
    paper_ = PaperSection{};
  }

  /// The open section will not count for the paper method; counted once.
  void mark_split() {
    section_from_rest_ = false;
    if (!split_counted_) { ++diag_.sections_split; split_counted_ = true; }
  }

  void close_section_if_resting(T v) {
    if (!section_open_) return;
    if (T(section_dir_sign()) * v < cfg_.velocity_min_m_s) {
      if (++below_count_ >= cfg_.rest_samples) { close_section(); rest_seen_ = true; }
    } else {
      below_count_ = 0;
    }
  }

  void close_section() {
    section_open_ = false;
    const int d = section_dir_;
    if (section_time_ < cfg_.min_section_s) ++diag_.sections_short;
    else if (section_from_rest_) add_paper_point(d);
    fold(d);
  }

  int section_dir_sign() const { return section_dir_ == 0 ? 1 : -1; }

  // --- per interval -------------------------------------------------------
  // Interval [t_{k-1}, t_k] by the trapezoid rule: mean force u, mean
  // velocity v, velocity change dv. Mirrored for the negative direction.
  void accumulate_interval(T dt, T u, T v, T dv, T v_now) {
    stats_interval_time_ += dt;
    ++stats_interval_count_;
    if (section_open_) section_time_ += dt;
    const T speed = port::abs(v);
    if (speed < cfg_.velocity_min_m_s) { close_window(); return; }  // at rest: not the model
    const int d = v > T(0) ? 0 : 1;
    const T sign = d == 0 ? T(1) : T(-1);
    const T um = sign * u, dvm = sign * dv;
    const int j = layout_.index(speed);
    const T sdt = speed * dt;
    // Paper method: the section's own integrals over all its moving intervals.
    if (section_open_ && section_dir_ == d) {
      paper_.time[j] += dt;
      paper_.speed[j] += sdt;
      paper_.speed2[j] += speed * sdt;
      paper_.force += um * dt;
      section_ua_ += um * dvm;
      section_aa_ += dvm * dvm / dt;
    }
    // Friction bands take quasi-steady intervals only: one that sweeps a
    // large part of its speed in a single step carries a large inertia
    // force, and any force/velocity timing error of the log leaks from it
    // into the narrow low-speed bands.
    if (port::abs(dv) <= cfg_.max_step_speed_ratio * speed) {
      Pending& p = pending_[d];
      p.time[j] += dt;
      p.speed[j] += sdt;
      p.speed2[j] += speed * sdt;
      p.force[j] += um * dt;
      p.dvel[j] += dvm;
      p.duration += dt;
    }
    // Mass window: consecutive intervals of one direction.
    if (window_.active && window_.dir != d) close_window();
    if (!window_.active) {
      window_.active = true;
      window_.dir = d;
      window_.v_start = sign * v_prev_;
      window_.lo = window_.hi = j;
    }
    window_.time[j] += dt;
    window_.speed[j] += sdt;
    window_.speed2[j] += speed * sdt;
    window_.force += um * dt;
    window_.tau += dt;
    window_.v_end = sign * v_now;
    ++window_.intervals;
    window_.lo = j < window_.lo ? j : window_.lo;
    window_.hi = j > window_.hi ? j : window_.hi;
    if (window_.tau >= cfg_.mass_window_s) close_window();
  }

  T interval_force(T u_now) const {
    switch (cfg_.force_alignment) {
      case ForceAlignment::held_force_backward_velocity:
        return u_history_ >= 2 ? T(0.5) * (u_prev2_ + u_prev_) : u_prev_;
      case ForceAlignment::held_force_instant_velocity: return u_prev_;
      default: return T(0.5) * (u_prev_ + u_now);
    }
  }

  void accumulate_noise(T u) {
    // Second difference of the force: a smooth force cancels, white noise of
    // variance s^2 leaves 6 s^2. Gives the noise floor without a model.
    if (u_history_ >= 2) {
      const T d2 = u - T(2) * u_prev_ + u_prev2_;
      noise_d2_ += d2 * d2;
      ++noise_count_;
    }
    u_prev2_ = u_prev_;
    if (u_history_ < 2) ++u_history_;
  }

  void close_window() {
    Window& w = window_;
    if (!w.active) return;
    if (w.intervals >= 2) {
      const T dvw = w.v_end - w.v_start;
      for (int j = w.lo; j <= w.hi; ++j) {
        BandSums<T>& b = stats_.band[w.dir][j];
        b.proj_time.add(dvw * w.time[j]);
        b.proj_speed.add(dvw * w.speed[j]);
        b.proj_speed2.add(dvw * w.speed2[j]);
      }
      DirectionSums<T, Candidates>& ds = stats_.dir[w.dir];
      ds.win_dv_force.add(dvw * w.force);
      ds.win_dv2.add(dvw * dvw);
      ds.win_tau_dv2.add(w.tau * dvw * dvw);
      ++diag_.mass_windows;
    }
    for (int j = w.lo; j <= w.hi; ++j) w.time[j] = w.speed[j] = w.speed2[j] = T(0);
    w.force = w.tau = T(0);
    w.intervals = 0;
    w.active = false;
  }

  /// Section end (not per sample): the section's point for the paper method
  /// (integral u dt = Fc T + sigma V + Fs E over the section), with
  /// integral exp(-(v/vs_i)^2) dt for each candidate vs_i from the section's
  /// band moments: Bands x Candidates exponentials. Paper mass equation:
  /// integral u a dt = sum u dv; integral a^2 dt = sum dv^2/dt.
  void add_paper_point(int d) {
    const PaperSection& p = paper_;
    T ts = T(0), vs_ = T(0);
    const T us = p.force;
    for (int j = 0; j < Bands; ++j) { ts += p.time[j]; vs_ += p.speed[j]; }
    if (!(ts > T(0))) return;
    DirectionSums<T, Candidates>& ds = stats_.dir[d];
    for (int i = 0; i < Candidates; ++i) {
      T e = T(0);
      for (int j = 0; j < Bands; ++j)
        if (p.time[j] > T(0)) e += exp_integral_moments(p.time[j], p.speed[j], p.speed2[j], stats_.vs_candidate[i]);
      ds.cand_et[i].add(e * ts);
      ds.cand_ev[i].add(e * vs_);
      ds.cand_eu[i].add(e * us);
      ds.cand_ee[i].add(e * e);
    }
    ds.sec_tt.add(ts * ts);
    ds.sec_tv.add(ts * vs_);
    ds.sec_vv.add(vs_ * vs_);
    ds.sec_tu.add(ts * us);
    ds.sec_vu.add(vs_ * us);
    ds.sec_uu.add(us * us);
    ds.sec_xy.add(section_aa_ * section_ua_);
    ds.sec_xx.add(section_aa_ * section_aa_);
    ds.sec_yy.add(section_ua_ * section_ua_);
    ++ds.sections;
    ++diag_.sections_complete[d];
  }

  /// Pending partial sums of direction d into the compensated totals.
  void fold(int d) {
    Pending& p = pending_[d];
    for (int j = 0; j < Bands; ++j) {
      if (p.time[j] == T(0) && p.dvel[j] == T(0)) continue;
      BandSums<T>& b = stats_.band[d][j];
      b.time_s.add(p.time[j]);
      b.speed.add(p.speed[j]);
      b.speed2.add(p.speed2[j]);
      b.force.add(p.force[j]);
      b.dvel.add(p.dvel[j]);
      p.time[j] = p.speed[j] = p.speed2[j] = p.force[j] = p.dvel[j] = T(0);
    }
    p.duration = T(0);
    fold_scalars();
    ++diag_.folds;
  }

  void fold_scalars() {
    stats_.noise_d2.add(noise_d2_);
    stats_.noise_count += noise_count_;
    stats_.total_interval_time.add(stats_interval_time_);
    stats_.interval_count += stats_interval_count_;
    noise_d2_ = stats_interval_time_ = T(0);
    noise_count_ = stats_interval_count_ = 0;
  }

  /// Keeps every plain partial sum shorter than max_fold_s.
  void fold_if_due() {
    for (int d = 0; d < 2; ++d) {
      if (pending_[d].duration < cfg_.max_fold_s) continue;
      if (section_open_ && section_dir_ == d) mark_split();
      fold(d);
    }
    if (stats_interval_time_ >= cfg_.max_fold_s) fold_scalars();  // e.g. a long rest
  }

  Config<T> cfg_{};
  Layout layout_{};
  Stats stats_{};
  Pending pending_[2] = {};
  Window window_{};
  PaperSection paper_{};
  Estimate<T> estimate_{};
  Diagnostics diag_{};
  const char* config_error_ = nullptr;
  bool initialized_ = false;
  // Previous accepted sample.
  bool has_prev_ = false;    ///< previous sample with a velocity
  bool has_x_prev_ = false;  ///< previous position known (from_position)
  bool rest_seen_ = false;   ///< axis below velocity_min since the last start
  T x_prev_ = T(0), v_prev_ = T(0), u_prev_ = T(0), u_prev2_ = T(0);
  int u_history_ = 0;
  T skipped_dt_ = T(0);  ///< time of rejected samples since the last good one (s)
  bool time_lost_ = false;  ///< a rejected sample had no usable dt
  // Section state.
  bool section_open_ = false, section_from_rest_ = false, split_counted_ = false;
  int section_dir_ = 0;
  uint16_t below_count_ = 0;
  T section_time_ = T(0), section_ua_ = T(0), section_aa_ = T(0);
  // Plain partial sums folded with the bands.
  T noise_d2_ = T(0), stats_interval_time_ = T(0);
  uint64_t noise_count_ = 0, stats_interval_count_ = 0;
};

}  // namespace feedid
