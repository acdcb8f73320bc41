// The streaming identifier of one axis: init(config), push(sample) at the
// servo rate, solve() when asked, then estimate(). Fixed memory (Bands and
// Candidates are compile-time), no heap, no exceptions, no globals: one
// instance per axis. docs/method.md derives what is accumulated and why.
#pragma once

#include "feedid/solve.hpp"
#include "feedid/statistics.hpp"
#include "feedid/types.hpp"
#include "feedid_port/math.hpp"

// The per-sample path is written as small functions; these keep it one
// straight function (no calls, no spills) and the rare work out of it.
#if defined(__GNUC__)
#define FEEDID_HOT_INLINE inline __attribute__((always_inline))
#define FEEDID_RARE __attribute__((noinline))
#else
#define FEEDID_HOT_INLINE inline
#define FEEDID_RARE
#endif

// The paper method (Method::paper) as a build option. Its statistics cost
// the servo path per sample (the section's mass-equation sums and its hard
// accelerations) and at every section end (Bands x Candidates exp and a
// fold of all bands in one push()). On by default (the host offers both
// methods); the firmware builds with -DFEEDID_PAPER_METHOD=0, where solve()
// offers the bands method only and no push() folds more than one band
// (docs/firmware.md).
#ifndef FEEDID_PAPER_METHOD
#define FEEDID_PAPER_METHOD 1
#endif

