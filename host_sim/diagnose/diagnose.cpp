#include "diagnose.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <complex>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <future>
#include <thread>
#include <tuple>
#include <utility>

#include "diagnose_blocks.hpp"
#include "diagnose_catalogue.hpp"
#include "diagnose_fit.hpp"
#include "phasor.hpp"
#include "identify/gravity.hpp"
#include "io/beside.hpp"

namespace feedid::host {
namespace {

using diag::ColumnBank;
using diag::EffectModel;
using diag::LinearFit;
using diag::log_grid;
using diag::Mat;
using diag::Observation;
using diag::Observations;
using diag::Vec;

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string fmt(double v, const std::string& unit) {
  std::ostringstream o;
  o.precision(3);
  o << v << " " << unit;
  return o.str();
}

// ---------------------------------------------------------------------------
// 1. Split: timing, folds, and the core's base model on the identification folds.
// ---------------------------------------------------------------------------

/// Signals with the force lag taken only as far as logging conventions
/// explain it: a delay beyond them is an effect (docs/diagnosis.md, "Timing").
Signals aligned_signals(const Trace& trace, const DiagnoseOptions& opt, DiagnoseResult& out) {
  IdentifyOptions timing = opt.identify;
  timing.lag_within_conventions = true;
  timing.check_stated_lag = false;  // identify's warning; the diagnosis does not print it
  // Residuals are read sample by sample, where a smoothed velocity's
  // rounding at starts and reversals puts friction of the wrong sign: on
  // the derivative of position the blind benchmark named 91 % right
  // instead of 97 %, with 2 false alarms in 40 instead of none.
  timing.velocity_source = VelocitySource::column;
  // A position logged faster than it was updated (a status frame every
  // 20 ms in a 5 ms loop) has backward differences that are mostly the
  // holds' sawtooth: its velocity noise put the lowest band of a SysId log
  // at 25 rad/s, and nothing could be identified.
  timing.spread_held_values = true;
  Signals sig = prepare_signals(trace, timing);
  // Without a position column x is the integrated velocity (prepare_signals):
  // the position and reversal candidates see relative positions, not zeros.
  out.position_origin = sig.position_origin;
  out.force_lag_s = sig.force_lag_s;
  out.lag_beyond_conventions_s = sig.lag_beyond_conventions / sig.sample_rate_hz;
  return sig;
}

bool identify_base(const Trace& trace, const Signals& sig, const diag::Folds& folds, const DiagnoseOptions& opt,
                   DiagnoseResult& out) {
  // The identification folds of the signals aligned_signals prepared: their
  // conventions and velocity as they are, not conditioned again (issue 29).
  std::vector<char> identification(sig.t.size());
  for (std::size_t k = 0; k < sig.t.size(); ++k) identification[k] = !diag::Folds::heldout(folds.of(sig.t[k]));
  IdentifyOptions idopt = opt.identify;
  // The base fit below refits the friction terms, vs on the core's grid;
  // a Stribeck law dropped by identify's model selection (vs = 0) left it
  // nothing to refit, and two effects of 66 went `unexplained`.
  idopt.select_friction_model = false;
  // Without a position column x is integrated: no arm's angle to place a gravity term at.
  if (!trace.has_position && idopt.gravity == GravityTerm::automatic) idopt.gravity = GravityTerm::none;
  if (!trace.has_position && idopt.gravity == GravityTerm::angle) {
    out.error = trace.source + ": " + kGravityAngleNeedsPosition;
    return false;
  }
  if (opt.model && !(out.error = opt.model->load.refusal(trace.source, trace.has_position)).empty()) return false;
  // Beside a given model this fit sets only the velocity range and the
  // signals' conventions: its standard errors (two more passes) are never
  // read or shown.
  if (opt.model) idopt.honest_standard_errors = false;
  out.base = identify_prepared(select_samples(sig, identification), idopt, trace.source + " (identification folds)");
  out.base.force_outliers = out.force_outliers;  // bridged on the whole trace, before the split
  if (!out.base.error.empty()) out.error = out.base.error;
  return out.error.empty();
}

// ---------------------------------------------------------------------------
// 2. Base fit: the core's model terms as columns, vs per direction on the
//    core's grid.
// ---------------------------------------------------------------------------

/// Bank columns of the base model: m, Fc+, Fc-, sigma+, sigma- (negative-
/// direction columns carry the model's signs so coefficients are
/// magnitudes) and, per direction with a Stribeck dip, exp(-(v/vs)^2) and
/// its vs-derivative for each vs of the core's grid.
struct BaseColumns {
  std::vector<int> fixed;
  std::vector<double> vs_grid;
  bool stribeck[2] = {false, false};
  std::vector<std::array<int, 2>> grid[2];
  /// Pooled runs after the first that moves in a direction: their own
  /// Coulomb and viscous level in it (add_run_levels), from that run's.
  struct RunLevel {
    std::size_t run = 0;
    std::size_t reference = 0;  ///< the first run identified in this direction, whose level the base's is
    int direction = 0;  ///< 0 positive, 1 negative
    bool viscous = false;
    int col = 0;
  };
  std::vector<RunLevel> run_levels;
};

/// The base model at a vs per direction, plus named effects' columns.
struct Model {
  struct Term {
    std::size_t effect = 0;  ///< catalogue index
    double p = 0.0;          ///< its nonlinear parameter
    int size = 1;            ///< its family size (EffectModel::sizes)
    std::vector<int> cols;
  };
  int g[2] = {0, 0};
  std::vector<Term> terms;
  LinearFit fit;
  Vec residual;
};

std::vector<int> model_columns(const BaseColumns& b, const Model& m) {
  std::vector<int> c = b.fixed;
  for (int d = 0; d < 2; ++d)
    if (b.stribeck[d]) {
      const auto& pair = b.grid[d][static_cast<std::size_t>(m.g[d])];
      c.insert(c.end(), pair.begin(), pair.end());
    }
  for (const auto& l : b.run_levels) c.push_back(l.col);
  for (const auto& t : m.terms) c.insert(c.end(), t.cols.begin(), t.cols.end());
  return c;
}

/// Each run level's fitted change (parallel to b.run_levels).
std::vector<double> run_level_changes(const BaseColumns& b, const Model& m) {
  const std::vector<int> cols = model_columns(b, m);
  std::vector<double> out;
  for (const auto& l : b.run_levels)
    out.push_back(m.fit.theta(static_cast<Eigen::Index>(std::find(cols.begin(), cols.end(), l.col) - cols.begin())));
  return out;
}

/// Every column a fit with vs free may use.
std::vector<int> all_columns(const BaseColumns& b, const Model& m) {
  std::vector<int> c = b.fixed;
  for (int d = 0; d < 2; ++d)
    for (const auto& pair : b.grid[d]) c.insert(c.end(), pair.begin(), pair.end());
  for (const auto& l : b.run_levels) c.push_back(l.col);
  for (const auto& t : m.terms) c.insert(c.end(), t.cols.begin(), t.cols.end());
  return c;
}

/// A direction whose friction law the run does not settle: friction falls
/// across every speed logged (flagged so, or a viscous slope that came out
/// negative). What the base then misses, a change of friction with speed
/// or time draws. Any non-physical magnitude is not enough: a strong
/// quadratic damping left a slightly negative Coulomb force, and the
/// damping was then not named (a blind pair case).
bool friction_unsettled(const feedid::DirectionEstimate<double>& d) {
  return d.friction_identified() &&
         ((d.flags & feedid::flag_friction_still_falling) != 0 ||
          ((d.flags & feedid::flag_not_physical) != 0 && d.viscous_Ns_m < 0.0));
}

BaseColumns add_base_columns(const Observations& obs, ColumnBank& bank, const IdentifyResult& base) {
  const Signals& s = obs.signals();
  BaseColumns b;
  b.fixed.push_back(bank.add(obs.sample_column([&](std::size_t j) { return (s.v[j + 1] - s.v[j]) / obs.interval_dt(j); })));
  b.fixed.push_back(bank.add(obs.sample_column([&](std::size_t j) { return obs.interval_v(j) > 0 ? 1.0 : 0.0; })));
  b.fixed.push_back(bank.add(obs.sample_column([&](std::size_t j) { return obs.interval_v(j) < 0 ? -1.0 : 0.0; })));
  b.fixed.push_back(bank.add(obs.sample_column([&](std::size_t j) { return std::max(obs.interval_v(j), 0.0); })));
  b.fixed.push_back(bank.add(obs.sample_column([&](std::size_t j) { return std::min(obs.interval_v(j), 0.0); })));
  const auto& est = base.estimate;
  // Wherever the core identified a direction's dip, or its friction law is
  // unsettled (a dip wider than the run's speeds, which it could not
  // place): least squares sets Fs near 0 if there is none. Without it the
  // dip's fall was left to the effects: on 8 s of a ladder whose speeds
  // rise with time, a thermal drift of +2700 N s/m.
  const auto dip = [](const feedid::DirectionEstimate<double>& d) {
    return d.friction_identified() && (d.breakaway_N > 0 || friction_unsettled(d));
  };
  b.stribeck[0] = dip(est.pos);
  b.stribeck[1] = dip(est.neg);
  b.vs_grid = log_grid(feedid::analysis::stribeck_lo(base.config), feedid::analysis::stribeck_hi(base.config),
                       feedid::thresholds::kStribeckGridPoints);
  const auto n = static_cast<int>(b.vs_grid.size());
  for (int d = 0; d < 2; ++d) {
    if (!b.stribeck[d]) continue;
    const double dir = d == 0 ? 1.0 : -1.0;
    // E and dE for every vs in one pass; exp(-50) is taken as 0.
    const Mat c = obs.sample_columns(2 * n, [&](std::size_t j, double* out) {
      const double v = obs.interval_v(j);
      const bool on = dir > 0 ? v > 0 : v < 0;
      for (int g = 0; g < n; ++g) {
        const double vs = b.vs_grid[static_cast<std::size_t>(g)], q2 = (v / vs) * (v / vs);
        const double e = on && q2 < 50.0 ? dir * std::exp(-q2) : 0.0;
        out[2 * g] = e;
        out[2 * g + 1] = e * 2.0 * q2 / vs;
      }
    });
    for (int g = 0; g < n; ++g) b.grid[d].push_back({bank.add(c.col(2 * g)), bank.add(c.col(2 * g + 1))});
  }
  return b;
}

/// Pooled recordings are one drive in states the trace cannot relate: each
/// file's friction level is set by its day (temperature, lubrication,
/// preload), and the time between files is made up. A level per run is
/// therefore part of the base model, not of any effect: every run after the
/// first gets its own Coulomb and viscous change per direction it moves in,
/// so that a candidate is judged only on what changes within runs. Without
/// them the thermal drift read the level between files as a warm-up
/// (-38 V over 123 s against a 0.09 V Coulomb force on pooled SysId
/// files), and position friction could read it as a range of travel one
/// file covers (docs/diagnosis.md, "Pooled runs").
void add_run_levels(const Observations& obs, ColumnBank& bank, const std::vector<double>& run_starts, BaseColumns& b) {
  auto column = [&](std::size_t r, int d, bool viscous) {
    return obs.sample_column([&](std::size_t j) {
      const double v = obs.interval_v(j);
      if ((d == 0 ? v <= 0 : v >= 0) || diag::run_of(run_starts, obs.interval_t(j)) != r) return 0.0;
      return viscous ? v : (d == 0 ? 1.0 : -1.0);
    });
  };
  auto identified = [&](const Vec& col) {  // a level only held-out folds see cannot be fitted
    for (std::size_t i = 0; i < obs.size(); ++i)
      if (!obs.obs()[i].heldout && col(static_cast<Eigen::Index>(i)) != 0.0) return true;
    return false;
  };
  // The base's level in a direction is that of the first run identified in
  // it: a level of its own for a later run where the first never moved that
  // way was the base's term again (two one-direction SysId runs gave an
  // offset in one order of the files and not in the other).
  std::array<std::size_t, 2> reference = {run_starts.size(), run_starts.size()};
  for (int d = 0; d < 2; ++d)
    for (std::size_t r = 0; r < run_starts.size() && reference[d] == run_starts.size(); ++r)
      if (identified(column(r, d, false))) reference[d] = r;
  for (std::size_t r = 1; r < run_starts.size(); ++r)
    for (int d = 0; d < 2; ++d)
      for (bool viscous : {false, true}) {
        if (r <= reference[d]) continue;
        const Vec col = column(r, d, viscous);
        if (identified(col)) b.run_levels.push_back({r, reference[d], d, viscous, bank.add(col)});
      }
}

/// Fit with vs per direction picked on the grid by coordinate search: an
/// unmodelled effect biases the core's vs (quadratic damping pulled it from
/// 2 to 17 mm/s), so every fit picks its own; the dE/dvs columns then move
/// vs within the grid cell linearly. `extra` must be made with all_columns.
LinearFit fit_vs_free(const ColumnBank& bank, const BaseColumns& b, Model& m, const ColumnBank::Extra* extra) {
  LinearFit best = bank.fit(model_columns(b, m), extra);
  for (int round = 0; round < 2; ++round)
    for (int d = 0; d < 2; ++d) {
      if (!b.stribeck[d]) continue;
      int chosen = m.g[d];
      for (int g = 0; g < static_cast<int>(b.vs_grid.size()); ++g) {
        m.g[d] = g;
        const LinearFit f = bank.fit(model_columns(b, m), extra);
        if (f.ok && (!best.ok || f.ssr_id < best.ssr_id)) {
          best = f;
          chosen = g;
        }
      }
      m.g[d] = chosen;
    }
  return best;
}

void refit(const ColumnBank& bank, const BaseColumns& b, Model& m) {
  m.fit = fit_vs_free(bank, b, m, nullptr);
  m.residual = bank.residual(model_columns(b, m), nullptr, m.fit.theta);
}

Model fit_base(const ColumnBank& bank, const BaseColumns& b, const IdentifyResult& base) {
  Model m;
  if (b.stribeck[0]) m.g[0] = static_cast<int>(diag::nearest_in_log(b.vs_grid, base.estimate.pos.stribeck_velocity_m_s));
  if (b.stribeck[1]) m.g[1] = static_cast<int>(diag::nearest_in_log(b.vs_grid, base.estimate.neg.stribeck_velocity_m_s));
  refit(bank, b, m);
  return m;
}

/// Held-out observations the identification folds do not pin down, in
/// units of the identification residual variance s2: the linear fit's
/// prediction variance (leverage), and, because a Stribeck velocity the data
/// barely constrain is outside that linear picture, the squared spread of
/// the predictions of every vs on the grid that fits the identification
/// observations almost as well as the best: SSR within 25 s2, the same
/// five standard deviations a candidate must clear (the blocks' errors are
/// correlated, so chi2_1 quantiles would claim more than the data know).
/// Those above max_leverage are set aside (a slow jog only a held-out fold
/// has is a question the fit cannot answer, not an unmodelled effect).
std::size_t set_aside_unsupported(Observations& obs, const ColumnBank& bank, const BaseColumns& b, const Model& base,
                                  double max_leverage) {
  constexpr double kIndistinct = 25.0;
  Vec spread = bank.leverage(model_columns(b, base));
  const auto n_id = static_cast<double>(std::count(bank.id().begin(), bank.id().end(), 1));
  const double s2 = base.fit.ssr_id / std::max(n_id - static_cast<double>(model_columns(b, base).size()), 1.0);
  for (int d = 0; d < 2 && s2 > 0; ++d) {
    if (!b.stribeck[d]) continue;
    for (int g = 0; g < static_cast<int>(b.vs_grid.size()); ++g) {
      Model m = base;
      m.g[d] = g;
      const LinearFit f = bank.fit(model_columns(b, m));
      if (!f.ok || f.ssr_id - base.fit.ssr_id > kIndistinct * s2) continue;
      const Vec change = bank.residual(model_columns(b, m), nullptr, f.theta) - base.residual;
      spread = spread.cwiseMax(change.array().square().matrix() / s2);
    }
  }
  return obs.set_aside_beyond(spread, max_leverage);
}

// ---------------------------------------------------------------------------
// 3. The gap on the held-out observations.
// ---------------------------------------------------------------------------

double heldout_rms(const Vec& r, const Observations& obs) {
  double s = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < obs.size(); ++i)
    if (obs.obs()[i].heldout) {
      s += r(static_cast<Eigen::Index>(i)) * r(static_cast<Eigen::Index>(i));
      ++n;
    }
  return n ? std::sqrt(s / static_cast<double>(n)) : 0.0;
}

/// White noise floor of the residual: held-out observations that follow
/// each other without sharing a block differ by noise only (smooth structure
/// cancels), so sigma = 1.4826 median|r_i - r_j| / sqrt(2).
double noise_floor(const Vec& r, const Observations& obs) {
  std::vector<double> d;
  const auto& o = obs.obs();
  for (std::size_t i = 2; i < o.size(); ++i)
    if (o[i].heldout && o[i - 2].heldout && o[i].a == o[i - 2].a + 2)
      d.push_back(std::fabs(r(static_cast<Eigen::Index>(i)) - r(static_cast<Eigen::Index>(i - 2))));
  if (d.size() < 10) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return 1.4826 * d[d.size() / 2] / std::sqrt(2.0);
}

struct Gap {
  double rms = 0.0, floor = 0.0;
  double ratio() const { return floor > 0 ? rms / floor : 0.0; }
  double excess() const { return std::max(rms - floor, 0.0); }
  double excess_energy() const { return std::max(rms * rms - floor * floor, 0.0); }
};

/// The held-out RMS against what a perfect model would leave: white noise
/// and the log's time resolution (point_sampling_floor).
Gap measure_gap(const Vec& r, const Observations& obs, double sampling_floor_N) {
  return {heldout_rms(r, obs), std::hypot(noise_floor(r, obs), sampling_floor_N)};
}

/// Held-out improvement of a candidate over its noise-only spread
/// (diag::improvement_z on the held-out observations).
double improvement_z(const Vec& r_cur, const Vec& r_new, const Observations& obs) {
  std::vector<Eigen::Index> ho;
  for (std::size_t i = 0; i < obs.size(); ++i)
    if (obs.obs()[i].heldout) ho.push_back(static_cast<Eigen::Index>(i));
  return diag::improvement_z(ho.size(), [&](std::size_t k) { return std::make_pair(r_cur(ho[k]), r_new(ho[k])); });
}

// ---------------------------------------------------------------------------
// 4. Candidates: each effect fitted jointly with the current model on the
//    identification observations, then judged on the held-out ones.
// ---------------------------------------------------------------------------

/// The columns a family's search draws (its grid, refinements and golden
/// sections), kept as EffectModel::keep_columns says: the parameter values
/// are fixed or follow the same path, and the columns depend on nothing
/// else; only the model they are fitted beside changes with the
/// selection's steps and pair trials (on the 25 s EMPS PULSES run with a
/// given model, the ripple's 160 periods were drawn 7 times and the
/// compliance's 50 frequencies 6). The same bits as drawing them again.
/// Kept up to kBytes in all; beyond that, drawn each time, so that a long
/// log's memory stays bounded: with every family's kept from the first
/// draw without a budget of its own, a one-step diagnosis of 60 s at 2 kHz
/// held 14 MB it never read again (2.0x identify's peak memory, the bar;
/// 1.86x within kFirstDrawBytes).
class SearchColumns {
 public:
  /// One store per family of `catalogue`, each with its own lock: a pair
  /// search draws one family beside several partners at once.
  SearchColumns(const std::vector<EffectModel>& catalogue, const ColumnBank& bank) : bank_(bank) {
    for (const EffectModel& em : catalogue) family_.emplace(&em, std::make_unique<Store>());
  }
  /// Columns are shared, not copied: a kept grid point is read by every
  /// search that asks for it (a ripple's 176 periods, 35 kB each on EMPS
  /// PULSES: their copies took a third of a search on the kept grid), its
  /// own products taken once (ColumnBank::Candidate).
  using Columns = std::shared_ptr<const ColumnBank::Candidate>;
  /// em's columns at each of ps and size, drawn as r says: those not kept
  /// drawn together where the family can (EffectModel::columns_at_many).
  std::vector<Columns> at_many(const EffectModel& em, const std::vector<double>& ps, int size, Observations::Draw r) {
    std::vector<Columns> out(ps.size());
    std::vector<std::size_t> missing;
    for (std::size_t i = 0; i < ps.size(); ++i)
      if (!(out[i] = kept(em, ps[i], size, r))) missing.push_back(i);
    if (missing.empty()) return out;
    std::vector<double> drawn_at;
    for (const std::size_t i : missing) drawn_at.push_back(ps[i]);
    std::vector<Mat> drawn;
    if (em.columns_at_many) drawn = em.columns_at_many(drawn_at, size, r);
    else
      for (const double p : drawn_at) drawn.push_back(em.columns(p, size, r));
    for (std::size_t j = 0; j < missing.size(); ++j) {
      out[missing[j]] = std::make_shared<const ColumnBank::Candidate>(bank_.candidate(std::move(drawn[j])));
      offer(em, drawn_at[j], size, r, out[missing[j]]);
    }
    return out;
  }

