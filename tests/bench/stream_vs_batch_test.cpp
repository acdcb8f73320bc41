// The streaming core against an independent batch recomputation of the same
// method on the same data (host_sim/bench/batch_reference.hpp): every sufficient
// statistic, the diagnostics counters and both estimates must agree to
// rounding. The solver is shared; what is checked is the bookkeeping.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "bench/batch_reference.hpp"
#include "sim/drive_sim.hpp"
#include "feedid/feedid.hpp"

namespace {

using feedid::Config;
using feedid::Diagnostics;
using feedid::Estimate;
using feedid::Method;
using feedid::Sample;
using feedid::Status;
using feedid::Sum;
using Core = feedid::Estimator<double>;
using Stats = feedid::host::BatchStatistics;

constexpr double kRel = 1e-9;      // relative agreement of sums and estimates
constexpr double kMagRel = 1e-12;  // absolute agreement, relative to the sum of |terms|

struct Trace {
  std::vector<double> t, x, v, u;
};

Trace simulated(double rate_hz, double encoder_m, double duration_s, std::uint64_t seed, double dwell_s = 0.15) {
  feedid::host::SimConfig sc;
  sc.motion.dwell_s = dwell_s;
  sc.controller.servo_rate_hz = rate_hz;
  sc.sensors.encoder_resolution_m = encoder_m;
  sc.motion.duration_s = duration_s;
  sc.seed = seed;
  const feedid::host::Trace tr = feedid::host::simulate(sc);
  Trace out;
  for (const auto& s : tr.samples) {
    out.t.push_back(s.t_s);
    out.x.push_back(s.x_m);
    out.v.push_back(s.v_m_s);
    out.u.push_back(s.u_N);
  }
  return out;
}

/// Samples as a host feeds the core: dt from consecutive time stamps.
std::vector<Sample<double>> to_samples(const Trace& tr) {
  std::vector<Sample<double>> out(tr.t.size());
  for (std::size_t k = 0; k < tr.t.size(); ++k) {
    out[k].dt_s = k == 0 ? 0.0 : tr.t[k] - tr.t[k - 1];
    out[k].position_m = tr.x[k];
    out[k].velocity_m_s = tr.v[k];
    out[k].force_N = tr.u[k];
  }
  return out;
}

Config<double> config_for(double encoder_m, double rate_hz) {
  Config<double> c;
  const double res = encoder_m * rate_hz;
  c.velocity_min_m_s = std::max(2.0 * res, 1e-5);
  c.velocity_max_m_s = 0.2;
  c.velocity_resolution_m_s = res;
  return c;
}

struct StreamResult {
  Stats stats{};
  Diagnostics diag{};
  Estimate<double> bands{}, paper{};
  Status bands_status{}, paper_status{};
  std::vector<Status> verdicts;
};

StreamResult run_stream(const std::vector<Sample<double>>& samples, const Config<double>& cfg) {
  auto core = std::make_unique<Core>();
  EXPECT_EQ(core->init(cfg), Status::ok) << core->config_error();
  StreamResult r;
  r.verdicts.reserve(samples.size());
  for (const auto& s : samples) r.verdicts.push_back(core->push(s));
  r.bands_status = core->solve(Method::bands);
  r.stats = core->statistics();
  r.diag = core->diagnostics();  // before a second solve() adds its own two folds
  r.bands = core->estimate();
  r.paper_status = core->solve(Method::paper);
  r.paper = core->estimate();
  return r;
}

std::string where(const char* what, int d = -1, int j = -1) {
  std::ostringstream o;
  o << what;
  if (d >= 0) o << " dir " << d;
  if (j >= 0) o << " [" << j << "]";
  return o.str();
}

struct Checker {
  int compared = 0;
  double max_rel = 0.0;    // largest relative difference of any sum
  double worst_rel = 0.0;  // largest among those beyond the magnitude floor
  double max_rel_estimate = 0.0;
  std::string worst_name;