namespace feedid {

/// Whether Estimator keeps the paper method's statistics unless told (FEEDID_PAPER_METHOD).
constexpr bool paper_method_default = FEEDID_PAPER_METHOD != 0;

template <typename T, int Bands = 32, int Candidates = 16, bool PaperMethod = paper_method_default> class Estimator {
 public:
  /// Without the paper method the candidate bank and its per-section sums
  /// are never used: the statistics keep a bank of one (the smallest array
  /// C++ allows), 15 x 4 x 2 running sums less (960 B in float).
  static constexpr int kept_candidates = PaperMethod ? Candidates : 1;
  using Stats = Statistics<T, Bands, kept_candidates>;
  using Layout = BandLayout<T, Bands>;
  static constexpr int bands = Bands;
  static constexpr int candidates = Candidates;
  /// solve(Method::paper) is available (else it returns method_not_built).
  static constexpr bool paper_method = PaperMethod;

  /// Checks every field, then resets all state. On error the estimator stays
  /// unusable (push/solve return not_initialized) and config_error() names
  /// the field. Context: task.
  [[nodiscard]] Status init(const Config<T>& cfg) {
    reset();
    config_error_ = check(cfg);
    if (config_error_) return Status::invalid_config;
    cfg_ = cfg;
    if (!(cfg_.section_enter_m_s > T(0))) cfg_.section_enter_m_s = T(2) * cfg_.velocity_min_m_s;
    // A velocity step of a few quanta is noise, not acceleration: it never
    // makes a velocity jump, and (half of it) at low speed it must not decide
    // which intervals count as quasi-steady (that selection would correlate
    // with the noise and bias Fs).
    jump_noise_allowance_ = T(4) * cfg_.velocity_resolution_m_s;
    quasi_steady_floor_ = T(0.5) * jump_noise_allowance_;
    fold_at_s_ = cfg_.max_fold_s;
    (void)pairing_.init(cfg_.force_lag_samples);  // range checked by check()
    layout_.init(cfg_.velocity_min_m_s, cfg_.velocity_max_m_s);
    if constexpr (PaperMethod)
      for (int i = 0; i < Candidates; ++i) stats_.vs_candidate[i] = detail::stribeck_candidate(cfg_, i, Candidates);
    initialized_ = true;
    return Status::ok;
  }

  /// Takes one sample. A rejected sample changes nothing but the rejection
  /// counters: it never reaches a sum, and the next good sample bridges it.
  /// Cost: constant, a few dozen flops and one band lookup; no loop over
  /// past data. Context: servo task or ISR (see port/ for the ISR hand-off).
  /// Inlined into the caller's servo loop (one call site per axis), so that
  /// the sample stays in registers and the rare paths' saved registers are
  /// not saved per sample; the rest is push_general_path().
  [[nodiscard]] FEEDID_HOT_INLINE Status push(const Sample<T>& s) {
    const T dt = s.dt_s, v = s.velocity_m_s, u = s.force_N;
    // The usual case: measured velocity, continuing a chain, no sample
    // rejected since the last one (fast_gap_bits_ != 0), and a sample that passes
    // every test of vet(). Each comparison below is false for NaN, and the
    // limits are finite, so a sample passing them is finite too: its
    // dt + skipped_dt_ (= dt) is within max_gap_s, its dt > 0, speed and
    // force within their limits, the velocity step within the jump limit.
    // Any other sample takes the general path, which finds its status.
    // (The fast path is off until init() succeeded, and until the chain's
    // force history is full.) Accepted samples are counted as intervals
    // (diagnostics()). The first three tests are one integer comparison
    // (set_fast_path()).
    if (((port::detail::to_bits(dt) - 1u) < fast_gap_bits_) && port::abs(v) <= cfg_.max_speed_m_s &&
        port::abs(u) <= cfg_.max_force_N &&
        port::abs(v - v_prev_) <= cfg_.max_acceleration_m_s2 * dt + jump_noise_allowance_) {
      step<true>(dt, v, u);
      return Status::ok;
    }
    return push_general_path(dt, s.position_m, v, u);
  }

  /// Folds the open section and window (the section then no longer counts
  /// for the paper method) and computes the estimate. Bounded work: about
  /// 3 x 2 x (24 + max_vs_iterations) friction fits of Bands points.
  /// Method::paper on an estimator built without it: method_not_built, and
  /// nothing changes. Context: task, never the ISR.
  [[nodiscard]] Status solve(Method method = Method::bands) {
    if (!initialized_) return Status::not_initialized;
    if (method == Method::paper && !PaperMethod) return Status::method_not_built;
    close_window(v_prev_);
    if (section_open_) mark_split();
    fold(0);
    fold(1);
    fold_left_ = 0;  // every band is folded
    fold_at_s_ = cfg_.max_fold_s;
    if (!finite_statistics(stats_)) return Status::numerical_error;  // the last good estimate stays
    Estimate<T> e;
    e.method = method;
    Status st;
    if constexpr (PaperMethod) {
      st = method == Method::paper ? detail::solve_paper(stats_, cfg_, e) : detail::solve_bands(stats_, layout_, cfg_, e);
    } else {
      st = detail::solve_bands(stats_, layout_, cfg_, e);
    }
    // A non-finite number is never published: the last good estimate stays.
    if (!finite_estimate(e)) return Status::numerical_error;
    estimate_ = e;
    return st;
  }

  const Estimate<T>& estimate() const { return estimate_; }

  /// Every number solve() reports, finite (rare path: once per solve).
  static bool finite_estimate(const Estimate<T>& e) {
    bool ok = port::all_finite(e.mass_kg, e.mass_se_kg, T(0));
    const DirectionEstimate<T>* dirs[2] = {&e.pos, &e.neg};
    for (const DirectionEstimate<T>* d : dirs)
      ok = ok && port::all_finite(d->viscous_Ns_m, d->coulomb_N, d->breakaway_N) &&
           port::all_finite(d->stribeck_velocity_m_s, d->viscous_se, d->coulomb_se) &&
           port::all_finite(d->breakaway_se, d->stribeck_velocity_se, T(0));
    return ok;
  }
  /// The counters. samples_accepted is assembled here: the servo path
  /// counts each accepted sample once, as an interval or a chain's start.
  Diagnostics diagnostics() const {
    Diagnostics d = diag_;
    d.samples_accepted += stats_.interval_count + stats_interval_count_;
    return d;
  }
  /// The sufficient statistics (folded part); for host-side plots and checks.
  const Stats& statistics() const { return stats_; }
  const Layout& layout() const { return layout_; }
  const Config<T>& config() const { return cfg_; }
  /// Name of the offending field after init() returned invalid_config.
  const char* config_error() const { return config_error_; }

 private:
  // Partial sums of the current fold period of each direction, indexed
  // [direction][band]; plain sums of at most max_fold_s of samples (accurate
  // in float). A section of direction d starts a fold period of d, so while
  // it is open the sums of d hold exactly its quasi-steady intervals.
  // Without the paper method the fold period is max_fold_s of all
  // intervals (not one per section), and a fold runs one band per push().
  struct Pending {
    T time[2][Bands], speed[2][Bands], speed2[2][Bands], force[2][Bands], dvel[2][Bands];
  };
  // Paper method only: per direction, the quasi-steady time since its last
  // fold (max_fold_s bounds it), and the open section's moving intervals
  // that are not quasi-steady (hard accelerations): with the pending sums of
  // its direction they make the section's own integrals.
  struct PaperOn {
    struct {
      T duration;
      // Paper mass equation, sum u' dv' and sum dv'^2/dt over every moving
      // interval of this direction since a section of it last opened (not folded).
      T ua, aa;
    } dir[2];
    T time[Bands], speed[Bands], speed2[Bands];
    T force;
  };
  struct PaperOff {};
  // Mass window: the band moments of its intervals, projected on its
  // velocity change when it closes. With the paper method: time, speed and
  // speed2 of all its intervals (WindowPaper). Without it the window's band
  // sums are the only band sums a sample adds to (WindowLean): per band a
  // cell of its quasi-steady intervals (the five friction sums) and one of
  // the moments of the others; at the window's close the cells go to the
  // pending sums (5 sums per sample instead of 5 + 3). The paper method
  // needs the pending sums whole at a section end, which may fall inside a
  // window, so it keeps the two apart.
  struct WindowPaper {
    T time[Bands], speed[Bands], speed2[Bands];
  };
  struct Cell {
    T time, speed, speed2, force, dvel;
  };
  struct Moments {
    T time, speed, speed2;
  };
  struct WindowLean {
    Cell quasi[Bands];
    Moments other[Bands];
  };
  // Without the paper method a window's projections too are plain partial
  // sums, folded with the bands (a window's close then costs a few adds per
  // band, not nine compensated sums).
  struct ProjectionLean {
    T time[2][Bands], speed[2][Bands], speed2[2][Bands];
    T dv_force[2], dv2[2], tau_dv2[2];
  };
  struct ProjectionPaper {};
  template <bool On, typename = void> struct PaperPick {
    using type = PaperOff;
    using window = WindowLean;
    using projection = ProjectionLean;
  };
  template <typename D> struct PaperPick<true, D> {
    using type = PaperOn;
    using window = WindowPaper;
    using projection = ProjectionPaper;
  };
  using PaperExtra = typename PaperPick<PaperMethod>::type;
  using WindowBands = typename PaperPick<PaperMethod>::window;
  using PendingProjection = typename PaperPick<PaperMethod>::projection;
  struct Window {
    T force, tau, v_start;  ///< force: without the paper method, of the intervals not quasi-steady only
    int intervals;
    uint32_t touched[(Bands + 31) / 32];  ///< bit j: band j has time in the window
    int16_t dir;  ///< -1: no window open
  };
  // Without the paper method: the band, direction and window of the last
  // interval. An interval whose mean velocity is in [lo, hi) falls in the
  // same band of the same open window (a velocity of direction 1 is
  // negative, its band's bounds mirrored): one test instead of the rest
  // test, the direction and the band lookup. Empty (lo = hi = 0) when no
  // window is open.
  struct BandCache {
    T lo, hi, sign;
    int16_t band, dir;
  };

  /// Back to the state of a fresh object, in place: `*this = Estimator{}`
  /// would build a whole temporary (8 KB for float) on the caller's stack.
  /// All members are trivially copyable and zero bytes mean 0 / false.
  void reset() {
    zero(stats_);
    zero(pending_);
    zero(window_);
    window_.dir = -1;
    zero(paper_);
    zero(window_bands_);
    zero(pending_proj_);
    zero(cache_);
    zero(diag_);
    zero(layout_);
    estimate_ = Estimate<T>{};
    cfg_ = Config<T>{};
    config_error_ = nullptr;
    initialized_ = has_prev_ = has_x_prev_ = rest_seen_ = time_lost_ = false;
    fast_gap_bits_ = GapBits(0);
    x_prev_ = v_prev_ = skipped_dt_ = jump_noise_allowance_ = quasi_steady_floor_ = T(0);
    fold_left_ = 0;
    fold_at_s_ = T(0);
    zero(u_ring_);
    u_head_ = u_history_ = 0;
    pairing_ = ForcePairing<T>{};
    section_open_ = section_from_rest_ = split_counted_ = false;
    section_sign_ = T(1);
    below_count_ = 0;
    last_low_interval_ = 0;
    section_time_ = T(0);
    noise_d2_ = stats_interval_time_ = T(0);
    noise_skipped_ = stats_interval_count_ = 0;
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
    if (!ForcePairing<T>{}.init(c.force_lag_samples)) return "force_lag_samples must be in [-5, 0]";
    return nullptr;
  }

  /// push() of a sample off the usual path: not initialised, a chain's
  /// first samples, after a rejection, or one that vet() must judge. The
  /// sample's fields by value: the caller's sample then needs no place in
  /// memory on the usual path.
  FEEDID_RARE Status push_general_path(T dt_s, T position_m, T velocity_m_s, T force_N) {
    Sample<T> s;
    s.dt_s = dt_s;
    s.position_m = position_m;
    s.velocity_m_s = velocity_m_s;
    s.force_N = force_N;
    if (!initialized_) return Status::not_initialized;
    bool interval = false;
    T dt_general = T(0), v_general = T(0);
    const Status st = push_general(s, interval, dt_general, v_general);
    if (interval) {
      skipped_dt_ = T(0);
      step<false>(dt_general, v_general, s.force_N);
    }
    // Set on every acceptance (has_prev_ or the source may have changed);
    // cleared by every rejection (skipped_dt_ or time_lost_ may have).
    set_fast_path(st == Status::ok && has_prev_ && cfg_.velocity_source == VelocitySource::measured &&
                  u_history_ == ForcePairing<T>::history);
    return st;
  }

  /// The fast path on (`on`) and 0 < dt <= max_gap_s, for a dt of bits b, is
  /// b - 1 < fast_gap_bits_ in unsigned integers: the bits of a positive
  /// float order as its value; +0 wraps to the largest integer; negatives,
  /// infinity and NaN lie above any positive finite limit (max_gap_s > 0,
  /// check()); and 0 fails every dt.
  void set_fast_path(bool on) {
    fast_gap_bits_ = on ? port::detail::to_bits(cfg_.max_gap_s) : GapBits(0);
  }

  /// push() for every case (first samples, gaps, velocity from position) up
  /// to the interval: if the sample is accepted and continues the chain, sets
  /// `interval` and the interval's dt and the sample's velocity.
  FEEDID_RARE Status push_general(const Sample<T>& s, bool& interval, T& dt_out, T& v_out) {
    const Status verdict = vet(s);
    if (verdict != Status::ok) return reject(verdict, s);
    // Accepted. One that makes an interval is counted by that interval
    // (diagnostics()); the others (a chain's first samples) here.

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
        ++diag_.samples_accepted;
        return Status::ok;
      }
      start_from(s, from_position ? (s.position_m - x_prev_) / dt : s.velocity_m_s);
      ++diag_.samples_accepted;
      return Status::ok;
    }
    v_out = velocity_of(s);
    dt_out = dt;
    x_prev_ = s.position_m;  // read only with velocity from position
    interval = true;
    return Status::ok;
  }

  /// An accepted sample that continues the chain: the section state, then
  /// the interval from the previous sample.
  /// FullHistory: the chain's force history is known to be full (the fast path).
  template <bool FullHistory> FEEDID_HOT_INLINE void step(T dt, T v, T u) {
    section_state(dt, v);
    remember_force(u);
    T paired;
    if (FullHistory || u_history_ == ForcePairing<T>::history) {  // every tap and the noise difference at hand
      const T* const now = newest_force();  // now[-k]: k samples back, no index wrap
      paired = pairing_.interval_force_of(now);
      accumulate_noise(now);
    } else {
      paired = chain_start_force_and_noise();
    }
    accumulate_interval(dt, paired, T(0.5) * (v_prev_ + v), v - v_prev_, v);
    v_prev_ = v;
  }

  T velocity_of(const Sample<T>& s) const {
    if (cfg_.velocity_source == VelocitySource::measured) return s.velocity_m_s;
    return has_x_prev_ ? (s.position_m - x_prev_) / (s.dt_s + skipped_dt_) : T(0);
  }

  Status vet(const Sample<T>& s) const {
    const bool need_x = cfg_.velocity_source == VelocitySource::from_position;
    if (!port::all_finite(s.dt_s, s.force_N, need_x ? s.position_m : s.velocity_m_s))
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
      const T allowed = cfg_.max_acceleration_m_s2 * dt + jump_noise_allowance_;
      if (port::abs(v - v_prev_) > allowed) return Status::rejected_velocity_jump;
    }
    return Status::ok;
  }

  FEEDID_RARE Status reject(Status why, const Sample<T>& s) {
    set_fast_path(false);
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
    u_history_ = 1;
    remember_force(s.force_N);
    section_open_ = false;
    below_count_ = 0;
    // A section opened before the axis was seen at rest did not start at rest.
    rest_seen_ = port::abs(v) < cfg_.velocity_min_m_s;
  }

  void break_continuity() {
    close_window(v_prev_);
    if (section_open_) { mark_split(); section_open_ = false; }
    if constexpr (PaperMethod) {
      fold(0);
      fold(1);
    } else {
      start_fold();  // a gap, e.g. after rejected samples, must not cost a whole fold in one push()
    }
  }

  // --- sections: hysteresis on velocity ---------------------------------
  // Open when |v| >= section_enter (2*velocity_min by default) from rest;
  // close after rest_samples consecutive samples below velocity_min, or at a
  // reversal beyond section_enter. Jitter of a few quanta around zero never
  // reaches section_enter, so it opens no sections.
  // A reversal passes through zero velocity, so it ends one section and
  // starts the next as rest does (the end points' inertia term is ~0).
  // Decided before the interval to v is accumulated: a section that closes
  // at v ends with an interval below velocity_min in its direction, which
  // adds nothing to its sums, so the order changes no section's integrals,
  // and the moving case costs one comparison.
  FEEDID_HOT_INLINE void section_state(T dt, T v) {
    if (section_open_) {
      if (section_sign_ * v < cfg_.velocity_min_m_s) {
        section_low(dt, v);  // reversal or rest: rare
      } else {
        section_time_ += dt;  // (below_count_ counts consecutive low samples: see section_low)
      }
      return;
    }
    const T speed = port::abs(v);
    if (speed < cfg_.velocity_min_m_s) rest_seen_ = true;
    if (speed >= cfg_.section_enter_m_s) {
      open_section(v > T(0) ? 0 : 1, rest_seen_);
      section_time_ = dt;  // the opening interval is the section's
    }
  }

  /// The open section's velocity fell below velocity_min in its direction:
  /// a reversal beyond section_enter ends it and opens the next; otherwise
  /// it ends after rest_samples such samples in a row.
  FEEDID_RARE void section_low(T dt, T v) {
    if (section_sign_ * v <= -cfg_.section_enter_m_s) {
      close_section();
      open_section(v > T(0) ? 0 : 1, true);
      section_time_ = dt;  // the interval belongs to the section just opened
      return;
    }
    section_time_ += dt;  // a section that rests ends with this interval
    // Consecutive low samples: a sample in between that was not low (the
    // moving case, which does not touch the count) restarts it.
    const uint64_t k = stats_.interval_count + stats_interval_count_;  // intervals before this one
    if (k != last_low_interval_ + 1) below_count_ = 0;
    last_low_interval_ = k;
    if (++below_count_ >= cfg_.rest_samples) { close_section(); rest_seen_ = true; }
  }

  FEEDID_RARE void open_section(int dir, bool from_rest) {
    section_open_ = true;
    section_sign_ = direction_sign[dir];
    section_from_rest_ = from_rest;
    section_time_ = T(0);
    below_count_ = 0;
    split_counted_ = false;
    if constexpr (PaperMethod) {
      // A new fold period of this direction: from here on the pending sums of
      // dir hold only this section's quasi-steady intervals.
      fold(dir);
      paper_.dir[dir].ua = T(0);
      paper_.dir[dir].aa = T(0);
      zero(paper_.time);
      zero(paper_.speed);
      zero(paper_.speed2);
      paper_.force = T(0);
    }
  }

  /// The open section will not count for the paper method; counted once.
  void mark_split() {
    section_from_rest_ = false;
    if (!split_counted_) { ++diag_.sections_split; split_counted_ = true; }
  }

  int section_dir() const { return section_sign_ < T(0) ? 1 : 0; }

  FEEDID_RARE void close_section() {
    section_open_ = false;
    const int d = section_dir();
    if (section_time_ < cfg_.min_section_s) {
      ++diag_.sections_short;
    } else if (section_from_rest_) {
      if constexpr (PaperMethod) {
        add_paper_point(d);
      } else {  // counted as the paper method counts its points
        ++stats_.dir[d].sections;
        ++diag_.sections_complete[d];
      }
    }
    if constexpr (PaperMethod) fold(d);
  }

  // --- per interval -------------------------------------------------------
  // Interval [t_{k-1}, t_k] by the trapezoid rule: mean force u, mean
  // velocity v, velocity change dv. Mirrored for the negative direction.
  FEEDID_HOT_INLINE void accumulate_interval(T dt, T u, T v, T dv, T v_now) {
    stats_interval_time_ += dt;
    ++stats_interval_count_;
    if (stats_interval_time_ >= fold_at_s_) fold_period_end();  // e.g. a long rest
    if constexpr (PaperMethod) accumulate_paper(dt, u, v, dv, v_now);
    else accumulate_lean(dt, u, v, dv, v_now);
  }

  /// Friction bands take quasi-steady intervals only: one that sweeps a
  /// large part of its speed in a single step carries a large inertia
  /// force, and any force/velocity timing error of the log leaks from it
  /// into the narrow low-speed bands.
  /// (A step of two velocity quanta, half the jump allowance, is always quasi-steady.)
  FEEDID_HOT_INLINE bool quasi_steady(T dv, T speed) const {
    return port::abs(dv) <= port::max(cfg_.max_step_speed_ratio * speed, quasi_steady_floor_);
  }

  FEEDID_HOT_INLINE void accumulate_paper(T dt, T u, T v, T dv, T v_now) {
    const T speed = port::abs(v);
    if (speed < cfg_.velocity_min_m_s) { close_window(v_prev_); return; }  // at rest: not the model
    const int d = v > T(0) ? 0 : 1;
    const T sign = direction_sign[d];
    const T um = sign * u, dvm = sign * dv;
    const int j = layout_.index(speed);
    const T sdt = speed * dt, s2dt = speed * sdt, udt = um * dt;
    Pending& p = pending_;
    auto& ps = paper_.dir[d];
    // Paper mass equation: valid for the open section if d is its direction.
    ps.ua += um * dvm;
    ps.aa += dvm * dvm / dt;
    if (quasi_steady(dv, speed)) {
      p.time[d][j] += dt;
      p.speed[d][j] += sdt;
      p.speed2[d][j] += s2dt;
      p.force[d][j] += udt;
      p.dvel[d][j] += dvm;
      ps.duration += dt;
      if (ps.duration >= cfg_.max_fold_s) fold_due(d);
    } else if (section_open_ && section_sign_ == sign) {
      // The paper method takes all of the section's moving intervals.
      paper_.time[j] += dt;
      paper_.speed[j] += sdt;
      paper_.speed2[j] += s2dt;
      paper_.force += udt;
    }
    // Mass window: consecutive intervals of one direction.
    Window& w = window_;
    if (w.dir != d) {
      close_window(v_prev_);
      w.dir = static_cast<int16_t>(d);
      w.v_start = sign * v_prev_;
    }
    WindowBands& wb = window_bands_;
    wb.time[j] += dt;
    wb.speed[j] += sdt;
    wb.speed2[j] += s2dt;
    w.force += udt;
    w.tau += dt;
    ++w.intervals;
    mark_band(j);
    if (w.tau >= cfg_.mass_window_s) close_active_window(v_now);
  }

  /// The same sums without the paper method: into the window's cells (the
  /// pending sums receive them when it closes).
  FEEDID_HOT_INLINE void accumulate_lean(T dt, T u, T v, T dv, T v_now) {
    // Band, direction and open window as the last interval's, or found anew.
    if (!(v >= cache_.lo && v < cache_.hi) && !enter_band(v)) return;  // at rest: not the model
    const int j = cache_.band;
    const T sign = cache_.sign;
    const T speed = sign * v;  // = |v|
    const T um = sign * u;
    const T sdt = speed * dt, s2dt = speed * sdt, udt = um * dt;
    Window& w = window_;
    if (quasi_steady(dv, speed)) {
      Cell& c = window_bands_.quasi[j];
      c.time += dt;
      c.speed += sdt;
      c.speed2 += s2dt;
      c.force += udt;
      c.dvel += sign * dv;
    } else {
      Moments& o = window_bands_.other[j];
      o.time += dt;
      o.speed += sdt;
      o.speed2 += s2dt;
      w.force += udt;
    }
    w.tau += dt;
    ++w.intervals;
    if (w.tau >= cfg_.mass_window_s) window_full(v_now);
  }

  /// The window reached mass_window_s: it closes, and the next one opens at
  /// once in the same direction and band (as the next interval of that
  /// direction would open it, from this velocity), so that interval needs
  /// no lookup. One of another direction or at rest closes it empty.
  FEEDID_RARE void window_full(T v_now) {
    const BandCache keep = cache_;
    close_active_window(v_now);
    Window& w = window_;
    w.dir = keep.dir;
    w.v_start = keep.sign * v_now;
    mark_band(keep.band);
    cache_ = keep;
  }

  /// An interval outside the cached band (not per sample): at rest it closes
  /// the window and returns false; else it finds its band, opens a window
  /// if its direction has none, and caches the band's velocity range.
  FEEDID_RARE bool enter_band(T v) {
    const T speed = port::abs(v);
    if (speed < cfg_.velocity_min_m_s) { close_window(v_prev_); return false; }
    const int d = v > T(0) ? 0 : 1;
    const T sign = direction_sign[d];
    const int j = layout_.index(speed);
    Window& w = window_;
    if (w.dir != d) {
      close_window(v_prev_);
      w.dir = static_cast<int16_t>(d);
      w.v_start = sign * v_prev_;
    }
    mark_band(j);
    // Band j holds edge[j] <= |v| < edge[j+1], the top band every |v| above
    // its lower edge. Direction 1: -edge[j+1] < v <= -edge[j], i.e.
    // next_up(-edge[j+1]) <= v < next_up(-edge[j]).
    using Bits = port::detail::FloatBits<T>;
    const T inf = port::detail::from_bits<T>(typename Bits::UInt(Bits::exponent_mask) << Bits::mantissa_bits);
    const T lo = layout_.edge[j], hi = j + 1 < Bands ? layout_.edge[j + 1] : inf;
    cache_.lo = d == 0 ? lo : next_up_negative(-hi);
    cache_.hi = d == 0 ? hi : next_up_negative(-lo);
    cache_.sign = sign;
    cache_.band = static_cast<int16_t>(j);
    cache_.dir = static_cast<int16_t>(d);
    return true;
  }
  /// The next float above x < 0 (-infinity: the lowest finite).
  static T next_up_negative(T x) { return port::detail::from_bits<T>(port::detail::to_bits(x) - 1); }

  FEEDID_HOT_INLINE void mark_band(int j) {
    if constexpr (Bands <= 32) window_.touched[0] |= uint32_t(1) << j;
    else window_.touched[j >> 5] |= uint32_t(1) << (j & 31);
  }

  // --- force history: the pairing rule (force_pairing.hpp) ------------------
  // Each force is stored twice, at u_head_ and u_head_ + history, so that
  // the taps behind the newest are read without wrapping the index.
  FEEDID_HOT_INLINE void remember_force(T u) {
    u_head_ = static_cast<uint8_t>((u_head_ + 1) & (ForcePairing<T>::history - 1));
    u_ring_[u_head_] = u;
    u_ring_[u_head_ + ForcePairing<T>::history] = u;
  }
  /// The newest logged force; p[-age] is the one `age` samples back (age < history).
  FEEDID_HOT_INLINE const T* newest_force() const { return &u_ring_[u_head_ + ForcePairing<T>::history]; }
  FEEDID_HOT_INLINE T force_at(int age) const { return newest_force()[-age]; }
  /// The first samples of a chain (until the history is full): taps older
  /// than its start take its first force; the noise needs three forces.
  FEEDID_RARE T chain_start_force_and_noise() {
    ++u_history_;
    if (u_history_ >= 3) accumulate_noise(newest_force());
    else ++noise_skipped_;
    return pairing_.interval_force_in_chain([this](int age) { return force_at(age); }, u_history_ - 1);
  }

  /// One term per interval (counted as stats_interval_count_ less
  /// noise_skipped_: the first interval of a chain has too few forces).
  FEEDID_HOT_INLINE void accumulate_noise(const T* now) {
    // Second difference of the force: a smooth force cancels, white noise of
    // variance s^2 leaves 6 s^2. Gives the noise floor without a model.
    const T d2 = now[0] - T(2) * now[-1] + now[-2];
    noise_d2_ += d2 * d2;
  }

  /// Ends the mass window, if one is open; v_last is the velocity at its end
  /// (that of the last sample it took).
  FEEDID_HOT_INLINE void close_window(T v_last) {
    if (window_.dir >= 0) close_active_window(v_last);
  }

  /// Band j of the closing window: without the paper method its
  /// quasi-steady cell goes to the pending sums of direction d; then cleared.
  void retire_band(int d, int j) {
    WindowBands& wb = window_bands_;
    if constexpr (PaperMethod) {
      wb.time[j] = wb.speed[j] = wb.speed2[j] = T(0);
    } else {
      Pending& p = pending_;
      Cell& c = wb.quasi[j];
      p.time[d][j] += c.time;
      p.speed[d][j] += c.speed;
      p.speed2[d][j] += c.speed2;
      p.force[d][j] += c.force;
      p.dvel[d][j] += c.dvel;
      c = Cell{};
      wb.other[j] = Moments{};
    }
  }
  /// The window's moments of band j over all its intervals.
  Moments window_moments(int j) const {
    const WindowBands& wb = window_bands_;
    if constexpr (PaperMethod) {
      return Moments{wb.time[j], wb.speed[j], wb.speed2[j]};
    } else {
      const Cell& c = wb.quasi[j];
      const Moments& o = wb.other[j];
      return Moments{c.time + o.time, c.speed + o.speed, c.speed2 + o.speed2};
    }
  }

  /// f(j) for each band j the window touched, in increasing order; clears the marks.
  template <typename F> void for_touched(F&& f) {
    for_each_touched(window_, f);
    zero(window_.touched);
  }

  FEEDID_RARE void close_active_window(T v_last) {
    Window& w = window_;
    const int d = w.dir;
    T force = w.force;
    if constexpr (!PaperMethod) {  // the quasi-steady intervals' force is in the cells
      for_each_touched(w, [&](int j) { force += window_bands_.quasi[j].force; });
      cache_ = BandCache{};  // no window: the next interval finds its band anew
    }
    if (w.intervals >= 2) {
      const T dvw = direction_sign[d] * v_last - w.v_start;
      if constexpr (PaperMethod) {
        for_touched([&](int j) {
          BandSums<T>& b = stats_.band[d][j];
          const Moments m = window_moments(j);
          b.proj_time.add(dvw * m.time);
          b.proj_speed.add(dvw * m.speed);
          b.proj_speed2.add(dvw * m.speed2);
          retire_band(d, j);
        });
        DirectionSums<T, kept_candidates>& ds = stats_.dir[d];
        ds.win_dv_force.add(dvw * force);
        ds.win_dv2.add(dvw * dvw);
        ds.win_tau_dv2.add(w.tau * dvw * dvw);
      } else {
        PendingProjection& pp = pending_proj_;
        for_touched([&](int j) {
          const Moments m = window_moments(j);
          pp.time[d][j] += dvw * m.time;
          pp.speed[d][j] += dvw * m.speed;
          pp.speed2[d][j] += dvw * m.speed2;
          retire_band(d, j);
        });
        pp.dv_force[d] += dvw * force;
        pp.dv2[d] += dvw * dvw;
        pp.tau_dv2[d] += w.tau * dvw * dvw;
      }
      ++diag_.mass_windows;
    } else {
      for_touched([&](int j) { retire_band(d, j); });
    }
    w.force = w.tau = T(0);
    w.intervals = 0;
    w.dir = -1;
  }
  template <typename F> static void for_each_touched(const Window& w, F&& f) {
    for (int k = 0; k < (Bands + 31) / 32; ++k)
      for (uint32_t m = w.touched[k]; m != 0; m &= m - 1) f(32 * k + __builtin_ctz(m));
  }

  /// Section end (not per sample): the section's point for the paper method
  /// (integral u dt = Fc T + sigma V + Fs E over the section), with
  /// integral exp(-(v/vs_i)^2) dt for each candidate vs_i from the section's
  /// band moments: Bands x Candidates exponentials. Paper mass equation:
  /// integral u a dt = sum u dv; integral a^2 dt = sum dv^2/dt.
  FEEDID_RARE void add_paper_point(int d) {
    // The section's integrals: its quasi-steady intervals (the pending sums
    // of d, whose fold period it opened) plus the others, added in place
    // (the extras are not needed after this).
    const Pending& p = pending_;
    PaperExtra& x = paper_;
    T* const time = x.time;
    T* const speed = x.speed;
    T* const speed2 = x.speed2;
    T ts = T(0), vs_ = T(0), us = x.force;
    for (int j = 0; j < Bands; ++j) {
      time[j] += p.time[d][j];
      speed[j] += p.speed[d][j];
      speed2[j] += p.speed2[d][j];
      ts += time[j];
      vs_ += speed[j];
      us += p.force[d][j];
      // From here on speed[] and speed2[] hold the band's squared mean speed
      // and variance: exp_integral_moments() split so that its divisions
      // are done once per band, not per band and candidate.
      if (time[j] > T(0)) {
        const T mean = speed[j] / time[j];
        speed[j] = mean * mean;
        speed2[j] = port::max(T(0), speed2[j] / time[j] - mean * mean);
      }
    }
    if (!(ts > T(0))) return;
    DirectionSums<T, Candidates>& ds = stats_.dir[d];
    for (int i = 0; i < Candidates; ++i) {
      const T inv_vs2 = T(1) / (stats_.vs_candidate[i] * stats_.vs_candidate[i]);
      T e = T(0);
      for (int j = 0; j < Bands; ++j)
        if (time[j] > T(0)) e += exp_integral_mean_var(time[j], speed[j], speed2[j], inv_vs2);
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
    const T ua = x.dir[d].ua, aa = x.dir[d].aa;
    ds.sec_xy.add(aa * ua);
    ds.sec_xx.add(aa * aa);
    ds.sec_yy.add(ua * ua);
    ++ds.sections;
    ++diag_.sections_complete[d];
  }

  /// Pending partial sums of direction d into the compensated totals.
  void fold(int d) {
    for (int j = 0; j < Bands; ++j) {
      // An empty band adds nothing (with the paper method, whose folds come
      // at every section, skip it; without it its projections may not be empty).
      if (PaperMethod && pending_.time[d][j] == T(0) && pending_.dvel[d][j] == T(0)) continue;
      fold_band(d, j);
    }
    if constexpr (PaperMethod) paper_.dir[d].duration = T(0);
    fold_scalars();
    ++diag_.folds;
  }

  /// Pending sums of band j of direction d into the totals.
  FEEDID_HOT_INLINE void fold_band(int d, int j) {
    Pending& p = pending_;
    BandSums<T>& b = stats_.band[d][j];
    b.time_s.add(p.time[d][j]);
    b.speed.add(p.speed[d][j]);
    b.speed2.add(p.speed2[d][j]);
    b.force.add(p.force[d][j]);
    b.dvel.add(p.dvel[d][j]);
    p.time[d][j] = p.speed[d][j] = p.speed2[d][j] = p.force[d][j] = p.dvel[d][j] = T(0);
    if constexpr (!PaperMethod) {
      PendingProjection& pp = pending_proj_;
      b.proj_time.add(pp.time[d][j]);
      b.proj_speed.add(pp.speed[d][j]);
      b.proj_speed2.add(pp.speed2[d][j]);
      pp.time[d][j] = pp.speed[d][j] = pp.speed2[d][j] = T(0);
    }
  }

  // Without the paper method a fold is spread over the next 2 x Bands
  // push() calls, one band each (about 100 instructions), so that no
  // push() folds all bands. The pending sums keep taking samples meanwhile:
  // each plain sum spans at most max_fold_s and 2 x Bands samples.
  FEEDID_RARE void fold_period_end() {
    if constexpr (PaperMethod) {
      fold_scalars();
    } else {
      if (stats_interval_time_ >= cfg_.max_fold_s) start_fold();
      if (fold_left_ != 0) fold_step();
    }
  }
  void start_fold() {
    fold_scalars();
    if (fold_left_ == 0) fold_left_ = static_cast<uint16_t>(2 * Bands);
    fold_at_s_ = T(-1);
  }
  void fold_step() {
    const int slot = --fold_left_;
    fold_band(slot >= Bands ? 1 : 0, slot % Bands);
    if (fold_left_ == 0) {
      ++diag_.folds;
      fold_at_s_ = cfg_.max_fold_s;
    }
  }

  FEEDID_RARE void fold_scalars() {
    stats_.noise_d2.add(noise_d2_);
    // (The pending counts are 32-bit: a fold period is far shorter than 2^32 samples.)
    stats_.noise_count += stats_interval_count_ - noise_skipped_;
    stats_.total_interval_time.add(stats_interval_time_);
    stats_.interval_count += stats_interval_count_;
    noise_d2_ = stats_interval_time_ = T(0);
    noise_skipped_ = stats_interval_count_ = 0;
    if constexpr (!PaperMethod) {
      PendingProjection& pp = pending_proj_;
      for (int d = 0; d < 2; ++d) {
        DirectionSums<T, kept_candidates>& ds = stats_.dir[d];
        ds.win_dv_force.add(pp.dv_force[d]);
        ds.win_dv2.add(pp.dv2[d]);
        ds.win_tau_dv2.add(pp.tau_dv2[d]);
        pp.dv_force[d] = pp.dv2[d] = pp.tau_dv2[d] = T(0);
      }
    }
  }

  /// Keeps every plain partial sum shorter than max_fold_s: direction d's
  /// pending sums reached it (the open section, if of that direction, is
  /// split and no longer counts for the paper method).
  FEEDID_RARE void fold_due(int d) {
    if (section_open_ && section_dir() == d) mark_split();
    fold(d);
  }

  static constexpr T direction_sign[2] = {T(1), T(-1)};  ///< mirror factor of direction 0 / 1

  // Members in the order the servo path reads them: those of every
  // sample first, within reach of an immediate offset (Thumb-2: 1 KB for a
  // float load), the large arrays after.
  Config<T> cfg_{};
  // Previous accepted sample.
  T x_prev_ = T(0), v_prev_ = T(0);
  T u_ring_[2 * ForcePairing<T>::history] = {};  ///< logged forces of this chain, newest at u_head_ and u_head_ + history (N)
  ForcePairing<T> pairing_{};
  T skipped_dt_ = T(0);  ///< time of rejected samples since the last good one (s)
  T jump_noise_allowance_ = T(0);    ///< 4 x velocity_resolution: part of the velocity-jump limit (m/s)
  T quasi_steady_floor_ = T(0);      ///< half of it: a velocity step always quasi-steady (m/s)
  // Section state.
  T section_sign_ = T(1);  ///< +1 / -1: the open section's direction is 0 / 1
  T section_time_ = T(0);
  // Plain partial sums folded with the bands.
  T noise_d2_ = T(0), stats_interval_time_ = T(0);
  uint32_t noise_skipped_ = 0, stats_interval_count_ = 0;
  /// stats_interval_time_ at which fold_period_end() runs (s): max_fold_s,
  /// or -1 while a spread fold runs, so that one test serves both.
  T fold_at_s_ = T(0);
  BandCache cache_{};
  Window window_{};
  uint64_t last_low_interval_ = 0;  ///< interval index of the last low sample of an open section (section_low)
  uint16_t below_count_ = 0;
  uint8_t u_head_ = 0;
  uint8_t u_history_ = 0;  ///< forces of this chain in u_ring_, up to its size
  uint16_t fold_left_ = 0;  ///< band slots of the running spread fold still to fold (no paper method)
  bool initialized_ = false;
  bool has_prev_ = false;    ///< previous sample with a velocity
  bool has_x_prev_ = false;  ///< previous position known (from_position)
  bool rest_seen_ = false;   ///< axis below velocity_min since the last start
  bool time_lost_ = false;   ///< a rejected sample had no usable dt
  /// max_gap_s's bits while push() may skip vet() (has_prev_, velocity
  /// measured, skipped_dt_ == 0, !time_lost_, the force history full), else 0.
  using GapBits = typename port::detail::FloatBits<T>::UInt;
  GapBits fast_gap_bits_ = 0;
  bool section_open_ = false, section_from_rest_ = false, split_counted_ = false;
  WindowBands window_bands_{};
  Pending pending_{};
  PendingProjection pending_proj_{};
  PaperExtra paper_{};
  Layout layout_{};
  Stats stats_{};
  Estimate<T> estimate_{};
  Diagnostics diag_{};
  const char* config_error_ = nullptr;
};

}  // namespace feedid

#undef FEEDID_HOT_INLINE
#undef FEEDID_RARE