 private:
  using Key = std::tuple<double, int, int, int>;
  static Key key_of(double p, int size, Observations::Draw r) {
    return Key{p, size, static_cast<int>(r.resolution), static_cast<int>(r.rows)};
  }
  /// The kept columns, or none.
  Columns kept(const EffectModel& em, double p, int size, Observations::Draw r) {
    if (em.keep_columns == EffectModel::Keep::never) return {};
    Store& store = *family_.at(&em);
    const std::lock_guard<std::mutex> hold(store.lock);
    const auto it = store.kept.find(key_of(p, size, r));
    return it == store.kept.end() ? Columns{} : it->second;
  }
  /// Columns just drawn, kept as em.keep_columns says and the budgets allow.
  void offer(const EffectModel& em, double p, int size, Observations::Draw r, const Columns& cols) {
    using Keep = EffectModel::Keep;
    if (em.keep_columns == Keep::never) return;
    Store& store = *family_.at(&em);
    const Key key = key_of(p, size, r);
    const std::size_t bytes = static_cast<std::size_t>(cols->cols_id.size()) * sizeof(double);
    const std::lock_guard<std::mutex> hold(store.lock);
    const bool again = !store.drawn.insert(key).second;
    if (store.kept.count(key) == 0 &&
        (again ? claim(bytes, kBytes) : em.keep_columns == Keep::from_first_draw && claim(bytes, kFirstDrawBytes)))
      store.kept.emplace(key, cols);
  }
  /// Kept from their first draw while all kept take less than this: a
  /// short log's grids are kept whole (EMPS PULSES: 9 MB), where a long
  /// log's would be memory a one-step diagnosis never reads again.
  static constexpr std::size_t kFirstDrawBytes = std::size_t{10} << 20;
  /// Kept from their second draw (a later step has asked again) up to this.
  static constexpr std::size_t kBytes = std::size_t{24} << 20;
  struct Store {
    std::mutex lock;
    std::set<Key> drawn;
    std::map<Key, Columns> kept;
  };
  const ColumnBank& bank_;
  std::map<const EffectModel*, std::unique_ptr<Store>> family_;
  std::atomic<std::size_t> bytes_{0};  ///< kept, over all families