  void sum(const Sum<double>& stream, const Sum<double>& batch, const Sum<double>& magnitude,
           const std::string& name) {
    const double a = stream.get(), b = batch.get(), m = magnitude.get();
    const double diff = std::fabs(a - b);
    const double scale = std::max(std::fabs(a), std::fabs(b));
    ++compared;
    if (scale > 0) max_rel = std::max(max_rel, diff / scale);
    if (scale > 0 && diff / scale > worst_rel && diff > kMagRel * m) { worst_rel = diff / scale; worst_name = name; }
    EXPECT_TRUE(diff <= kRel * scale || diff <= kMagRel * m)
        << name << ": stream " << a << " batch " << b << " (diff " << diff << ", magnitude " << m << ")";
  }

  void value(double a, double b, const std::string& name, double abs_floor = 0.0) {
    const double diff = std::fabs(a - b);
    const double scale = std::max(std::fabs(a), std::fabs(b));
    ++compared;
    if (scale > 0) max_rel_estimate = std::max(max_rel_estimate, diff / scale);
    EXPECT_TRUE(diff <= kRel * scale || diff <= abs_floor || (std::isnan(a) && std::isnan(b)))
        << name << ": stream " << a << " batch " << b << " (rel " << (scale > 0 ? diff / scale : 0.0) << ")";
  }
};

void compare_statistics(const Stats& s, const feedid::host::BatchResult& b, Checker& ck) {
  const Stats& v = b.stats;
  const Stats& m = b.magnitude;
  for (int d = 0; d < 2; ++d) {
    for (int j = 0; j < 32; ++j) {
      const auto &x = s.band[d][j], &y = v.band[d][j], &z = m.band[d][j];
      ck.sum(x.time_s, y.time_s, z.time_s, where("band.time", d, j));
      ck.sum(x.speed, y.speed, z.speed, where("band.speed", d, j));
      ck.sum(x.speed2, y.speed2, z.speed2, where("band.speed2", d, j));
      ck.sum(x.force, y.force, z.force, where("band.force", d, j));
      ck.sum(x.dvel, y.dvel, z.dvel, where("band.dvel", d, j));
      ck.sum(x.proj_time, y.proj_time, z.proj_time, where("band.proj_time", d, j));
      ck.sum(x.proj_speed, y.proj_speed, z.proj_speed, where("band.proj_speed", d, j));
      ck.sum(x.proj_speed2, y.proj_speed2, z.proj_speed2, where("band.proj_speed2", d, j));
    }
    const auto &x = s.dir[d], &y = v.dir[d], &z = m.dir[d];
    EXPECT_EQ(x.sections, y.sections) << "dir " << d;
    ck.sum(x.win_dv_force, y.win_dv_force, z.win_dv_force, where("win_dv_force", d));
    ck.sum(x.win_dv2, y.win_dv2, z.win_dv2, where("win_dv2", d));
    ck.sum(x.win_tau_dv2, y.win_tau_dv2, z.win_tau_dv2, where("win_tau_dv2", d));
    ck.sum(x.sec_xy, y.sec_xy, z.sec_xy, where("sec_xy", d));
    ck.sum(x.sec_xx, y.sec_xx, z.sec_xx, where("sec_xx", d));
    ck.sum(x.sec_yy, y.sec_yy, z.sec_yy, where("sec_yy", d));
    ck.sum(x.sec_tt, y.sec_tt, z.sec_tt, where("sec_tt", d));
    ck.sum(x.sec_tv, y.sec_tv, z.sec_tv, where("sec_tv", d));
    ck.sum(x.sec_vv, y.sec_vv, z.sec_vv, where("sec_vv", d));
    ck.sum(x.sec_tu, y.sec_tu, z.sec_tu, where("sec_tu", d));
    ck.sum(x.sec_vu, y.sec_vu, z.sec_vu, where("sec_vu", d));
    ck.sum(x.sec_uu, y.sec_uu, z.sec_uu, where("sec_uu", d));
    for (int i = 0; i < 16; ++i) {
      ck.sum(x.cand_et[i], y.cand_et[i], z.cand_et[i], where("cand_et", d, i));
      ck.sum(x.cand_ev[i], y.cand_ev[i], z.cand_ev[i], where("cand_ev", d, i));
      ck.sum(x.cand_eu[i], y.cand_eu[i], z.cand_eu[i], where("cand_eu", d, i));
      ck.sum(x.cand_ee[i], y.cand_ee[i], z.cand_ee[i], where("cand_ee", d, i));
    }
  }
  ck.sum(s.noise_d2, v.noise_d2, m.noise_d2, "noise_d2");
  ck.sum(s.total_interval_time, v.total_interval_time, m.total_interval_time, "total_interval_time");
  EXPECT_EQ(s.noise_count, v.noise_count);
  EXPECT_EQ(s.interval_count, v.interval_count);
  for (int i = 0; i < 16; ++i) EXPECT_EQ(s.vs_candidate[i], v.vs_candidate[i]) << i;
}

void compare_diagnostics(const Diagnostics& a, const Diagnostics& b) {
  EXPECT_EQ(a.samples_accepted, b.samples_accepted);
  EXPECT_EQ(a.samples_rejected, b.samples_rejected);
  EXPECT_EQ(a.rejected_not_finite, b.rejected_not_finite);
  EXPECT_EQ(a.rejected_time_not_increasing, b.rejected_time_not_increasing);
  EXPECT_EQ(a.rejected_out_of_range, b.rejected_out_of_range);
  EXPECT_EQ(a.rejected_velocity_jump, b.rejected_velocity_jump);
  EXPECT_EQ(a.continuity_breaks, b.continuity_breaks);
  EXPECT_EQ(a.sections_complete[0], b.sections_complete[0]);
  EXPECT_EQ(a.sections_complete[1], b.sections_complete[1]);
  EXPECT_EQ(a.sections_short, b.sections_short);
  EXPECT_EQ(a.sections_split, b.sections_split);
  EXPECT_EQ(a.mass_windows, b.mass_windows);
  EXPECT_EQ(a.folds, b.folds);
}

void compare_direction(const feedid::DirectionEstimate<double>& a, const feedid::DirectionEstimate<double>& b,
                       const std::string& name, Checker& ck) {
  ck.value(a.viscous_Ns_m, b.viscous_Ns_m, name + ".sigma");
  ck.value(a.coulomb_N, b.coulomb_N, name + ".fc");
  ck.value(a.breakaway_N, b.breakaway_N, name + ".fs");
  ck.value(a.stribeck_velocity_m_s, b.stribeck_velocity_m_s, name + ".vs");
  ck.value(a.viscous_se, b.viscous_se, name + ".sigma_se");
  ck.value(a.coulomb_se, b.coulomb_se, name + ".fc_se");
  ck.value(a.breakaway_se, b.breakaway_se, name + ".fs_se");
  ck.value(a.stribeck_velocity_se, b.stribeck_velocity_se, name + ".vs_se");
  ck.value(a.friction_r2, b.friction_r2, name + ".r2", 1e-12);
  ck.value(a.friction_rms_N, b.friction_rms_N, name + ".rms");
  ck.value(a.time_in_bands_s, b.time_in_bands_s, name + ".time_in_bands");
  EXPECT_EQ(a.bands_used, b.bands_used) << name;
  EXPECT_EQ(a.sections, b.sections) << name;
  EXPECT_EQ(a.flags, b.flags) << name;
}

void compare_estimates(const Estimate<double>& a, const Estimate<double>& b, const std::string& name, Checker& ck) {
  EXPECT_EQ(a.method, b.method) << name;
  ck.value(a.mass_kg, b.mass_kg, name + ".m");
  ck.value(a.mass_se_kg, b.mass_se_kg, name + ".m_se");
  EXPECT_EQ(a.mass_flags, b.mass_flags) << name;
  ck.value(a.force_noise_N, b.force_noise_N, name + ".force_noise");
  compare_direction(a.pos, b.pos, name + ".pos", ck);
  compare_direction(a.neg, b.neg, name + ".neg", ck);
}

/// Streams, recomputes in batch, compares everything; returns the stream's result for case-specific checks.
StreamResult check_case(const std::vector<Sample<double>>& samples, const Config<double>& cfg) {
  const StreamResult st = run_stream(samples, cfg);
  const feedid::host::BatchResult b = feedid::host::batch_compute(samples, cfg);
  Checker ck;
  compare_statistics(st.stats, b, ck);
  compare_diagnostics(st.diag, b.diagnostics);

  Status bs{}, ps{};
  const Estimate<double> eb = feedid::host::batch_estimate(samples, cfg, Method::bands, &bs);
  const Estimate<double> ep = feedid::host::batch_estimate(samples, cfg, Method::paper, &ps);
  EXPECT_EQ(st.bands_status, bs);
  EXPECT_EQ(st.paper_status, ps);
  compare_estimates(st.bands, eb, "bands", ck);
  compare_estimates(st.paper, ep, "paper", ck);

  // The thin wrapper agrees with the detailed one.
  Diagnostics d2;
  const Stats s2 = feedid::host::batch_statistics(samples, cfg, &d2);
  EXPECT_EQ(d2.folds, b.diagnostics.folds);
  EXPECT_EQ(s2.band[0][10].time_s.get(), b.stats.band[0][10].time_s.get());

  const Diagnostics& g = st.diag;
  std::printf("    accepted %llu rejected %llu breaks %u sections +%u -%u short %u split %u windows %u folds %u\n"
              "    %d values compared; sums: max relative difference %.2e, beyond the magnitude floor %.2e (%s)\n"
              "    estimates: max relative difference %.2e; bands: m %.4f  paper: m %.4f sections %u/%u\n",
              static_cast<unsigned long long>(g.samples_accepted), static_cast<unsigned long long>(g.samples_rejected),
              g.continuity_breaks, g.sections_complete[0], g.sections_complete[1], g.sections_short, g.sections_split,
              g.mass_windows, g.folds, ck.compared, ck.max_rel, ck.worst_rel, ck.worst_name.empty() ? "-" : ck.worst_name.c_str(),
              ck.max_rel_estimate, st.bands.mass_kg, st.paper.mass_kg, st.paper.pos.sections, st.paper.neg.sections);
  return st;
}

const Trace& trace_2khz() {
  static const Trace t = simulated(2000.0, 1e-8, 60.0, 1);
  return t;
}

const Trace& trace_1khz() {
  static const Trace t = simulated(1000.0, 1e-7, 60.0, 7);
  return t;
}

/// The 1 kHz trace with faults a real log has: NaN and Inf values, an
/// out-of-range sample, a repeated time stamp, a velocity spike and a gap.
std::vector<Sample<double>> faulty_1khz() {
  Trace tr = trace_1khz();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 1500; k < tr.t.size(); k += 2311) {  // scattered, also inside motion
    if ((k / 2311) % 2 == 0) tr.v[k] = nan;
    else tr.u[k] = nan;
  }
  tr.v[3001] = tr.v[3002] = nan;                 // two in a row
  tr.u[9000] = std::numeric_limits<double>::infinity();
  tr.v[12345] = 50.0;                            // beyond max_speed_m_s
  tr.v[20000] += 0.5;                            // a spike: velocity jump
  // 0.25 s lost in the middle of a stroke: a continuity break with a section open.
  std::size_t gap = 30000;
  while (std::fabs(tr.v[gap]) < 0.01) ++gap;
  for (auto* col : {&tr.t, &tr.x, &tr.v, &tr.u})
    col->erase(col->begin() + static_cast<std::ptrdiff_t>(gap), col->begin() + static_cast<std::ptrdiff_t>(gap + 250));
  std::vector<Sample<double>> s = to_samples(tr);
  s[15000].dt_s = 0.0;                           // repeated time stamp
  return s;
}

