#include "uncertainty.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <utility>

namespace feedid::host {
namespace {

/// Pointers to the nine standard errors of an estimate.
std::array<double*, 9> se_fields(feedid::Estimate<double>& e) {
  return {&e.mass_se_kg, &e.pos.viscous_se, &e.pos.coulomb_se, &e.pos.breakaway_se, &e.pos.stribeck_velocity_se,
          &e.neg.viscous_se, &e.neg.coulomb_se, &e.neg.breakaway_se, &e.neg.stribeck_velocity_se};
}

/// Calls f with a null pointer to the core type for `method`: BandsCore, the drive's core, for
/// the bands method; Core, which keeps the paper method's sums, for the
/// paper method. The two agree to rounding where both can solve.
template <typename F> auto for_method(feedid::Method method, F&& f) {
  return method == feedid::Method::paper ? f(static_cast<Core*>(nullptr)) : f(static_cast<BandsCore*>(nullptr));
}

template <typename C>
feedid::Status solve_stats(const typename C::Stats& s, const C& layout_of, feedid::Method method, feedid::Estimate<double>& e) {
  e = feedid::Estimate<double>{};
  e.method = method;
  if constexpr (C::paper_method)
    if (method == feedid::Method::paper) return feedid::analysis::solve_paper(s, layout_of.config(), e);
  return feedid::analysis::solve_bands(s, layout_of.layout(), layout_of.config(), e);
}

/// Delete-one-chunk jackknife: sqrt((K-1)/K sum (theta_-i - mean)^2).
int jackknife(const Signals& s, const feedid::Config<double>& cfg, feedid::Method method, std::array<double, 9>& se,
              const std::array<bool, 2>& refitted) {
  return for_method(method, [&](auto* type) {
    using C = std::remove_pointer_t<decltype(type)>;
    const std::size_t n = s.t.size();
    const int k = kJackknifeChunks;
    std::vector<std::unique_ptr<C>> cores;
    for (int c = 0; c < k; ++c) {
      SolvedCore<C> run = solve_core<C>(s, cfg, method, chunk_begin(c, n), chunk_begin(c + 1, n));
      if (run.status == feedid::Status::invalid_config) return 0;
      cores.push_back(std::move(run.core));
    }
    return jackknife_over(cores, method, se, refitted);
  });
}

}  // namespace

template <typename C>
int jackknife_over(const std::vector<std::unique_ptr<C>>& cores, feedid::Method method, std::array<double, 9>& se,
                   const std::array<bool, 2>& refitted) {
  const int k = static_cast<int>(cores.size());
  std::vector<std::array<double, 9>> theta;
  auto pooled = std::make_unique<typename C::Stats>();
  for (int leave = 0; leave < k; ++leave) {
    *pooled = typename C::Stats{};
    for (int c = 0; c < k; ++c)
      if (c != leave) feedid::add_statistics(*pooled, cores[static_cast<std::size_t>(c)]->statistics());
    feedid::Estimate<double> e;
    if (solve_stats(*pooled, *cores[0], method, e) != feedid::Status::ok) continue;
    bool ok = true;
    for (int d = 0; d < 2; ++d)
      if (refitted[static_cast<std::size_t>(d)]) ok = ok && refit_coulomb_viscous(*pooled, d, e.mass_kg, d == 0 ? e.pos : e.neg);
    if (!ok) continue;
    theta.push_back(parameters(e));
  }
  const int used = static_cast<int>(theta.size());
  if (used < k / 2) return 0;
  std::vector<double> column(theta.size());
  for (int i = 0; i < 9; ++i) {
    for (std::size_t j = 0; j < theta.size(); ++j) column[j] = theta[j][static_cast<std::size_t>(i)];
    se[static_cast<std::size_t>(i)] = jackknife_se(column);
  }
  return used;
}
template int jackknife_over(const std::vector<std::unique_ptr<Core>>&, feedid::Method, std::array<double, 9>&,
                            const std::array<bool, 2>&);
template int jackknife_over(const std::vector<std::unique_ptr<BandsCore>>&, feedid::Method, std::array<double, 9>&,
                            const std::array<bool, 2>&);

namespace {

/// Sensitivity of the parameters to the lag (one more identification, half
/// a period away, on the side the pairing rule can reach) times its uncertainty.
std::array<double, 9> timing_se(const Signals& s, const feedid::Config<double>& cfg, feedid::Method method,
                                const std::array<double, 9>& theta, double lag_uncertainty) {
  std::array<double, 9> out{};
  if (!(lag_uncertainty > 0)) return out;
  const double lag = timing_probe_lag(s);
  feedid::Config<double> c = cfg;
  c.force_lag_samples = lag;
  // The core pairs by c's lag: the samples need no copy. The friction law
  // is chosen on the probe's bands as on the estimate's.
  const auto [status, estimate] = for_method(method, [&](auto* type) {
    auto run = solve_core<std::remove_pointer_t<decltype(type)>>(s, c, method);
    if (run.status == feedid::Status::ok) (void)select_friction_models(*run.core, run.estimate);
    return std::make_pair(run.status, run.estimate);
  });
  if (status != feedid::Status::ok) return out;
  const auto at = parameters(estimate);
  for (int i = 0; i < 9; ++i) out[i] = std::fabs(at[i] - theta[i]) / kTimingProbeStep * lag_uncertainty;
  return out;
}

}  // namespace

double timing_probe_lag(const Signals& s) {
  return s.force_lag_samples >= -feedid::ForcePairing<double>::max_lead + kTimingProbeStep
             ? s.force_lag_samples - kTimingProbeStep
             : s.force_lag_samples + kTimingProbeStep;
}

std::array<double, 9> standard_errors(const feedid::Estimate<double>& e) {
  return {e.mass_se_kg, e.pos.viscous_se, e.pos.coulomb_se, e.pos.breakaway_se, e.pos.stribeck_velocity_se,
          e.neg.viscous_se, e.neg.coulomb_se, e.neg.breakaway_se, e.neg.stribeck_velocity_se};
}

std::array<double, 9> parameters(const feedid::Estimate<double>& e) {
  return {e.mass_kg, e.pos.viscous_Ns_m, e.pos.coulomb_N, e.pos.breakaway_N, e.pos.stribeck_velocity_m_s,
          e.neg.viscous_Ns_m, e.neg.coulomb_N, e.neg.breakaway_N, e.neg.stribeck_velocity_m_s};
}

std::array<bool, 2> refitted_directions(const IdentifyResult& r) {
  return {r.friction_model[0].refitted, r.friction_model[1].refitted};
}

Uncertainty widen_standard_errors(IdentifyResult& r, const IdentifyOptions& opt) {
  Uncertainty u;
  u.model_se = standard_errors(r.estimate);
  const Signals& s = r.signals;
  u.chunks_used = jackknife(s, r.config, opt.method, u.jackknife_se, refitted_directions(r));
  u.timing_se = timing_standard_errors(s, r.config, opt.method, parameters(r.estimate), r.lag_se_periods);
  u.cutoff_se = cutoff_standard_errors(s, r.config, opt.method, parameters(r.estimate), refitted_directions(r));
  apply_standard_errors(r.estimate, u);
  return u;
}

std::array<double, 9> timing_standard_errors(const Signals& s, const feedid::Config<double>& cfg, feedid::Method method,
                                             const std::array<double, 9>& theta, double& lag_se_periods) {
  const double dt = s.period_s();
  // A stated lag with a standard error was estimated on another stretch of the log.
  const bool estimated = s.force_lag_origin == Signals::LagOrigin::estimated || s.force_lag_se_s > 0;
  lag_se_periods = estimated ? std::hypot(s.force_lag_se_s / dt, kLagAccuracy) : 0.0;
  return timing_se(s, cfg, method, theta, lag_se_periods);
}

std::array<double, 9> cutoff_standard_errors(const Signals& s, const feedid::Config<double>& cfg, feedid::Method method,
                                             const std::array<double, 9>& theta, const std::array<bool, 2>& refitted) {
  std::array<double, 9> out{};
  int used = 0;
  Signals rival;  // one copy, its velocity each rival's in turn
  if (!s.rival_velocities.empty()) rival = s;
  for (const std::vector<double>& v : s.rival_velocities) {
    rival.v = v;
    // The law chosen on the data, refitted below as the jackknife does.
    const auto [ok, at] = for_method(method, [&](auto* type) {
      auto run = solve_core<std::remove_pointer_t<decltype(type)>>(rival, cfg, method);
      bool fits = run.status == feedid::Status::ok;
      for (int d = 0; d < 2 && fits; ++d)
        if (refitted[static_cast<std::size_t>(d)])
          fits = refit_coulomb_viscous(run.core->statistics(), d, run.estimate.mass_kg,
                                       d == 0 ? run.estimate.pos : run.estimate.neg);
      return std::make_pair(fits, parameters(run.estimate));
    });
    if (!ok) continue;
    for (std::size_t i = 0; i < out.size(); ++i) out[i] += (at[i] - theta[i]) * (at[i] - theta[i]);
    ++used;
  }
  for (double& x : out) x = used > 0 ? std::sqrt(x / used) : 0.0;
  return out;
}

void apply_standard_errors(feedid::Estimate<double>& e, const Uncertainty& u) {
  const auto f = se_fields(e);
  const std::array<bool, 9> resolved = {e.mass_identified(),
                                        e.pos.viscous_identified(), e.pos.friction_identified(),
                                        e.pos.stribeck_identified(), e.pos.stribeck_identified(),
                                        e.neg.viscous_identified(), e.neg.friction_identified(),
                                        e.neg.stribeck_identified(), e.neg.stribeck_identified()};
  for (int i = 0; i < 9; ++i) {
    const double widened = std::hypot(u.chunks_used > 0 ? u.jackknife_se[i] : u.model_se[i], u.timing_se[i], u.cutoff_se[i]);
    // What the core could not resolve keeps its own (huge) standard error.
    *f[i] = resolved[i] ? widened : std::max(widened, u.model_se[i]);
  }
  for (auto* d : {&e.pos, &e.neg}) {
    // Fc's and sigma's rule on their widened standard errors, whatever the core's said.
    if (d->friction_identified())
      d->flags = (d->flags & ~static_cast<uint32_t>(feedid::flag_coulomb_uncertain | feedid::flag_viscous_uncertain)) |
                 feedid::analysis::coulomb_uncertainty_flags(*d) | feedid::analysis::viscous_uncertainty_flags(*d);
    if (d->flags & feedid::flag_stribeck_uncertain) continue;
    d->flags |= feedid::analysis::stribeck_uncertainty_flags(*d);
  }
  if (e.mass_identified()) e.mass_flags |= feedid::analysis::mass_uncertainty_flags(e.mass_kg, e.mass_se_kg);
}

}  // namespace feedid::host