  /// Room for `bytes` more within `limit`, taken at once (families keep
  /// columns from several threads); false when they do not fit.
  bool claim(std::size_t bytes, std::size_t limit) {
    std::size_t now = bytes_.load();
    while (now + bytes <= limit)
      if (bytes_.compare_exchange_weak(now, now + bytes)) return true;
    return false;
  }
};

struct Stage {
  const Observations& obs;
  ColumnBank& bank;
  SearchColumns& search_columns;
  const BaseColumns& base;
  const std::vector<EffectModel>& catalogue;
  double sampling_floor_N = 0.0;  ///< point_sampling_floor
  double given_mass_kg = 0.0;     ///< a given model's mass (DiagnoseOptions::model); 0 when the base is fitted
  bool base_friction_unsettled = false;  ///< a fitted base with a direction friction_unsettled
};

/// The mass an effect's parameters are judged against: the given model's,
/// or the fitted one's (the first base column).
double stage_mass(const Stage& st, const Vec& theta) { return st.base.fixed.empty() ? st.given_mass_kg : theta(0); }

/// Relative SSR difference below which two grid points tie.
constexpr double kGridTieRelative = 1e-9;

/// Width in log(p) at which a continuous parameter's search stops.
constexpr double kParameterLogTolerance = 1e-3;

/// Share of the noise variance within which a continuous parameter's SSR
/// is resolved: an SSR within 0.01 sigma^2 of the least lies within a
/// tenth of the parameter's standard error (the SSR rises by sigma^2 at one
/// standard error, where it is quadratic in the parameter).
constexpr double kResolvedNoiseShare = 0.01;

/// The golden section's smaller share of a bracket, (3 - sqrt 5) / 2.
constexpr double kGoldenShare = 0.3819660112501051;

/// Candidates drawn at once where a family draws them cheaper together.
constexpr std::size_t kBatch = 8;

/// Whether em's search at `size` scores its candidates from edges (EffectModel::edges_of).
bool by_edges(const EffectModel& em, int size) { return em.edges_of && size == em.sizes.front(); }

/// The identification SSR of the held fit with em's columns at each of ps
/// (size `size`, drawn as r says): from the columns themselves, or from
/// their edges' products where the family's columns are differences of
/// edges (EffectModel::edges_of), every edge drawn once for all of ps.
std::vector<double> ssrs_beside(const Stage& st, const ColumnBank::Held& held, const EffectModel& em,
                                const std::vector<double>& ps, int size, Observations::Draw r) {
  std::vector<double> out;
  if (by_edges(em, size)) {
    const diag::EdgeSet set(em.edges_of, ps);
    const ColumnBank::Edges e = st.bank.edges_beside(held, em.edge_columns(set.edges, r));
    std::vector<std::pair<Eigen::Index, Eigen::Index>> pairs;
    for (const double p : ps) {
      const auto [a, b] = em.edges_of(p);
      pairs.emplace_back(set.index(a), set.index(b));
    }
    return st.bank.ssrs_of_differences(held, e, pairs);
  }
  for (const SearchColumns::Columns& cols : st.search_columns.at_many(em, ps, size, r))
    out.push_back(st.bank.ssr_beside(held, *cols));
  return out;
}

/// How far below fx the parabola through (x, fx), (w, fw), (v, fv) goes
/// on [lo, hi]: what a step anywhere in the bracket could gain, where the
/// least lies inside it or at an end (a time constant at the end of its
/// grid); infinite where the points do not define a parabola.
double parabola_decrease(double x, double fx, double w, double fw, double v, double fv, double lo, double hi) {
  const double dw = w - x, dv = v - x, det = dw * dv * (dw - dv);
  // A failed fit's infinite SSR among the points defines no parabola: its
  // gains would be NaN, which must not read as resolved.
  if (det == 0.0 || !(std::isfinite(fx) && std::isfinite(fw) && std::isfinite(fv))) return kInf;
  const double a = ((fw - fx) * dv - (fv - fx) * dw) / det, b = ((fv - fx) * dw * dw - (fw - fx) * dv * dv) / det;
  const auto gain = [&](double t) { return -(a * t + b) * t; };
  double best = std::max({0.0, gain(lo - x), gain(hi - x)});
  if (a > 0.0) {
    const double t = -b / (2.0 * a);
    if (x + t > lo && x + t < hi) best = std::max(best, gain(t));
  }
  return std::isnan(best) ? kInf : best;
}

/// Brent's minimisation (Brent 1973, ch. 5; Numerical Recipes 10.3) of f
/// on [a, b] from x0 inside it, where f(x0) = f0 is known, until the
/// bracket is within `width`, or until the parabola through the three best
/// points promises no more than `resolved`: parabolic steps through those
/// points where they fall well inside, golden sections where not. On the
/// smooth minima of a family's SSR it takes 4-7 values of f where golden
/// sections alone took 11 from the grid's bracket.
template <class F>
void brent_minimum(double a, double b, double x0, double f0, double width, double resolved, F f) {
  const double tol = 0.25 * width;  // stops once |x - mid| <= 2 tol - (b - a) / 2: b - a <= 4 tol
  double x = x0, w = x0, v = x0, fx = f0, fw = f0, fv = f0, d = 0.0, e = 0.0;
  for (int it = 0; it < 40; ++it) {
    const double mid = 0.5 * (a + b);
    if (std::fabs(x - mid) <= 2.0 * tol - 0.5 * (b - a)) return;
    if (v != w && w != x && v != x && parabola_decrease(x, fx, w, fw, v, fv, a, b) <= resolved) return;
    bool golden = true;
    if (std::fabs(e) > tol) {
      const double r = (x - w) * (fx - fv);
      double q = (x - v) * (fx - fw), p = (x - v) * q - (x - w) * r;
      q = 2.0 * (q - r);
      if (q > 0.0) p = -p;
      q = std::fabs(q);
      const double e_before = e;
      e = d;
      if (std::fabs(p) < std::fabs(0.5 * q * e_before) && p > q * (a - x) && p < q * (b - x)) {
        d = p / q;
        const double u = x + d;
        if (u - a < 2.0 * tol || b - u < 2.0 * tol) d = mid > x ? tol : -tol;
        golden = false;
      }
    }
    if (golden) {
      e = x >= mid ? a - x : b - x;
      d = kGoldenShare * e;
    }
    const double u = std::fabs(d) >= tol ? x + d : x + (d > 0 ? tol : -tol);
    const double fu = f(u);
    if (fu <= fx) {
      (u >= x ? a : b) = x;
      v = w, fv = fw, w = x, fw = fx, x = u, fx = fu;
    } else {
      (u < x ? a : b) = u;
      if (fu <= fw || w == x) {
        v = w, fv = fw, w = u, fw = fu;
      } else if (fu <= fv || v == x || v == w) {
        v = u, fv = fu;
      }
    }
  }
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Grid points either side of the one nearest a first size's best among
/// which a larger size's search looks again (EffectModel::SearchAgain::near_first).
constexpr std::size_t kResearchCells = 2;

/// The effect's nonlinear parameter by least squares with the current
/// model's terms (vs held): grid on coarse segments (the basin), then
/// discrete refinement or Brent's steps in log on fine ones. Only the
/// identification observations' SSR is read, so only they are drawn.
/// `near`: only the grid points within kResearchCells places of the one
/// nearest it (EffectModel::SearchAgain::near_first).
double search_parameter(const Stage& st, const std::vector<int>& with, const EffectModel& em, int size,
                        double near = kNaN) {
  using Res = Observations::Resolution;
  using Rows = Observations::Rows;
  const std::vector<double> grid = em.grid.empty()   ? std::vector<double>{0.0}
                                   : std::isnan(near) ? em.grid
                                                      : diag::grid_window(em.grid, near, kResearchCells);
  const ColumnBank::Held held = st.bank.hold(with);
  const auto ssrs = [&](const std::vector<double>& ps, Res r) { return ssrs_beside(st, held, em, ps, size, {r, Rows::identification}); };
  auto cost = [&](double p, Res r) { return ssrs({p}, r).front(); };
  const Res grid_res = em.fine_grid || grid.size() == 1 ? Res::fine : Res::coarse;
  double best_ssr = kInf, best_p = grid[0];
  std::size_t best_i = 0;
  // A few grid points drawn at once, where the family draws them cheaper
  // together (EffectModel::columns_at_many); all at once from edges.
  const std::size_t batch = by_edges(em, size) ? grid.size() : kBatch;
  for (std::size_t i0 = 0; i0 < grid.size(); i0 += batch) {
    const std::vector<double> ps(grid.begin() + static_cast<std::ptrdiff_t>(i0),
                                 grid.begin() + static_cast<std::ptrdiff_t>(std::min(grid.size(), i0 + batch)));
    const std::vector<double> ssr = ssrs(ps, grid_res);
    for (std::size_t j = 0; j < ps.size(); ++j) {
      // Grid points whose columns agree on the identification observations
      // (two position ranges over the same blocks) tie to the last digits:
      // the first one is kept, so that rounding does not choose.
      const double margin = std::isfinite(best_ssr) ? kGridTieRelative * std::fabs(best_ssr) : 0.0;
      if (ssr[j] < best_ssr - margin) best_ssr = ssr[j], best_p = ps[j], best_i = i0 + j;
    }
  }
  if (grid.size() == 1) return best_p;
  if (grid_res != Res::fine) best_ssr = cost(best_p, Res::fine);
  auto try_p = [&](double p) {
    const double c = cost(p, Res::fine);
    if (c < best_ssr) best_ssr = c, best_p = p;
    return c;
  };
  // Each round's values in batches (a round's all at once from edges),
  // tried in order as one by one (a position range's edges moved cell by
  // cell: 40 passes over the fine segments a round, a tenth of diagnose on
  // EMPS PULSES, before batches; one pass over 42 edges since).
  if (em.refine)
    for (int round = 0; round < 2; ++round) {
      const std::vector<double> around = em.refine(best_p);
      const std::size_t refine_batch = by_edges(em, size) ? around.size() : kBatch;
      for (std::size_t i0 = 0; i0 < around.size(); i0 += refine_batch) {
        const std::vector<double> ps(around.begin() + static_cast<std::ptrdiff_t>(i0),
                                     around.begin() + static_cast<std::ptrdiff_t>(std::min(around.size(), i0 + refine_batch)));
        const std::vector<double> ssr = ssrs(ps, Res::fine);
        for (std::size_t j = 0; j < ps.size(); ++j)
          if (ssr[j] < best_ssr) best_ssr = ssr[j], best_p = ps[j];
      }
    }
  if (em.continuous && grid.size() >= 3) {
    double a = std::log(grid[best_i > 0 ? best_i - 1 : 0]), b = std::log(grid[std::min(best_i + 1, grid.size() - 1)]);
    if (a > b) std::swap(a, b);  // a descending grid (a ripple's on a travel under 1.2 mm)
    const auto f = [&](double x) { return try_p(std::exp(x)); };
    // From the grid's best value, whose SSR is known; where that is an end
    // of the bracket (the grid's first or last value), from the golden
    // point inside it, as the golden sections started.
    double x0 = std::log(best_p), f0 = best_ssr;
    if (!(x0 > a && x0 < b)) {
      const double at_end = best_ssr;
      x0 = a + kGoldenShare * (b - a), f0 = f(x0);
      // The least may lie beyond the search range (a compliance above the
      // grid's top, a ripple longer than three travels): where the golden
      // point is no better than the grid's end, the end is kept (a dip
      // inside the last cell nearer the end than that point is missed).
      // On EMPS PULSES such searches took 7-10 of Brent's steps toward the
      // end; all but one found nothing better, and that one a point 0.4 %
      // inside it (a compliance at the top of its range, not physical there).
      if (!(f0 < at_end)) return best_p;
    }
    // Done where a step could lower the SSR by no more than
    // kResolvedNoiseShare of the noise variance (the least SSR over the
    // observations, an upper bound): the best point is then within a tenth
    // of the parameter's standard error of the minimum, where the SSR is
    // quadratic, and the data tell the points apart no further.
    const auto n_id = static_cast<double>(std::max<std::size_t>(1, st.bank.identification_count()));
    const double resolved = kResolvedNoiseShare * best_ssr / n_id;
    brent_minimum(a, b, x0, f0, kParameterLogTolerance, resolved, f);
  }
  return best_p;
}

/// em's columns at parameter p for each of its sizes, on every observation:
/// the largest size drawn once where the smaller ones are its first columns
/// (EffectModel::columns_per_size).
class SizedColumns {
 public:
  SizedColumns(const EffectModel& em, double p) : em_(em), p_(p) {
    if (em.columns_per_size > 0) largest_ = em.columns(p, em.sizes.back(), {});
  }
  /// Where sizes are not nested, each drawn once: choose_size fits every
  /// size, and the evaluation fits the chosen one again.
  Mat at(int size) const {
    if (em_.columns_per_size > 0) return largest_.leftCols(static_cast<Eigen::Index>(size) * em_.columns_per_size);
    auto it = drawn_.find(size);
    if (it == drawn_.end()) it = drawn_.emplace(size, em_.columns(p_, size, {})).first;
    return it->second;
  }

 private:
  const EffectModel& em_;
  double p_;
  Mat largest_;
  mutable std::map<int, Mat> drawn_;  ///< sizes drawn, where not nested

 public:
  /// Only `size` is read from here on: the others' memory goes (on a long
  /// log the three spline sizes of position friction held 46 MB).
  void keep_only(int size) {
    for (auto it = drawn_.begin(); it != drawn_.end();) it = it->first == size ? std::next(it) : drawn_.erase(it);
  }
};

/// The family size at parameter p: each size fitted on the identification
/// observations, scored on the held-out ones by n ln(SSR) + k ln(n)
/// (Schwarz's penalty: a column must lower the held-out error by more than
/// ln(n)/n of it), where n counts independent held-out observations (each
/// block serves two observations: half of them) and k the effect's
/// columns. The held-out test then judges the chosen size.
int choose_size(const Stage& st, const std::vector<int>& with, const EffectModel& em, const SizedColumns& columns) {
  if (em.sizes.size() == 1) return em.sizes.front();
  double n = 0.0;
  for (const Observation& o : st.obs.obs()) n += o.heldout ? 0.5 : 0.0;
  double best_cost = kInf;
  int best = em.sizes.front();
  for (int size : em.sizes) {
    const ColumnBank::Extra ex = st.bank.extra(columns.at(size), with);
    const LinearFit f = st.bank.fit(with, &ex);
    if (!f.ok) continue;
    const double ssr = 2.0 * n * std::pow(heldout_rms(st.bank.residual(with, &ex, f.theta), st.obs), 2);
    const double cost = n * std::log(ssr) + static_cast<double>(ex.cols.cols()) * std::log(n);
    if (cost < best_cost) best_cost = cost, best = size;
  }
  return best;
}

struct Evaluation {
  Candidate c;
  std::size_t effect = 0;
  double p = 0.0;
  int size = 1;  ///< family size (choose_size)
  Model model;  ///< current + this effect, vs free (its columns not yet in the bank)
  bool plausible = false;  ///< fitted, physical, and not a combination of the model's terms
  bool eligible = false;
  Mat columns;  ///< kept where plausible and asked for (keep_columns): the effect's columns at p and size, on every observation
};

/// `keep_columns`: a plausible evaluation keeps its columns for adopt()
/// (a step's; a pair's second member is drawn again where adopted, so
/// that a pair step's many evaluations do not hold theirs at once).
Evaluation evaluate(const Stage& st, const Model& current, std::size_t effect, bool keep_columns) {
  const EffectModel& em = st.catalogue[effect];
  Evaluation e;
  e.effect = effect;
  e.c.kind = em.kind;
  const std::vector<int> with = model_columns(st.base, current);
  e.p = search_parameter(st, with, em, em.sizes.front());
  SizedColumns sized(em, e.p);
  e.size = choose_size(st, with, em, sized);
  sized.keep_only(e.size);
  // A larger size can move the parameter (a compliance's frequency with
  // its damping): searched again at the size chosen.
  const double p_searched = e.p;
  using Again = EffectModel::SearchAgain;
  if (e.size != em.sizes.front() && em.continuous && em.search_again_at_size != Again::no) {
    const bool near = em.search_again_at_size == Again::near_first;
    e.p = search_parameter(st, with, em, e.size, near ? p_searched : kNaN);
    // Best on the window's edge (not the grid's): the least may lie
    // beyond the window, so the whole grid is searched after all.
    if (near && diag::on_window_edge(em.grid, p_searched, kResearchCells, e.p))
      e.p = search_parameter(st, with, em, e.size);
  }
  ColumnBank::Extra ex = st.bank.extra(e.p == p_searched ? sized.at(e.size) : em.columns(e.p, e.size, {}),
                                       all_columns(st.base, current));
  e.model = current;
  const LinearFit f = fit_vs_free(st.bank, st.base, e.model, &ex);
  if (!f.ok) {
    e.c.note = "fit failed";
    return e;
  }
  e.model.fit = f;
  e.model.residual = st.bank.residual(model_columns(st.base, e.model), &ex, f.theta);
  e.c.parameters = em.parameters(e.p, e.size, f.theta.tail(ex.cols.cols()), stage_mass(st, f.theta));
  e.c.heldout_rms_N = heldout_rms(e.model.residual, st.obs);
  e.c.z_statistic = improvement_z(current.residual, e.model.residual, st.obs);
  // Exactly a combination of the model's terms (an offset is Fc+ - Fc-
  // while moving): the split between them is arbitrary, never named. Nearly
  // one (a v|v| beside v on sine motion, R^2 0.998): the held-out test decides.
  const double r2 = st.bank.max_collinearity(with, ex);
  e.c.indistinguishable = r2 > 1.0 - 1e-6;
  if (e.c.indistinguishable) {
    // It changes the prediction only by rounding: what it "closes" and its
    // z are rounding's, and would change with the order of a sum.
    e.c.heldout_rms_N = heldout_rms(current.residual, st.obs);
    e.c.z_statistic = 0.0;
  }
  if (r2 > 0.995)
    e.c.note = std::string(e.c.indistinguishable ? "its term is" : "its term is nearly") +
               " a combination of the model's terms on this data (R^2 " + std::to_string(r2) + ")";
  const std::string why_not = em.implausible ? em.implausible(e.c.parameters, stage_mass(st, f.theta)) : std::string();
  if (!why_not.empty()) e.c.note = "not physical: " + why_not;
  // Beside a base whose friction law the run does not settle, a change of
  // friction with speed or time draws what the base misses (12 s of a
  // ladder: a c2 of 7e5 N s^2/m^2 "closed" 97 % of a gap the base left).
  const bool stands_in = st.base_friction_unsettled && em.friction_with_speed_or_time;
  if (stands_in && why_not.empty())
    e.c.note = "not named: the base's friction law is not settled on this run, and this effect would stand in for it";
  e.c.significant = !e.c.indistinguishable && why_not.empty() && !stands_in;
  e.plausible = e.c.significant;
  // Kept for adopt(), which would otherwise draw the same columns again
  // (serial: a pair step adopts every plausible candidate alone first).
  if (e.plausible && keep_columns) e.columns = std::move(ex.cols);
  return e;
}

/// Significance and size against the gap the current model leaves.
void judge(Evaluation& e, const Gap& gap, const DiagnoseOptions& opt) {
  Candidate& c = e.c;
  c.closed_fraction = gap.excess() > 0 ? std::clamp((gap.rms - c.heldout_rms_N) / gap.excess(), -1.0, 1.0) : 0.0;
  c.energy_share = gap.excess_energy() > 0
                       ? std::clamp((gap.rms * gap.rms - c.heldout_rms_N * c.heldout_rms_N) / gap.excess_energy(), -1.0, 1.0)
                       : 0.0;
  c.significant = c.significant && c.z_statistic >= opt.significance_z && c.heldout_rms_N < gap.rms;
  e.eligible = c.significant && c.energy_share >= opt.min_step_energy_share;
}

// ---------------------------------------------------------------------------
// 5. Selection: forward, one effect per step, on what the others leave.
// ---------------------------------------------------------------------------

/// Bank columns of an effect's term at parameter p: `drawn`, where they
/// were drawn already on every observation, else drawn here.
Model::Term make_term(const Stage& st, std::size_t effect, double p, int size, const Mat& drawn = Mat()) {
  Model::Term term;
  term.effect = effect;
  term.p = p;
  term.size = size;
  const Mat cols = drawn.size() > 0 ? drawn : st.catalogue[effect].columns(p, size, {});
  for (Eigen::Index c = 0; c < cols.cols(); ++c) term.cols.push_back(st.bank.add(cols.col(c)));
  return term;
}

/// Adds the chosen effect's columns to the bank and refits the model with it.
Model adopt(const Stage& st, const Evaluation& e) {
  Model m = e.model;
  m.terms.push_back(make_term(st, e.effect, e.p, e.size, e.columns));
  refit(st.bank, st.base, m);
  return m;
}

/// job(k) for every k < n on up to opt.threads threads, the caller's among
/// them; `progress(share done)` on the caller's thread only. The jobs share
/// only read-only state (the observations, the bank's columns and their
/// products) and the grid stores, so what they compute is the same on any
/// number of threads. The first exception a job throws is rethrown here.
template <class Job>
void run_jobs(std::size_t n, const DiagnoseOptions& opt, Job job, const std::function<void(double)>& progress = {}) {
  std::atomic<std::size_t> next{0}, done{0};
  double reported = 0.0;  ///< the share last reported: the caller's thread only
  std::exception_ptr failure;
  std::mutex failure_lock;
  // Nothing escapes a worker: a throwing job or progress callback is kept
  // for the caller, and the remaining jobs are dropped.
  auto work = [&](bool on_caller) {
    for (std::size_t k = next++; k < n; k = next++) {
      try {
        job(k);
        const double share = static_cast<double>(++done) / static_cast<double>(n);
        if (on_caller && progress) progress(reported = share);
      } catch (...) {
        const std::lock_guard<std::mutex> hold(failure_lock);
        if (!failure) failure = std::current_exception();
        next = n;
      }
    }
  };
  const unsigned wanted = opt.threads > 0 ? static_cast<unsigned>(opt.threads) : std::thread::hardware_concurrency();
  const std::size_t threads = std::clamp<std::size_t>(wanted, 1, std::max<std::size_t>(n, 1));
  std::vector<std::thread> pool;
  try {
    for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work, false);
  } catch (const std::system_error&) {
    // No more threads to be had: the jobs run on those there are.
  }
  work(true);
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
  if (progress && reported < 1.0) progress(1.0);  // the last jobs ended on other threads
}

/// Each unused family evaluated beside the current model (run_jobs), then
/// judged and sorted.
std::vector<Evaluation> evaluate_all(const Stage& st, const Model& current, const std::vector<bool>& used,
                                     const Gap& gap, const DiagnoseOptions& opt, double progress_from, double progress_to) {
  std::vector<std::size_t> todo;
  for (std::size_t i = 0; i < st.catalogue.size(); ++i)
    if (!used[i]) todo.push_back(i);
  std::vector<Evaluation> evals(todo.size());
  std::function<void(double)> progress;
  if (opt.progress) progress = [&](double share) { opt.progress(progress_from + (progress_to - progress_from) * share); };
  run_jobs(todo.size(), opt, [&](std::size_t k) { evals[k] = evaluate(st, current, todo[k], true); }, progress);
  for (auto& e : evals) judge(e, gap, opt);
  std::stable_sort(evals.begin(), evals.end(), [](const Evaluation& a, const Evaluation& b) {
    if (a.eligible != b.eligible) return a.eligible;
    return a.c.heldout_rms_N < b.c.heldout_rms_N;
  });
  // Only the first is adopted where it is eligible; where not, the pair
  // step adopts each plausible one alone.
  if (!evals.empty() && evals.front().eligible)
    for (auto e = evals.begin() + 1; e != evals.end(); ++e) e->columns = Mat();
  return evals;
}

/// Term k's parameters from m's joint fit with all its terms.
nlohmann::json term_parameters(const Stage& st, const Model& m, std::size_t k) {
  Eigen::Index c = static_cast<Eigen::Index>(model_columns(st.base, m).size());
  for (const auto& t : m.terms) c -= static_cast<Eigen::Index>(t.cols.size());
  for (std::size_t i = 0; i < k; ++i) c += static_cast<Eigen::Index>(m.terms[i].cols.size());
  const auto& t = m.terms[k];
  return st.catalogue[t.effect].parameters(t.p, t.size, m.fit.theta.segment(c, static_cast<Eigen::Index>(t.cols.size())),
                                           stage_mass(st, m.fit.theta));
}

/// Why term k of m is not physical in m's joint fit (empty: it is).
std::string term_implausible(const Stage& st, const Model& m, std::size_t k) {
  const EffectModel& em = st.catalogue[m.terms[k].effect];
  return em.implausible ? em.implausible(term_parameters(st, m, k), stage_mass(st, m.fit.theta)) : std::string();
}

/// Two effects that explain the gap only together. Tested alone, each
/// leaves the other's residual in its z test's spread, so neither passes
/// (z 4-5 on gaps 10-50x the noise floor: drift beside a delay, position
/// friction beside quadratic damping). Tried only when no single candidate
/// qualifies but the gap is real: every pair of plausible candidates, the
/// second's parameter searched beside the first. A pair is named
/// when each member is significant given the other and together they
/// explain the step's energy share; the best such pair (least held-out RMS).
struct PairStep {
  struct Member {
    std::size_t effect = 0;  ///< catalogue index
    Candidate c;
  };
  Member first, second;  ///< second: searched and fitted beside first
  Model model;           ///< current + both, both in the bank
  double first_z = 0.0;  ///< first's z given second
  bool found = false;
};

PairStep best_pair(const Stage& st, const std::vector<Evaluation>& evals, const Gap& gap,
                   const DiagnoseOptions& opt) {
  std::vector<const Evaluation*> pool;
  for (const auto& e : evals)
    if (e.plausible) pool.push_back(&e);
  if (pool.size() < 2) return PairStep{};
  // Each candidate adopted alone once (it adds its columns to the bank, so
  // not on the threads), then every second member searched beside its first.
  std::vector<Model> alone;
  for (const Evaluation* e : pool) alone.push_back(adopt(st, *e));
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t i = 0; i < pool.size(); ++i)
    for (std::size_t j = i + 1; j < pool.size(); ++j) pairs.emplace_back(i, j);
  std::vector<Evaluation> second(pairs.size());
  run_jobs(pairs.size(), opt, [&](std::size_t k) {
    second[k] = evaluate(st, alone[pairs[k].first], pool[pairs[k].second]->effect, false);
  });
  PairStep best;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto [i, j] = pairs[k];
    const Evaluation& a = *pool[i];  // evals are sorted: a fits better alone
    Evaluation& b = second[k];
    judge(b, gap, opt);  // z of b given a; energy share of the pair against the step's gap
    if (!b.eligible || (best.found && b.c.heldout_rms_N >= best.second.c.heldout_rms_N)) continue;
    const Model both = adopt(st, b);
    // The first member was judged physical alone; refitted beside the
    // second it may not be (a compliance whose load mass turned negative
    // was named in a pair): such a pair is not named.
    if (!term_implausible(st, both, both.terms.size() - 2).empty()) continue;
    const double a_given_b = improvement_z(alone[j].residual, both.residual, st.obs);
    if (a_given_b < opt.significance_z) continue;
    best = {{a.effect, a.c}, {b.effect, b.c}, both, a_given_b, true};
  }
  return best;
}