TEST(StreamVsBatch, Simulated2kHz) {
  const auto samples = to_samples(trace_2khz());
  const Config<double> cfg = config_for(1e-8, 2000.0);
  const StreamResult st = check_case(samples, cfg);
  EXPECT_EQ(st.diag.samples_rejected, 0u);
  EXPECT_GT(st.diag.sections_complete[0] + st.diag.sections_complete[1], 10u);
  EXPECT_GT(st.diag.mass_windows, 100u);
  EXPECT_EQ(st.bands_status, Status::ok);
}

TEST(StreamVsBatch, Simulated1kHzCoarseEncoderWithRejections) {
  const auto samples = faulty_1khz();
  const Config<double> cfg = config_for(1e-7, 1000.0);
  const StreamResult st = check_case(samples, cfg);
  EXPECT_GE(st.diag.rejected_not_finite, 20u);
  EXPECT_GE(st.diag.rejected_out_of_range, 1u);
  EXPECT_GE(st.diag.rejected_time_not_increasing, 1u);
  EXPECT_GE(st.diag.rejected_velocity_jump, 1u);
  EXPECT_EQ(st.diag.continuity_breaks, 1u);
  EXPECT_GE(st.diag.sections_split, 2u);  // the one open at the gap, the one open at the end
  EXPECT_GT(st.diag.sections_complete[0] + st.diag.sections_complete[1], 10u);
}

