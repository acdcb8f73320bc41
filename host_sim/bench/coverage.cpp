#include "coverage.hpp"
#include "io/output_file.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "baselines.hpp"
#include "sim/drive_sim.hpp"
#include "identify/identify.hpp"

namespace feedid::host {
namespace {

/// The drives of the Monte Carlo: mass, rate and encoder spread over the
/// range the identifier promises (20-400 kg, 1-8 kHz, 20-100 nm).
struct DriveCase {
  const char* name;
  double mass_kg, rate_hz, encoder_m;
};
constexpr DriveCase kDrives[] = {
    {"20 kg, 1 kHz, 20 nm", 20.0, 1000.0, 20e-9},
    {"100 kg, 2 kHz, 50 nm", 100.0, 2000.0, 50e-9},
    {"400 kg, 4 kHz, 100 nm", 400.0, 4000.0, 100e-9},
    {"100 kg, 8 kHz, 100 nm", 100.0, 8000.0, 100e-9},
};
constexpr ForceLog kForceLogs[] = {ForceLog::held, ForceLog::instant, ForceLog::averaged};

/// One trace's outcome: per parameter the error, the standard error and
/// whether the tool called it identifiable.
struct CaseOutcome {
  int drive = 0, force = 0;
  std::string velocity;   ///< how velocity was logged
  bool position = true;   ///< position column given to identify
  bool ok = false;
  ParamVector err{}, se{}, lm_err{};
  std::array<bool, 9> identified{};
  bool lm = false;
};

SimConfig case_config(const DriveCase& d, ForceLog f, std::uint64_t seed, double duration_s) {
  SimConfig c;
  c.drive.mass_kg = d.mass_kg;
  c.controller.servo_rate_hz = d.rate_hz;
  c.sensors.encoder_resolution_m = d.encoder_m;
  c.motion.duration_s = duration_s;
  c.seed = seed;
  c.logging.force = f;
  // The velocity filter cycles with the seed: none, a moving average, a low-pass.
  switch (seed % 3) {
    case 0: c.logging.velocity = VelocityLog::backward_difference; break;
    case 1:
      c.logging.velocity = VelocityLog::moving_average;
      c.logging.velocity_average_samples = 2 + static_cast<int>(seed / 3 % 3);
      break;
    default:
      c.logging.velocity = VelocityLog::low_pass;
      c.logging.velocity_time_constant_s = (0.5 + 0.5 * static_cast<double>(seed / 3 % 3)) / d.rate_hz;
  }
  return c;
}

std::string velocity_label(const LoggingParams& l) {
  std::ostringstream o;
  switch (l.velocity) {
    case VelocityLog::backward_difference: o << "difference"; break;
    case VelocityLog::moving_average: o << "average " << l.velocity_average_samples; break;
    case VelocityLog::low_pass: o << "low-pass"; break;
  }
  return o.str();
}

std::array<bool, 9> identified_of(const feedid::Estimate<double>& e) {
  std::array<bool, 9> id{};
  id[0] = e.mass_identified();
  for (int d = 0; d < 2; ++d) {
    const auto& de = d == 0 ? e.pos : e.neg;
    id[1 + 4 * d] = de.viscous_identified();
    id[2 + 4 * d] = de.friction_identified();
    id[3 + 4 * d] = id[4 + 4 * d] = de.stribeck_identified();
  }
  return id;
}

ParamVector se_of(const feedid::Estimate<double>& e) {
  return {e.mass_se_kg, e.pos.viscous_se, e.pos.coulomb_se, e.pos.breakaway_se, e.pos.stribeck_velocity_se,
          e.neg.viscous_se, e.neg.coulomb_se, e.neg.breakaway_se, e.neg.stribeck_velocity_se};
}

CaseOutcome run_case(int drive, int force, std::uint64_t seed, const CoverageOptions& opt, bool with_lm) {
  CaseOutcome o;
  o.drive = drive;
  o.force = force;
  const SimConfig cfg = case_config(kDrives[drive], kForceLogs[force], seed, opt.duration_s);
  o.velocity = velocity_label(cfg.logging);
  Trace t = simulate(cfg);
  // Every fourth trace is a velocity-only log, as many drives write.
  o.position = seed % 4 != 3;
  t.has_position = o.position;
  const IdentifyResult r = identify(t, IdentifyOptions{});
  if (!r.error.empty() || r.status != feedid::Status::ok) return o;
  o.ok = true;
  const ParamVector est = param_vector(to_drive_params(r.estimate)), truth = param_vector(cfg.drive);
  o.se = se_of(r.estimate);
  o.identified = identified_of(r.estimate);
  for (int i = 0; i < 9; ++i) o.err[i] = est[i] - truth[i];
  if (with_lm) {
    const BaselineResult lm = batch_lm(t, BaselineOptions{});
    if (lm.ok) {
      o.lm = true;
      const ParamVector p = param_vector(lm.params);
      for (int i = 0; i < 9; ++i) o.lm_err[i] = p[i] - truth[i];
    }
  }
  return o;
}

/// Coverage and efficiency of one parameter over a set of outcomes.
struct ParamStats {
  int identified = 0, covered = 0, flagged = 0;
  double sum_err2 = 0.0, sum_z2 = 0.0;  // over identified
  int lm_n = 0;
  double core_err2_lm = 0.0, lm_err2 = 0.0;  // over traces where LM ran (all, flagged or not)
  double coverage() const { return identified > 0 ? double(covered) / identified : 0.0; }
  double rms_z() const { return identified > 0 ? std::sqrt(sum_z2 / identified) : 0.0; }
  double rmse_ratio() const { return lm_n > 0 && lm_err2 > 0 ? std::sqrt(core_err2_lm / lm_err2) : 0.0; }
};

std::array<ParamStats, 9> tally(const std::vector<CaseOutcome>& v, const std::function<bool(const CaseOutcome&)>& keep) {
  std::array<ParamStats, 9> s{};
  for (const CaseOutcome& o : v) {
    if (!o.ok || !keep(o)) continue;
    for (int i = 0; i < 9; ++i) {
      ParamStats& p = s[i];
      if (o.lm) {
        ++p.lm_n;
        p.core_err2_lm += o.err[i] * o.err[i];
        p.lm_err2 += o.lm_err[i] * o.lm_err[i];
      }
      if (!o.identified[i]) { ++p.flagged; continue; }
      ++p.identified;
      const double z = o.se[i] > 0 ? o.err[i] / o.se[i] : INFINITY;
      if (std::fabs(z) <= 1.96) ++p.covered;
      p.sum_z2 += std::isfinite(z) ? z * z : 1e6;
      p.sum_err2 += o.err[i] * o.err[i];
    }
  }
  return s;
}

std::string pct(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f %%", 100.0 * x);
  return b;
}

std::string markdown(const std::vector<CaseOutcome>& all, const CoverageOptions& opt, int failed) {
  std::ostringstream o;
  const auto total = tally(all, [](const CaseOutcome&) { return true; });
  o << "| parameter | identified | flagged | 95 % coverage | RMS of err/se | RMSE core / LM (" << total[0].lm_n
    << " traces) |\n|---|---|---|---|---|---|\n";
  for (int i = 0; i < 9; ++i) {
    const ParamStats& p = total[i];
    char ratio[32];
    std::snprintf(ratio, sizeof ratio, "%.2f", p.rmse_ratio());
    char rz[32];
    std::snprintf(rz, sizeof rz, "%.2f", p.rms_z());
    o << "| " << kParamNames[i] << " | " << p.identified << " | " << p.flagged << " | " << pct(p.coverage()) << " | "
      << rz << " | " << (p.lm_n > 0 ? ratio : "–") << " |\n";
  }
  o << "\nWorst parameter's coverage per drive and force convention (identified parameters only):\n\n| drive |";
  for (ForceLog f : kForceLogs) o << " " << force_log_name(f) << " |";
  o << "\n|---|---|---|---|\n";
  for (int d = 0; d < static_cast<int>(std::size(kDrives)); ++d) {
    o << "| " << kDrives[d].name << " |";
    for (int f = 0; f < 3; ++f) {
      const auto s = tally(all, [&](const CaseOutcome& x) { return x.drive == d && x.force == f; });
      double worst = 1.0;
      int worst_i = 0;
      for (int i = 0; i < 9; ++i)
        if (s[i].identified >= 5 && s[i].coverage() < worst) { worst = s[i].coverage(); worst_i = i; }
      o << " " << pct(worst) << " (" << kParamNames[worst_i] << ") |";
    }
    o << "\n";
  }
  o << "\n" << all.size() << " traces (" << opt.seeds << " seeds x " << std::size(kDrives) << " drives x 3 force logs, "
    << opt.duration_s << " s each); " << failed << " could not be identified.\n";
  return o.str();
}

}  // namespace

RunEnd run_coverage(const CoverageOptions& opt) {
  std::vector<std::array<int, 3>> jobs;  // drive, force, seed index
  for (int d = 0; d < static_cast<int>(std::size(kDrives)); ++d)
    for (int f = 0; f < 3; ++f)
      for (int s = 0; s < opt.seeds; ++s) jobs.push_back({d, f, s});
  // Every case's simulation is checked here (--duration), so that none
  // throws inside a worker thread.
  for (const auto& [d, f, s] : jobs) {
    const std::string why = sim_config_error(
        case_config(kDrives[d], kForceLogs[f], opt.first_seed + static_cast<std::uint64_t>(s), opt.duration_s));
    if (!why.empty()) return RunEnd::refused(why);
  }
  std::vector<CaseOutcome> out(jobs.size());
  std::atomic<std::size_t> next{0}, done{0};
  std::mutex progress_lock;
  auto worker = [&]() {
    for (std::size_t j; (j = next++) < jobs.size();) {
      const auto [d, f, s] = jobs[j];
      const bool lm = opt.lm_every > 0 && s % opt.lm_every == 0;
      out[j] = run_case(d, f, opt.first_seed + static_cast<std::uint64_t>(s), opt, lm);
      const std::size_t n = ++done;
      if (opt.progress) {
        std::lock_guard<std::mutex> g(progress_lock);
        opt.progress(static_cast<double>(n) / static_cast<double>(jobs.size()));
      }
    }
  };
  std::vector<std::thread> pool;
  for (int i = 0; i < std::max(1, opt.threads); ++i) pool.emplace_back(worker);
  for (auto& th : pool) th.join();

  const int failed = static_cast<int>(std::count_if(out.begin(), out.end(), [](const CaseOutcome& o) { return !o.ok; }));
  const std::string md = markdown(out, opt, failed);
  std::fputs(md.c_str(), stdout);
  RunEnd end;
  if (!opt.markdown_path.empty()) end.written(write_whole_file(opt.markdown_path, md));
  if (!opt.json_path.empty()) {
    nlohmann::json j = nlohmann::json::array();
    for (const CaseOutcome& o : out) {
      if (!o.ok) { j.push_back({{"ok", false}}); continue; }
      j.push_back({{"ok", true}, {"drive", kDrives[o.drive].name}, {"force_log", force_log_name(kForceLogs[o.force])},
                   {"velocity_log", o.velocity}, {"position", o.position}, {"err", o.err}, {"se", o.se},
                   {"identified", o.identified}, {"lm", o.lm}, {"lm_err", o.lm_err}});
    }
    end.written(write_whole_file(opt.json_path, j.dump(1) + "\n"));
  }
  return end;
}

}  // namespace feedid::host