/// Where the next eligible candidate fits the held-out observations as
/// well as the one named (the held-out test does not prefer the named one
/// over it), the run cannot tell them apart: said in `ambiguities`, so
/// that the name is not read as a finding over the other. Seen with a load
/// smooth in position over 30 s: position_friction (per-direction profiles
/// draw any load in position) or a ripple longer than the travel, named by
/// the seed.
void report_rival(const Stage& st, const std::vector<Evaluation>& evals, const DiagnoseOptions& opt, DiagnoseResult& out) {
  const Evaluation& best = evals.front();
  const auto rival = std::find_if(evals.begin() + 1, evals.end(), [](const Evaluation& e) { return e.eligible; });
  if (rival == evals.end()) return;
  const double z = improvement_z(rival->model.residual, best.model.residual, st.obs);
  if (!(z < opt.significance_z)) return;
  const std::string& N = opt.identify.units.force;
  std::ostringstream zs;
  zs << std::setprecision(2) << z << " < " << opt.significance_z;
  out.ambiguities.push_back(
      {{"kinds", {best.c.kind, rival->c.kind}},
       {"effect_number", out.effects.size() + 1},  // the effect being named: 1 for the first
       {"z", z},
       {"note", best.c.kind + " (held-out RMS " + fmt(best.c.heldout_rms_N, N) + ") or " + rival->c.kind + " (" +
                    fmt(rival->c.heldout_rms_N, N) + "): each closes the gap, and the held-out test does not prefer the "
                    "first (z " + zs.str() + "); " + best.c.kind +
                    " is named for its lower error, but this run does not tell them apart"}});
}