// Short fold periods split sections (max_fold_s), other pairing rules, a
// longer rest rule and a longer minimum section: the fold timing decides
// which sections count for the paper method.
TEST(StreamVsBatch, ShortFoldsTrapezoidAndInstantPairing) {
  const auto samples = to_samples(trace_2khz());
  Config<double> cfg = config_for(1e-8, 2000.0);
  cfg.max_fold_s = 0.3;
  cfg.rest_samples = 5;
  cfg.min_section_s = 0.1;
  cfg.force_lag_samples = feedid::force_lag_of<double>(feedid::ForceAlignment::trapezoid);
  const StreamResult st = check_case(samples, cfg);
  EXPECT_GT(st.diag.sections_split, 5u);

  cfg.force_lag_samples = feedid::force_lag_of<double>(feedid::ForceAlignment::held_force_instant_velocity);
  cfg.max_fold_s = 1.0;
  cfg.mass_window_s = 0.05;
  check_case(samples, cfg);
}

// No dwell between strokes: the velocity crosses zero within a sample or
// two, so sections end at a reversal beyond section_enter, not at rest.
TEST(StreamVsBatch, DirectReversals) {
  const auto samples = to_samples(simulated(2000.0, 1e-8, 30.0, 3, 0.0));
  const Config<double> cfg = config_for(1e-8, 2000.0);
  const StreamResult st = check_case(samples, cfg);
  EXPECT_GT(st.diag.sections_complete[0] + st.diag.sections_complete[1], 10u);
}

// A filtered velocity makes the force lead it by a fractional number of
// periods: the three-tap pairing reaches four samples back.
TEST(StreamVsBatch, FractionalForceLead) {
  const auto samples = to_samples(simulated(2000.0, 1e-8, 30.0, 3, 0.1));
  Config<double> cfg = config_for(1e-8, 2000.0);
  cfg.force_lag_samples = -2.3;
  check_case(samples, cfg);
}

TEST(StreamVsBatch, VelocityFromPositionWithRejections) {
  const auto samples = faulty_1khz();
  Config<double> cfg = config_for(1e-7, 1000.0);
  cfg.velocity_source = feedid::VelocitySource::from_position;
  cfg.force_lag_samples = feedid::force_lag_of<double>(feedid::ForceAlignment::held_force_instant_velocity);
  check_case(samples, cfg);
}

}  // namespace