/// report_rival's entries against the effects finally named: a rival is
/// an alternative to an effect that stays named, so one whose effect the
/// verdict dropped goes, and so does one that a later step named too (not
/// an alternative but the other half of a pair whose members each close
/// part of the first step's gap).
void keep_rivals_of_named(DiagnoseResult& out) {
  const auto named = [&](const nlohmann::json& kind) {
    return std::any_of(out.effects.begin(), out.effects.end(), [&](const NamedEffect& e) { return e.kind == kind; });
  };
  auto& a = out.ambiguities;
  a.erase(std::remove_if(a.begin(), a.end(),
                         [&](const nlohmann::json& x) { return x.contains("z") && (!named(x["kinds"][0]) || named(x["kinds"][1])); }),
          a.end());
}

/// The effects named so far with their parameters from current's joint
/// fit: what name_parameters reports where no later step names more.
std::vector<NamedEffect> named_so_far(const Stage& st, const Model& current, const DiagnoseResult& out) {
  std::vector<NamedEffect> named = out.effects;
  for (std::size_t k = 0; k < current.terms.size() && k < named.size(); ++k) named[k].parameters = term_parameters(st, current, k);
  return named;
}

/// Forward selection: add the best significant effect, refit, test the
/// rest on what remains; stop when the gap is noise or nothing qualifies.
Model select_effects(const Stage& st, const Model& base, const DiagnoseOptions& opt, DiagnoseResult& out) {
  Model current = base;
  std::vector<bool> used(st.catalogue.size(), false);
  for (int step = 0; step < opt.max_effects; ++step) {
    if (step > 0 && opt.on_effects_provisional) opt.on_effects_provisional(named_so_far(st, current, out));
    const Gap gap = measure_gap(current.residual, st.obs, st.sampling_floor_N);
    // The first step's candidates are listed even without a gap (and
    // calibrate the test on effect-free traces); later ones need a gap.
    if (step > 0 && gap.ratio() < opt.unexplained_ratio) break;
    const double from = step == 0 ? 0.2 : 0.8, to = step == 0 ? 0.8 : 0.95;
    const std::vector<Evaluation> evals = evaluate_all(st, current, used, gap, opt, from, to);
    out.steps.emplace_back();
    for (const auto& e : evals) out.steps.back().push_back(e.c);
    if (step == 0) out.candidates = out.steps.back();
    if (evals.empty()) break;
    if (gap.ratio() < opt.unexplained_ratio) {
      // No gap to explain: a candidate passing the held-out test here is
      // not named, and says why (DATA_EMPS printed `effect: none` beside a
      // candidate it called significant). Naming it was tried: on pooled
      // effect-free runs a 380 Hz "compliance" (a timing residual) was named
      // at a gap ratio of 1.12.
      for (auto& c : out.steps.back())
        if (c.significant)
          c.note = "significant, but not named: the held-out gap is within " + fmt(opt.unexplained_ratio, "times") +
                   " of the noise floor";
      if (step == 0) out.candidates = out.steps.back();
      break;
    }
    if (!evals.front().eligible) {
      if (step + 2 > opt.max_effects) break;
      const PairStep pair = best_pair(st, evals, gap, opt);
      if (!pair.found) break;
      used[pair.first.effect] = used[pair.second.effect] = true;
      out.effects.push_back({pair.first.c.kind, {}, pair.first.c.heldout_rms_N, 0.0, pair.first_z, pair.second.c.kind});
      current = pair.model;
      out.effects.push_back({pair.second.c.kind, {}, heldout_rms(current.residual, st.obs), 0.0, pair.second.c.z_statistic,
                             pair.first.c.kind});
      ++step;
      continue;
    }
    const Evaluation& best = evals.front();
    report_rival(st, evals, opt, out);
    used[best.effect] = true;
    current = adopt(st, best);
    NamedEffect named;
    named.kind = best.c.kind;
    named.heldout_rms_N = heldout_rms(current.residual, st.obs);
    named.z_statistic = best.c.z_statistic;
    out.effects.push_back(named);
  }
  return current;
}

/// Each named effect's parameters from the joint fit with all of them.
void name_parameters(const Stage& st, const Model& m, DiagnoseResult& out) { out.effects = named_so_far(st, m, out); }

/// theta: m, Fc+, Fc-, sigma+, sigma-, then (Fs, dE) per direction with a dip.
DriveParams drive_params(const BaseColumns& b, const Model& m) {
  const Vec& th = m.fit.theta;
  DriveParams a;
  a.mass_kg = th(0);
  a.pos = {th(3), th(1), 0.0, b.vs_grid.empty() ? 0.0 : b.vs_grid[static_cast<std::size_t>(m.g[0])]};
  a.neg = {th(4), th(2), 0.0, b.vs_grid.empty() ? 0.0 : b.vs_grid[static_cast<std::size_t>(m.g[1])]};
  Eigen::Index c = 5;
  for (int d = 0; d < 2; ++d) {
    if (!b.stribeck[d]) continue;
    auto& side = d == 0 ? a.pos : a.neg;
    side.breakaway_N = th(c);
    // The dE/dvs coefficient is Fs dvs: one linearised step within the cell.
    if (th(c) > 0)
      side.stribeck_velocity_m_s =
          std::clamp(side.stribeck_velocity_m_s + th(c + 1) / th(c), 0.7 * side.stribeck_velocity_m_s, 1.4 * side.stribeck_velocity_m_s);
    c += 2;
  }
  return a;
}

/// An offset and Coulomb friction that differs by direction are the same
/// regressor while the axis moves, and at rest a drive holds the friction of
/// its last stroke, which carries the same asymmetry: the data cannot
/// separate them, so a large asymmetry is reported as that ambiguity, never
/// as an `offset` (docs/diagnosis.md, "Offset").
void report_offset_ambiguity(const Model& m, const DiagnoseOptions& opt, DiagnoseResult& out) {
  // A direction the trace never moves in has no Coulomb force to compare:
  // its zero made a 25 N "difference" and a 12.5 N "offset" of a
  // one-way trace.
  const bool pos_seen = out.base.estimate.pos.friction_identified(), neg_seen = out.base.estimate.neg.friction_identified();
  if (pos_seen != neg_seen) {
    out.ambiguities.push_back(
        {{"kinds", {effect_name(Effect::offset), "coulomb_asymmetry"}},
         {"note", std::string("the trace moves in the ") + (pos_seen ? "positive" : "negative") +
                      " direction only: neither an offset nor a Coulomb force that differs by direction can be read "
                      "from it (a run that moves both ways would compare them)"}});
    return;
  }
  if (!pos_seen) return;
  const double fcp = m.fit.theta(1), fcn = m.fit.theta(2);
  const double asym = 0.5 * (fcp - fcn), mean_fc = 0.5 * (fcp + fcn);
  if (!(mean_fc > 0) || std::fabs(asym) <= opt.offset_asymmetry_ratio * mean_fc) return;
  const std::string& N = opt.identify.units.force;
  out.ambiguities.push_back(
      {{"kinds", {effect_name(Effect::offset), "coulomb_asymmetry"}},
       {"offset_N", asym},
       {"coulomb_difference_N", fcp - fcn},
       {"note", "Coulomb friction differs by " + fmt(fcp - fcn, N) + " between directions (" +
                    fmt(100.0 * std::fabs(asym) / mean_fc, "%") + " of the mean): either an offset of " + fmt(asym, N) +
                    " (gravity, cable drag, a sensor offset) or friction that differs by direction. While the axis "
                    "moves the two are the same term, and at rest the drive holds the friction of its last stroke; "
                    "this trace has no evidence that separates them (a force reading with the axis unloaded would)."}});
}

/// A fitted base whose friction law the run does not settle (Stage::
/// base_friction_unsettled): said, with what it means for the effects.
void report_unsettled_friction(DiagnoseResult& out) {
  std::string dirs;
  for (const auto* d : {&out.base.estimate.pos, &out.base.estimate.neg})
    if (friction_unsettled(*d)) dirs += std::string(dirs.empty() ? "" : " and ") + (d == &out.base.estimate.pos ? "positive" : "negative");
  out.ambiguities.push_back(
      {{"kinds", {"base_friction_unsettled"}},
       {"directions", dirs},
       {"note", "the base model's friction law is not settled by this run in the " + dirs +
                    " direction (friction falls across every speed logged): the base "
                    "gets a Stribeck dip to fit, and a change of friction with speed or time (quadratic_viscous, "
                    "thermal_drift) is not named, since it would stand in for what the base misses. A run that also "
                    "reaches speeds where friction rises again settles it (docs/recording.md)."}});
}

/// A position friction named where position and speed rise together (a
/// one-way ramp, as SysId's quasi-static test drives): the run cannot tell
/// friction that changes along the travel from friction that changes with
/// speed in a way the model lacks. A review saw a 1.42 V level named at
/// z 83 on a drivetrain whose Coulomb force is 0.06 V, without a word.
/// Said beside it, with the correlation of position and speed.
void report_position_with_speed(const Observations& obs, DiagnoseResult& out) {
  constexpr double kConfounded = 0.9;  // |correlation| of position and speed in one direction
  constexpr double kFewest = 20.0;     // observations a direction needs for a correlation
  const auto named = [](const NamedEffect& e) { return e.kind == effect_name(Effect::position_friction); };
  if (std::none_of(out.effects.begin(), out.effects.end(), named)) return;
  double worst = 0.0;
  for (const int d : {1, -1}) {
    double n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    for (const auto& o : obs.obs()) {
      if (o.dir != d) continue;
      const double y = std::fabs(o.v);
      n += 1;
      sx += o.x, sy += y, sxx += o.x * o.x, syy += y * y, sxy += o.x * y;
    }
    if (n < kFewest) continue;
    const double cxx = sxx - sx * sx / n, cyy = syy - sy * sy / n, cxy = sxy - sx * sy / n;
    if (cxx > 0 && cyy > 0) worst = std::max(worst, std::fabs(cxy) / std::sqrt(cxx * cyy));
  }
  if (worst < kConfounded) return;
  char r[16];
  std::snprintf(r, sizeof r, "%.2f", worst);
  out.ambiguities.push_back(
      {{"kinds", {effect_name(Effect::position_friction), "friction_with_speed"}},
       {"correlation", worst},
       {"note", "position and speed rise together in this run (correlation " + std::string(r) +
                    "): the position friction named may be a change of friction with speed that the model lacks; a "
                    "run that passes the same positions at other speeds would tell them apart"}});
}

/// The base model's level per pooled run (add_run_levels) is a finding, not
/// an effect: the runs' friction differs, and the trace cannot say whether
/// by day, load or a warm-up between them. Reported beside the offset's
/// ambiguity, with each run's change from the first.
void report_run_levels(const BaseColumns& b, const Model& m, const DiagnoseOptions& opt, DiagnoseResult& out) {
  if (b.run_levels.empty()) return;
  const std::vector<double> change = run_level_changes(b, m);
  const Units& u = opt.identify.units;
  nlohmann::json runs = nlohmann::json::array();
  std::string text;
  for (std::size_t i = 0; i < b.run_levels.size(); ++i) {
    const auto& l = b.run_levels[i];
    const char* dir = l.direction == 0 ? "positive" : "negative";
    runs.push_back({{"run", l.run + 1}, {"from_run", l.reference + 1}, {"direction", dir}, {"term", l.viscous ? "viscous" : "coulomb"},
                    {"change", change[i]}, {"unit", l.viscous ? u.viscous() : u.force}});
    if (!l.viscous)
      text += (text.empty() ? "" : ", ") + std::string("run ") + std::to_string(l.run + 1) + " " + dir + " " +
              fmt(change[i], u.force) + (l.reference == 0 ? "" : " from run " + std::to_string(l.reference + 1) + "'s");
  }
  out.ambiguities.push_back(
      {{"kinds", {"run_friction_levels"}},
       {"levels", runs},
       {"note", "each pooled run has its own Coulomb and viscous friction level in the base model (Coulomb, from the "
                "first run's that moves that way: " + text + "): the time between recordings is unknown, so a difference between runs is "
                "not read as a drift or any other effect"}});
}

// ---------------------------------------------------------------------------
// 6. Where the gap lies.
// ---------------------------------------------------------------------------

std::string range_text(double lo, double hi, const char* unit) {
  if (!std::isfinite(lo)) return "below " + fmt(hi, unit);
  if (!std::isfinite(hi)) return "above " + fmt(lo, unit);
  return fmt(lo, unit) + " .. " + fmt(hi, unit);
}

template <typename Value>
void where_bins(const Observations& obs, const Vec& r, const std::string& domain, const std::vector<double>& edges,
                Value value, const char* unit, std::vector<WhereEntry>& out) {
  double e_total = 0.0, t_total = 0.0;
  const auto& o = obs.obs();
  for (std::size_t i = 0; i < o.size(); ++i)
    if (o[i].heldout) {
      e_total += r(static_cast<Eigen::Index>(i)) * r(static_cast<Eigen::Index>(i)) * o[i].area;
      t_total += o[i].area;
    }
  WhereEntry best;
  double best_lift = -1.0;
  for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
    double e = 0.0, tt = 0.0;
    for (std::size_t i = 0; i < o.size(); ++i) {
      const double q = value(o[i]);
      if (!o[i].heldout || q < edges[b] || q >= edges[b + 1]) continue;
      e += r(static_cast<Eigen::Index>(i)) * r(static_cast<Eigen::Index>(i)) * o[i].area;
      tt += o[i].area;
    }
    if (tt < 0.02 * t_total || e_total <= 0) continue;
    const double share = e / e_total, tshare = tt / t_total;
    if (share - tshare > best_lift) {
      best_lift = share - tshare;
      best = {domain, range_text(edges[b], edges[b + 1], unit), edges[b], edges[b + 1], share, tshare};
    }
  }
  if (best_lift > -1.0) out.push_back(best);
}

/// Peak of the periodogram of the held-out residual over runs of contiguous observations.
void where_in_frequency(const Observations& obs, const Vec& r, double block_s, std::vector<WhereEntry>& out) {
  const std::vector<double> freqs = log_grid(0.5, 0.45 / block_s, 120);
  const std::size_t nf = freqs.size();
  std::vector<double> k(nf), power(nf, 0.0), re(nf), im(nf), zr(nf), zi(nf);
  for (std::size_t fi = 0; fi < nf; ++fi) k[fi] = 2 * M_PI * freqs[fi];
  const auto& o = obs.obs();
  for (std::size_t i = 0; i < o.size();) {
    std::size_t j = i + 1;
    while (j < o.size() && o[i].heldout && o[j].heldout && o[j].a == o[j - 1].a + 1) ++j;
    if (o[i].heldout && j - i >= 32) {
      // Every frequency's phasors at an observation side by side
      // (unit_phasors); each frequency's sums in the observations' order.
      std::fill(re.begin(), re.end(), 0.0);
      std::fill(im.begin(), im.end(), 0.0);
      for (std::size_t b = i; b < j; ++b) {
        diag::unit_phasors(k.data(), o[b].t, nf, zr.data(), zi.data());
        const double rb = r(static_cast<Eigen::Index>(b));
        for (std::size_t fi = 0; fi < nf; ++fi) re[fi] += rb * zr[fi], im[fi] += rb * zi[fi];
      }
      for (std::size_t fi = 0; fi < nf; ++fi) power[fi] += (re[fi] * re[fi] + im[fi] * im[fi]) / static_cast<double>(j - i);
    }
    i = j;
  }
  double total = 0.0;
  for (double p : power) total += p;
  if (!(total > 0)) return;
  const auto pk = static_cast<std::size_t>(std::max_element(power.begin(), power.end()) - power.begin());
  double near = 0.0, bins = 0.0;
  for (std::size_t fi = 0; fi < freqs.size(); ++fi)
    if (std::fabs(std::log(freqs[fi] / freqs[pk])) < 0.1) near += power[fi], bins += 1.0;
  out.push_back({"frequency", fmt(freqs[pk], "Hz"), freqs[pk] * 0.9, freqs[pk] * 1.1, near / total,
                 bins / static_cast<double>(freqs.size())});
}

std::vector<WhereEntry> where_gap_lies(const Observations& obs, const Vec& r, const IdentifyResult& base, double block_s) {
  std::vector<WhereEntry> out;
  const Units& u = base.units;
  const double v_min = base.config.velocity_min_m_s, vmax = base.config.velocity_max_m_s;
  std::vector<double> v_edges;
  for (int i = 8; i >= 0; --i) v_edges.push_back(-vmax * std::pow(v_min / vmax, i / 8.0));
  v_edges.front() = -kInf;
  for (int i = 0; i <= 8; ++i) v_edges.push_back(vmax * std::pow(v_min / vmax, 1.0 - i / 8.0));
  v_edges.back() = kInf;
  where_bins(obs, r, "velocity", v_edges, [](const Observation& o) { return o.v; }, u.velocity().c_str(), out);
  const diag::TraceExtent e = diag::trace_extent(obs);
  std::vector<double> x_edges, t_edges;
  for (int i = 0; i <= 10; ++i) x_edges.push_back(e.x_lo + e.travel * i / 10.0);
  x_edges.back() += 1e-12;
  where_bins(obs, r, "position", x_edges, [](const Observation& o) { return o.x; }, u.position.c_str(), out);
  for (int i = 0; i <= 5; ++i) t_edges.push_back(e.t0 + e.duration * i / 5.0);
  t_edges.back() += 1e-9;
  where_bins(obs, r, "time", t_edges, [](const Observation& o) { return o.t; }, "s", out);
  where_bins(obs, r, "after_reversal", {0.0, 1e-5, 1e-4, 1e-3, kInf}, [](const Observation& o) { return o.since_reversal; }, u.position.c_str(), out);
  std::vector<double> ac;
  for (const auto& o : obs.obs()) ac.push_back(o.accel_change);
  std::nth_element(ac.begin(), ac.begin() + static_cast<std::ptrdiff_t>(ac.size() * 9 / 10), ac.end());
  where_bins(obs, r, "acceleration_change", {0.0, ac[ac.size() * 9 / 10], kInf},
             [](const Observation& o) { return o.accel_change; }, u.acceleration().c_str(), out);
  where_in_frequency(obs, r, block_s, out);
  std::stable_sort(out.begin(), out.end(), [](const WhereEntry& a, const WhereEntry& b) {
    return a.share - a.time_share > b.share - b.time_share;
  });
  return out;
}

// ---------------------------------------------------------------------------
// 7. Verdict and the report's series.
// ---------------------------------------------------------------------------

/// RMS (N) the log's time resolution adds to the held-out
/// observations when the force is a point sample at the tick: a step of
/// acceleration da at an unknown place within a period moves the force
/// integral of that period by up to m da dt / 2 (uniform: variance
/// (m da dt)^2 / 12), seen through the observation's weight (mean w^2 = 1/3)
/// and divided by its area. A period-mean log (held, averaged) integrates
/// the step exactly and has none of it.
double point_sampling_floor(const Observations& obs, double mass_kg, bool point_sampled) {
  if (!point_sampled || !(mass_kg > 0)) return 0.0;
  const double dt = 1.0 / obs.signals().sample_rate_hz;
  double sum = 0.0;
  std::size_t n = 0;
  for (const Observation& o : obs.obs())
    if (o.heldout) {
      const double jump = mass_kg * o.accel_change * dt / o.area;
      sum += jump * jump / 36.0;
      ++n;
    }
  return n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

void verdict(const Stage& st, const Model& base, const Model& final_model, const DiagnoseOptions& opt, DiagnoseResult& out) {
  // The white floor from what is left too: structure the effects remove (a
  // ripple at speed) no longer inflates the differences it is taken from.
  const double white_base = noise_floor(base.residual, st.obs), white_left = noise_floor(final_model.residual, st.obs);
  out.noise_floor_N = std::min(white_base, white_left > 0 ? white_left : white_base);
  out.sampling_floor_N = st.sampling_floor_N;
  double floor = std::hypot(out.noise_floor_N, out.sampling_floor_N);
  out.rms_base_N = heldout_rms(base.residual, st.obs);
  out.rms_augmented_N = heldout_rms(final_model.residual, st.obs);
  const double excess = std::max(out.rms_base_N - floor, 0.0);
  auto closed = [&](double rms) { return excess > 0 ? std::clamp((out.rms_base_N - rms) / excess, -1.0, 1.0) : 0.0; };
  out.closed_fraction = closed(out.rms_augmented_N);
  for (auto& e : out.effects) e.closed_fraction = closed(e.heldout_rms_N);
  // Together they must explain enough of the excess energy (the measure the
  // selection steps use) to be the gap's cause.
  const double excess_energy = out.rms_base_N * out.rms_base_N - floor * floor;
  const double energy_closed =
      excess_energy > 0 ? (out.rms_base_N * out.rms_base_N - out.rms_augmented_N * out.rms_augmented_N) / excess_energy : 0.0;
  if (!out.effects.empty() && energy_closed < opt.min_closed_fraction) {
    out.effects.clear();
    out.rms_augmented_N = out.rms_base_N;
    out.closed_fraction = 0.0;
    // The floor of a model with no effect is the base's own: one taken from
    // the residual of effects just dropped made an effect-free trace
    // `unexplained` (ratio 1.11 to the base's floor, 1.47 to theirs).
    out.noise_floor_N = white_base;
    floor = std::hypot(out.noise_floor_N, out.sampling_floor_N);
  }
  out.gap_remains = floor > 0 && out.rms_augmented_N / floor >= opt.unexplained_ratio;
  if (!out.effects.empty()) {
    out.effect = out.effects.front().kind;
    out.effect_parameters = out.effects.front().parameters;
  } else {
    out.effect = out.gap_remains ? "unexplained" : "none";
  }
}

void keep_series(const Observations& obs, const Vec& r_base, const Vec& r_aug, DiagnoseResult& out) {
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const Observation& o = obs.obs()[i];
    out.block_t.push_back(o.t);
    out.block_x.push_back(o.x);
    out.block_v.push_back(o.v);
    out.block_r_base.push_back(r_base(static_cast<Eigen::Index>(i)));
    out.block_r_aug.push_back(r_aug(static_cast<Eigen::Index>(i)));
    out.block_heldout.push_back(o.heldout);
  }
}

/// Where each pooled recording starts on the trace's clock (empty for one).
std::vector<double> run_starts(const Trace& trace) {
  std::vector<double> t;
  for (const TraceRun& r : trace.runs)
    if (r.first < trace.samples.size()) t.push_back(trace.samples[r.first].t_s);
  return t;
}

/// Each pooled run's fitted level change (add_run_levels) added to f's per-run friction.
void add_level_changes(const BaseColumns& b, const Model& base, diag::MeasuredFriction& f) {
  const std::vector<double> change = run_level_changes(b, base);
  for (std::size_t i = 0; i < b.run_levels.size(); ++i) {
    const auto& l = b.run_levels[i];
    (l.viscous ? f.viscous_Ns_m : f.coulomb_N)[2 * l.run + static_cast<std::size_t>(l.direction)] += change[i];
  }
}

/// theta: m, Fc+, Fc-, sigma+, sigma-: the friction the trace shows without any effect.
/// Plus each run's own level (add_run_levels) for pooled runs.
diag::MeasuredFriction measured_friction(const BaseColumns& b, const Model& base, std::size_t runs) {
  const Vec& th = base.fit.theta;
  diag::MeasuredFriction f;
  for (std::size_t r = 0; r < runs; ++r) {
    f.coulomb_N.insert(f.coulomb_N.end(), {th(1), th(2)});
    f.viscous_Ns_m.insert(f.viscous_Ns_m.end(), {th(3), th(4)});
  }
  add_level_changes(b, base, f);
  return f;
}

/// The friction a given model states, for every run (the drift's
/// plausibility test), plus each pooled run's own level.
diag::MeasuredFriction given_friction(const DriveParams& d, const BaseColumns& b, const Model& base, std::size_t runs) {
  diag::MeasuredFriction f;
  for (std::size_t r = 0; r < runs; ++r) {
    f.coulomb_N.insert(f.coulomb_N.end(), {d.pos.coulomb_N, d.neg.coulomb_N});
    f.viscous_Ns_m.insert(f.viscous_Ns_m.end(), {d.pos.viscous_Ns_m, d.neg.viscous_Ns_m});
  }
  add_level_changes(b, base, f);
  return f;
}

/// The mean force a given model's inertia and friction predict over each
/// interval (its load: load_prediction), from the same velocity and
/// acceleration the fitted base's columns use: what the observations'
/// force less it leaves is the gap the effects may explain.
Vec given_prediction(const Observations& obs, const ModelFile& m) {
  const Signals& s = obs.signals();
  return obs.sample_column([&](std::size_t j) {
    const double a = (s.v[j + 1] - s.v[j]) / obs.interval_dt(j);
    return predict_force(m.drive, obs.interval_v(j), a);
  });
}

/// A load over each interval, at its middle position: a given model's,
/// or the gravity term the base's identification fitted.
Vec load_prediction(const Observations& obs, const ModelLoad& load) {
  const Signals& s = obs.signals();
  return obs.sample_column([&](std::size_t j) { return load.at(0.5 * (s.x[j] + s.x[j + 1])); });
}



bool enough_observations(const Trace& trace, const Observations& obs, DiagnoseResult& out) {
  out.blocks_heldout = obs.heldout_count();
  out.blocks_identification = obs.size() - out.blocks_heldout - out.heldout_beyond_identification;
  if (out.blocks_identification >= 50 && out.blocks_heldout >= 50) return true;
  if (out.blocks_identification >= 50 && out.blocks_heldout + out.heldout_beyond_identification >= 50) {
    // Motion enough, but the held-out folds move where the identification
    // folds do not pin the base model down (a review met it on DATA_EMPS cut
    // to 12.5 s, while 12 and 13 s were diagnosed): say that, not "too little motion".
    out.error = trace.source + ": the held-out time moves where the identification time does not pin the base model " +
                "down: " + std::to_string(out.heldout_beyond_identification) + " of " +
                std::to_string(out.blocks_heldout + out.heldout_beyond_identification) +
                " held-out observations set aside (their predictions under the base fit vary by more than half "
                "the noise), " + std::to_string(out.blocks_heldout) + " left, need 50";
    return false;
  }
  out.error = trace.source + ": too little motion to diagnose: " + std::to_string(obs.size()) +
              " observations of motion, " + std::to_string(out.blocks_identification) + " for identification and " +
              std::to_string(out.blocks_heldout) + " held out" +
              (out.heldout_beyond_identification > 0
                   ? " (" + std::to_string(out.heldout_beyond_identification) +
                         " more set aside: the identification folds do not pin the base model down there)"
                   : std::string()) +
              "; need 50 of each";
  return false;
}

/// What the diagnosis reads of the trace.
struct Prepared {
  Signals sig;
  diag::Folds folds;
  std::vector<double> run_starts;
};

/// The trace's part: force outliers bridged (residuals are read block by
/// block: one force row of 1e12 would be all of them), the signals aligned,
/// the folds laid and the base identified on the identification ones
/// (out.base). The bridged copy of the trace ends here: on a long log it
/// was as large as the bank of columns, at the diagnosis's peak.
bool prepare(const Trace& logged, const DiagnoseOptions& opt, DiagnoseResult& out, Prepared& p) {
  const Trace trace = bridge_force_outliers(logged, opt.identify.units.force, out.force_outliers);
  if (trace.samples.size() < 1000) {
    out.error = trace.source + ": trace too short to diagnose: " + std::to_string(trace.samples.size()) +
                " samples (need at least 1000)";
    return false;
  }
  if (opt.folds < 2) {
    out.error = "--folds must be >= 2";
    return false;
  }
  p.sig = aligned_signals(trace, opt, out);
  const Signals& sig = p.sig;
  if (!sig.error.empty()) {
    out.error = sig.error;
    return false;
  }
  // A block closes once it spans block_s: 0 or less (or NaN) is no length
  // asked for, and infinity holds no observation.
  if (!(std::isfinite(opt.block_s) && opt.block_s > 0.0)) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "--block %g s: must be a positive, finite length (default 0.005 s; a block is at "
                  "least one sample period, %g s at %g Hz)", opt.block_s, sig.period_s(), sig.sample_rate_hz);
    out.error = buf;
    return false;
  }
  p.folds = diag::make_folds(sig, opt.folds, auto_config(sig, opt.identify).velocity_min_m_s);
  out.folds = p.folds.count();
  out.fold_edges = p.folds.edges;
  if (opt.model) {
    out.model_given = true;
    out.given_model = *opt.model;
  }
  p.run_starts = run_starts(trace);
  if (!identify_base(trace, sig, p.folds, opt, out)) return false;
  // What is read of them from here on is their conventions and the base's
  // sample count (its time stamps), not the samples: the base's copy of
  // the identification folds' and the rival cut-offs' velocities, which
  // only the base's standard errors took.
  p.sig.rival_velocities = {};
  Signals& base = out.base.signals;
  base.rival_velocities = {};
  base.x = base.v = base.u = {};
  return true;
}

}  // namespace

DiagnoseResult diagnose(const Trace& logged, const DiagnoseOptions& opt) {
  DiagnoseResult out;
  out.time_origin_s = logged.time_origin_s;
  Prepared prepared;
  if (!prepare(logged, opt, out, prepared)) return out;
  const Signals& sig = prepared.sig;
  const diag::Folds& folds = prepared.folds;
  if (opt.progress) opt.progress(0.1);

  Observations obs(sig, out.base.config.velocity_min_m_s, opt.block_s, folds);
  if (!enough_observations(logged, obs, out)) return out;
  std::vector<char> id(obs.size());
  for (std::size_t i = 0; i < obs.size(); ++i) id[i] = obs.identification(i) ? 1 : 0;
  Vec force = obs.sample_column([&](std::size_t j) { return obs.interval_force(j); });
  // A given model: its force is taken off and nothing of it is refitted
  // (no base columns), so the effects explain what it leaves. Pooled runs
  // still get their own levels: the file states one day's friction, and a
  // level between recordings is no effect of the model (add_run_levels).
  if (opt.model) force -= given_prediction(obs, *opt.model) + load_prediction(obs, opt.model->load);
  // The base's gravity term (auto on a rotary axis) is the base's, as it is
  // in the model identify writes: taken off, so no effect takes it up again.
  if (!opt.model && out.base.gravity.form != GravityTerm::none) force -= load_prediction(obs, gravity_load(out.base.gravity));
  ColumnBank bank(force, id);
  const diag::TraceExtent extent = diag::trace_extent(obs, prepared.run_starts);
  BaseColumns base_cols;
  if (!opt.model) base_cols = add_base_columns(obs, bank, out.base);
  add_run_levels(obs, bank, extent.run_starts, base_cols);
  const Model base = fit_base(bank, base_cols, out.base);
  // A given model has no fit whose reach the held-out folds could exceed.
  if (!opt.model) out.heldout_beyond_identification = set_aside_unsupported(obs, bank, base_cols, base, opt.max_leverage);
  if (!enough_observations(logged, obs, out)) return out;
  if (opt.progress) opt.progress(0.2);

  const std::size_t runs = extent.run_starts.size();
  const double mass_kg = opt.model ? opt.model->drive.mass_kg : out.base.estimate.mass_kg;
  const std::vector<EffectModel> catalogue = diag::effect_catalogue(
      obs, extent, out.lag_beyond_conventions_s,
      opt.model ? given_friction(opt.model->drive, base_cols, base, runs) : measured_friction(base_cols, base, runs));
  SearchColumns search_columns(catalogue, bank);
  const Stage st{obs, bank, search_columns, base_cols, catalogue,
                 point_sampling_floor(obs, mass_kg, out.base.signals.force_convention == "instant"),
                 opt.model ? mass_kg : 0.0,
                 !opt.model && (friction_unsettled(out.base.estimate.pos) || friction_unsettled(out.base.estimate.neg))};
  if (st.base_friction_unsettled) report_unsettled_friction(out);
  // Where the base's gap lies depends on the base alone: found beside the
  // selection, on a thread of its own where threads are allowed (3 of
  // PULSES' 90 ms, otherwise after the selection's last step), or after
  // it where no thread can be had.
  auto where_base = [&] { return where_gap_lies(obs, base.residual, out.base, opt.block_s); };
  std::future<std::vector<WhereEntry>> where = run_beside(opt.threads != 1, where_base);
  const Model final_model = select_effects(st, base, opt, out);
  name_parameters(st, final_model, out);
  verdict(st, base, final_model, opt, out);
  keep_rivals_of_named(out);
  if (!out.effects.empty()) {
    out.augmented_model = opt.model ? opt.model->drive : drive_params(base_cols, final_model);
    out.has_augmented_model = true;
  }
  // A given model's Coulomb forces are not fitted here: an asymmetry in
  // them is the file's, and an offset is a candidate like any other.
  if (!opt.model) report_offset_ambiguity(out.effects.empty() ? base : final_model, opt, out);
  report_run_levels(base_cols, out.effects.empty() ? base : final_model, opt, out);
  report_position_with_speed(obs, out);
  if (opt.on_effects_final) opt.on_effects_final(out);
  out.where = where.get();
  if (out.gap_remains && !out.effects.empty()) out.where_left = where_gap_lies(obs, final_model.residual, out.base, opt.block_s);
  keep_series(obs, base.residual, out.effects.empty() ? base.residual : final_model.residual, out);
  if (opt.progress) opt.progress(1.0);
  return out;
}

// ---------------------------------------------------------------------------
// 8. JSON and summary.
// ---------------------------------------------------------------------------

namespace {

nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

nlohmann::json where_json(const std::vector<WhereEntry>& where) {
  nlohmann::json w = nlohmann::json::array();
  for (const auto& e : where)
    w.push_back({{"domain", e.domain}, {"range", e.range}, {"lo", finite_or_null(e.lo)}, {"hi", finite_or_null(e.hi)},
                 {"share", e.share}, {"time_share", e.time_share}});
  return w;
}

nlohmann::json effects_json(const DiagnoseResult& r) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& e : r.effects)
    list.push_back({{"kind", e.kind}, {"parameters", e.parameters}, {"heldout_rms_N", e.heldout_rms_N},
                    {"closed_fraction", e.closed_fraction}, {"z_statistic", e.z_statistic},
                    {"named_with", e.named_with.empty() ? nlohmann::json() : nlohmann::json(e.named_with)}});
  if (r.gap_remains) {
    nlohmann::json u = {{"kind", "unexplained"}, {"heldout_rms_N", r.rms_augmented_N}};
    const auto& where = r.effects.empty() ? r.where : r.where_left;
    if (!where.empty()) u["where"] = where_json({where.front()}).front();
    list.push_back(u);
  }
  return list;
}

}  // namespace

nlohmann::json to_json(const DiagnoseResult& r) {
  nlohmann::json j;
  if (!r.error.empty()) {
    j["error"] = r.error;
    return j;
  }
  j["units"] = units_json(r.base.units);  // the log's: every key and value below is in them
  j["effect"] = {{"kind", r.effect}, {"parameters", r.effect_parameters.is_null() ? nlohmann::json::object() : r.effect_parameters}};
  for (auto it = r.effect_parameters.begin(); r.effect_parameters.is_object() && it != r.effect_parameters.end(); ++it)
    j["effect"][it.key()] = it.value();
  j["effects"] = effects_json(r);
  j["heldout"] = {{"rms_base_N", r.rms_base_N}, {"rms_augmented_N", r.rms_augmented_N},
                  {"closed_fraction", r.closed_fraction},
                  {"gap_ratio", r.noise_floor_N > 0 ? r.rms_base_N / r.noise_floor_N : 0.0},
                  {"gap_ratio_left", r.noise_floor_N > 0 ? r.rms_augmented_N / r.noise_floor_N : 0.0},
                  {"sampling_floor_N", r.sampling_floor_N},
                  {"sampling_floor", "a force logged as a point sample cannot place an acceleration step within its "
                                     "period: the RMS this adds (m da dt / sqrt(36) over each observation's area) joins the "
                                     "noise floor in the test for a gap that remains"},
                  {"blocks", r.blocks_heldout},
                  {"blocks_beyond_identification", r.heldout_beyond_identification},
                  {"max_leverage", "held-out observations whose prediction variance under the base fit exceeds half the "
                                   "noise variance lie where the identification folds do not reach; they are set aside"}};
  j["noise_floor_N"] = r.noise_floor_N;
  j["where"] = where_json(r.where);
  j["where_left"] = where_json(r.where_left);
  nlohmann::json c = nlohmann::json::array();
  for (const auto& x : r.candidates)
    c.push_back({{"kind", x.kind}, {"parameters", x.parameters}, {"heldout_rms_N", x.heldout_rms_N},
                 {"closed_fraction", x.closed_fraction}, {"energy_share", x.energy_share},
                 {"z_statistic", x.z_statistic}, {"significant", x.significant},
                 {"indistinguishable", x.indistinguishable}, {"note", x.note}});
  j["candidates"] = c;
  nlohmann::json steps = nlohmann::json::array();
  for (const auto& step : r.steps) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& x : step)
      list.push_back({{"kind", x.kind}, {"heldout_rms_N", x.heldout_rms_N}, {"energy_share", x.energy_share},
                      {"z_statistic", x.z_statistic}, {"significant", x.significant}, {"note", x.note}});
    steps.push_back(list);
  }
  j["selection_steps"] = steps;
  nlohmann::json ind = nlohmann::json::array();
  for (const auto& x : r.candidates)
    if (x.indistinguishable) ind.push_back({{"kind", x.kind}, {"note", x.note}, {"parameters", x.parameters}});
  j["indistinguishable"] = ind;
  j["ambiguities"] = r.ambiguities;
  if (r.model_given) {
    // The given model is the base; the core's fit on the identification
    // folds only set the signals' timing and velocity range.
    nlohmann::json m = model_json(r.given_model.drive, r.base.units);
    put_load(m, r.given_model.load);
    j["base_model"] = {{"given", r.given_model.source}, {"refitted", false}, {"model", m},
                       {"note", "the mass, friction and offset are the file's; only the effects are fitted, on the "
                                "identification folds"}};
  } else {
    j["base_model"] = to_json(r.base);
  }
  j["timing"] = {{"force_lag_s", r.force_lag_s},
                 {"lag_beyond_conventions_s", r.lag_beyond_conventions_s},
                 {"convention_force_delay_limit_periods", convention_force_delay_limit()},
                 {"rule", "the base model takes the force lag only as far as logging conventions explain it (force delay "
                          "within +-convention_force_delay_limit_periods); the rest is left to the delay candidate"}};
  j["input"] = {{"position", r.position_origin}, {"time_origin_s", r.time_origin_s}, {"force_outlier_rows", r.force_outliers.rows},
                {"force_outlier_limit", r.force_outliers.limit}, {"force_saturation", r.force_outliers.saturation.to_json()}, {"force_sign", r.base.signals.force_sign.sign},
                {"force_sign_origin", r.base.signals.force_sign.describe()}};
  j["split"] = {{"method", "time folds of two motion cycles or more, edges in dwells; odd folds held out"},
                {"folds", r.folds}, {"blocks_identification", r.blocks_identification},
                {"blocks_heldout", r.blocks_heldout}};
  return j;
}

std::string summary(const DiagnoseResult& r) {
  std::ostringstream o;
  if (!r.error.empty()) return "not diagnosed: " + r.error + "\n";  // the CLI prints the error itself
  const std::string& N = r.base.units.force;
  const char* n = N.c_str();
  char buf[400];
  std::snprintf(buf, sizeof buf, "held-out gap: RMS %.3g %s (noise floor %.3g %s, ratio %.2f) over %zu observations\n",
                r.rms_base_N, n, r.noise_floor_N, n, r.noise_floor_N > 0 ? r.rms_base_N / r.noise_floor_N : 0.0, r.blocks_heldout);
  o << buf;
  if (r.model_given)
    o << "base model: " << r.given_model.source << " as given (mass, friction and offset not refitted)\n";
  if (r.sampling_floor_N > 0) {
    std::snprintf(buf, sizeof buf, "  the force is point-sampled: acceleration steps within a period add %.3g %s RMS to the floor\n",
                  r.sampling_floor_N, n);
    o << buf;
  }
  if (r.heldout_beyond_identification > 0)
    o << "  " << r.heldout_beyond_identification
      << " held-out observations set aside: the identification folds do not pin the base model down there (prediction variance above half the noise)\n";
  if (r.position_origin != "measured") o << "position " << r.position_origin << "\n";
  if (r.force_outliers.rows > 0) o << "force: " << r.force_outliers.describe(N) << "\n";
  const ForceSign& sign = r.base.signals.force_sign;
  if (sign.sign < 0 || !sign.conclusive) o << "force " << sign.describe() << "\n";
  o << "effect: " << r.effect << "\n";
  for (std::size_t i = 0; i < r.effects.size(); ++i) {
    const NamedEffect& e = r.effects[i];
    // A pair is said once, before its first member: the first step's table
    // shows each member alone, not significant, with another z.
    const bool pair_starts = !e.named_with.empty() && i + 1 < r.effects.size() && r.effects[i + 1].named_with == e.kind;
    if (pair_starts)
      o << "  (a pair: " << e.kind << " and " << e.named_with << " close the gap only together; neither passes the "
        << "z test alone, and each z below is given the other)\n";
    std::snprintf(buf, sizeof buf, "  + %-22s held-out RMS -> %.3g %s, closes %.0f %% of the excess (z %.1f%s%s)\n",
                  e.kind.c_str(), e.heldout_rms_N, n, 100.0 * e.closed_fraction, e.z_statistic,
                  e.named_with.empty() ? "" : " given ", e.named_with.c_str());
    // A position-friction profile is 120 numbers: the JSON has it, the summary says so.
    nlohmann::json shown = e.parameters;
    if (shown.is_object() && shown.contains("profile")) shown["profile"] = "in the JSON";
    // Keys in the log's units, as the JSON names them (delta_V, x_max_rad).
    o << buf << "    " << keys_in_units(shown, r.base.units).dump() << "\n";
  }
  if (r.gap_remains && !r.effects.empty()) {
    o << "  + unexplained: a gap of " << fmt(r.rms_augmented_N, N) << " RMS remains";
    if (!r.where_left.empty()) o << ", most in " << r.where_left.front().domain << " " << r.where_left.front().range;
    o << "\n";
  }
  for (const auto& a : r.ambiguities) o << "ambiguous: " << a.value("note", std::string()) << "\n";
  o << "where the base model's residual lies (share of held-out residual energy vs share of time):\n";
  for (std::size_t i = 0; i < r.where.size() && i < 4; ++i) {
    std::snprintf(buf, sizeof buf, "  %-20s %-28s %5.1f %% of energy in %5.1f %% of time\n", r.where[i].domain.c_str(),
                  r.where[i].range.c_str(), 100 * r.where[i].share, 100 * r.where[i].time_share);
    o << buf;
  }
  o << "candidates at the first step (held-out RMS, z, share of the excess closed):\n";
  for (const auto& c : r.candidates) {
    std::snprintf(buf, sizeof buf, "  %-22s %8.3g %s  z %7.1f  closes %6.1f %%%s%s\n", c.kind.c_str(), c.heldout_rms_N, n,
                  c.z_statistic, 100 * c.closed_fraction, c.significant ? "  significant" : "",
                  c.indistinguishable ? "  indistinguishable from the model's terms" : "");
    o << buf;
    if (c.significant && r.effects.empty() && !c.note.empty()) o << "      (" << c.note << ")\n";
  }
  return o.str();
}

}  // namespace feedid::host
