// feedid bench: see bench.hpp and docs/benchmarks.md.
#include "bench.hpp"
#include "io/output_file.hpp"

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "baselines.hpp"
#include "feedid/footprint_budget.hpp"
#include "io/csv_trace.hpp"
#include "diagnose/diagnose.hpp"
#include "sim/drive_sim.hpp"
#include "identify/identify.hpp"
#include "io/progress.hpp"
#include "io/svg_plot.hpp"

namespace feedid::host {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

const char* const kAllMethods[] = {"streaming", "batch_lm", "ga", "rls"};

// ---------------------------------------------------------------------------
// Drives and traces
// ---------------------------------------------------------------------------

struct Case {
  std::string name;  ///< e.g. "default/s1/60s"
  std::string drive;
  SimConfig sim;
};

SimConfig drive_config(const std::string& drive, std::uint64_t seed, double duration_s) {
  SimConfig c;
  c.seed = seed;
  c.motion.duration_s = duration_s;
  if (drive == "heavy") {
    // A 400 kg table on a 1 kHz drive with stronger friction and force noise.
    c.drive.mass_kg = 400.0;
    c.drive.pos = DirectionFriction{1500.0, 60.0, 20.0, 4.0e-3};
    c.drive.neg = DirectionFriction{1600.0, 65.0, 24.0, 3.0e-3};
    c.controller.servo_rate_hz = 1000.0;
    c.sensors.force_noise_N = 2.0;
  } else if (drive == "paper") {
    // The seed paper's identified testbed (Table 1, proposed method): vs of
    // 1.4e-4 m/s, 14 velocity quanta at 1 kHz with a 10 nm encoder.
    c.drive.mass_kg = 98.99;
    c.drive.pos = DirectionFriction{705.05, 25.79, 7.48, 1.44e-4};
    c.drive.neg = DirectionFriction{759.82, 26.96, 7.59, 1.43e-4};
    c.controller.servo_rate_hz = 1000.0;
    c.motion.slowest_speed_m_s = 5.0e-5;
  }  // "default": the simulator's defaults (100 kg, 2 kHz)
  return c;
}

std::vector<Case> default_cases(bool quick) {
  std::vector<Case> cs;
  auto add = [&](const std::string& drive, std::uint64_t seed, double dur) {
    char b[64];
    std::snprintf(b, sizeof b, "%s/s%llu/%gs", drive.c_str(), static_cast<unsigned long long>(seed), dur);
    cs.push_back({b, drive, drive_config(drive, seed, dur)});
  };
  if (quick) {
    add("default", 1, 30);
    add("heavy", 1, 30);
    return cs;
  }
  for (const char* d : {"default", "heavy", "paper"})
    for (std::uint64_t s : {1, 2}) add(d, s, 60);
  add("default", 3, 20);
  add("default", 3, 180);
  return cs;
}

// ---------------------------------------------------------------------------
// Measuring
// ---------------------------------------------------------------------------

/// Peak resident memory of a stretch of code: returns freed heap to the OS,
/// resets the kernel's high-water mark (/proc/self/clear_refs, Linux >= 4.0)
/// and reads VmHWM afterwards. Reports -1 where that is not available.
class RssProbe {
 public:
  void start() {
    malloc_trim(0);
    std::ofstream f("/proc/self/clear_refs");
    f << "5";
    f.close();
    ok_ = static_cast<bool>(f);
    base_kb_ = status_kb("VmRSS:");
  }
  long long peak_increase_bytes() const {
    if (!ok_ || base_kb_ < 0) return -1;
    const long long hwm = status_kb("VmHWM:");
    return hwm < 0 ? -1 : std::max(0LL, hwm - base_kb_) * 1024;
  }
  static long long status_kb(const char* key) {
    std::ifstream f("/proc/self/status");
    std::string line;
    while (std::getline(f, line))
      if (line.rfind(key, 0) == 0) return std::atoll(line.c_str() + std::char_traits<char>::length(key));
    return -1;
  }

 private:
  bool ok_ = false;
  long long base_kb_ = -1;
};

/// CPU time of this process (s): on a shared machine it is the steadier
/// figure; the benchmark reports both.
double cpu_now() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Wall time of the fastest of `repeats` runs of f (and the smallest CPU
/// time), peak memory of the first.
template <typename F> double timed(F&& f, int repeats, long long* peak_rss, double* cpu_seconds = nullptr) {
  double best = HUGE_VAL, best_cpu = HUGE_VAL;
  for (int r = 0; r < std::max(repeats, 1); ++r) {
    RssProbe probe;
    if (r == 0) probe.start();
    const double c0 = cpu_now();
    const auto t0 = Clock::now();
    f();
    best = std::min(best, since(t0));
    best_cpu = std::min(best_cpu, cpu_now() - c0);
    if (r == 0 && peak_rss) *peak_rss = probe.peak_increase_bytes();
  }
  if (cpu_seconds) *cpu_seconds = best_cpu;
  return best;
}

// The core alone: samples pushed from a prepared array. push_one is kept out
// of line so callgrind shows its inclusive cost per call.
template <typename T>
__attribute__((noinline)) feedid::Status push_one(feedid::Estimator<T>& est, const feedid::Sample<T>& s) {
  return est.push(s);
}

struct CoreRun {
  double push_s = 0.0, solve_s = 0.0;
  long samples = 0;
  long rejected = 0;
  feedid::Status status = feedid::Status::not_initialized;
  DriveParams params{};
};

/// Pushes n samples, cycling through `loop`, then solves once. Fastest of
/// `repeats` runs.
template <typename T>
CoreRun run_core(const std::vector<feedid::Sample<T>>& loop, const feedid::Config<double>& cfg, long n, int repeats) {
  CoreRun best;
  best.push_s = best.solve_s = HUGE_VAL;
  const feedid::Config<T> c = config_as<T>(cfg);
  for (int r = 0; r < std::max(repeats, 1); ++r) {
    auto est = std::make_unique<feedid::Estimator<T>>();
    if (est->init(c) != feedid::Status::ok) { best.status = feedid::Status::invalid_config; return best; }
    long rejected = 0;
    const std::size_t L = loop.size();
    const auto t0 = Clock::now();
    std::size_t i = 0;
    for (long k = 0; k < n; ++k) {
      if (push_one(*est, loop[i]) != feedid::Status::ok) ++rejected;
      if (++i == L) i = 0;
    }
    const double tp = since(t0);
    const auto t1 = Clock::now();
    const feedid::Status st = est->solve();
    const double ts = since(t1);
    best.push_s = std::min(best.push_s, tp);
    best.solve_s = std::min(best.solve_s, ts);
    best.samples = n;
    best.rejected = rejected;
    best.status = st;
    const auto& e = est->estimate();
    feedid::Estimate<double> ed;
    ed.mass_kg = e.mass_kg;
    auto dir = [](const feedid::DirectionEstimate<T>& d, feedid::DirectionEstimate<double>& o) {
      o.viscous_Ns_m = d.viscous_Ns_m;
      o.coulomb_N = d.coulomb_N;
      o.breakaway_N = d.breakaway_N;
      o.stribeck_velocity_m_s = d.stribeck_velocity_m_s;
    };
    dir(e.pos, ed.pos);
    dir(e.neg, ed.neg);
    best.params = to_drive_params(ed);
  }
  return best;
}

// ---------------------------------------------------------------------------
// Methods on one trace
// ---------------------------------------------------------------------------

struct MethodRun {
  std::string method;
  bool ran = false;
  bool skipped = false;       ///< not run (budget); seconds may be extrapolated
  bool extrapolated = false;
  bool ok = false, converged = false;
  std::string status;
  DriveParams params{};
  double seconds = kNaN;            ///< wall time (s)
  double cpu_seconds = kNaN;        ///< CPU time of the process over the same run (s)
  long long peak_rss_bytes = -1;
  std::size_t working_bytes = 0, state_bytes = 0, rows = 0;
  long evaluations = 0, iterations = 0;
  double max_rel_error = kNaN, friction_r2 = kNaN;
  int worst = -1;
  // streaming only
  double core_seconds = kNaN;      ///< double core, push + solve
  double core_float_seconds = kNaN;
  double core_push_d = kNaN, core_solve_d = kNaN, core_push_f = kNaN, core_solve_f = kNaN;
  json flags;
};

struct TraceRun {
  Case c;
  std::size_t samples = 0;
  double sim_seconds = 0.0;
  double v_lo = 0.0, v_hi = 0.0;
  std::vector<MethodRun> runs;
  const MethodRun* find(const std::string& m) const {
    for (const auto& r : runs) if (r.method == m) return &r;
    return nullptr;
  }
};

BaselineOptions baseline_options(const BenchOptions& o) {
  BaselineOptions b;
  b.ga_population = o.ga_population;
  b.ga_generations = o.ga_generations;
  b.filter_hz = o.filter_hz;
  b.lm_naive_start = o.lm_naive_start;
  b.stated_conventions = o.stated_conventions;
  return b;
}

void score(MethodRun& r, const DriveParams& truth, double v_lo, double v_hi) {
  if (!r.ok) return;
  r.max_rel_error = max_rel_error(r.params, truth, &r.worst);
  r.friction_r2 = friction_curve_r2(r.params, truth, v_lo, v_hi);
}

MethodRun run_method(const std::string& m, const Trace& tr, const Signals& sig, const feedid::Config<double>& cfg,
                     const BenchOptions& o, int repeats) {
  MethodRun r;
  r.method = m;
  r.ran = true;
  const BaselineOptions bo = baseline_options(o);
  if (m == "streaming") {
    IdentifyResult res;
    const IdentifyOptions io = bench_identify_options(tr, o.stated_conventions);
    r.seconds = timed([&] { res = identify(tr, io); }, repeats, &r.peak_rss_bytes, &r.cpu_seconds);
    r.ok = res.error.empty() && res.status == feedid::Status::ok;
    r.converged = r.ok;
    r.status = res.error.empty() ? std::string("status ") + feedid::status_name(res.status) : res.error;
    r.params = to_drive_params(res.estimate);
    r.rows = res.diagnostics.samples_accepted;
    r.evaluations = 1;
    r.state_bytes = sizeof(Core);
    r.working_bytes = sizeof(Core);
    r.flags = {{"m", flag_names(res.estimate.mass_flags)},
               {"pos", flag_names(res.estimate.pos.flags)},
               {"neg", flag_names(res.estimate.neg.flags)}};
    // The core alone on the same samples (double, as identify runs it; and float).
    const auto sd = core_samples<double>(sig, sig.t.size());
    const CoreRun cd = run_core<double>(sd, cfg, static_cast<long>(sd.size()), repeats);
    r.core_seconds = cd.push_s + cd.solve_s;
    r.core_push_d = cd.push_s;
    r.core_solve_d = cd.solve_s;
    const auto sf = core_samples<float>(sig, sig.t.size());
    const CoreRun cf = run_core<float>(sf, cfg, static_cast<long>(sf.size()), repeats);
    r.core_float_seconds = cf.push_s + cf.solve_s;
    r.core_push_f = cf.push_s;
    r.core_solve_f = cf.solve_s;
    return r;
  }
  BaselineResult b;
  BaselineOptions bo2 = bo;
  Progress progress("    " + m);
  if (m == "ga" && tr.samples.size() > 200000) bo2.progress = std::ref(progress);
  auto fn = [&] {
    if (m == "batch_lm") b = batch_lm(tr, bo2);
    else if (m == "ga") b = genetic_algorithm(tr, bo2);
    else b = recursive_least_squares(tr, bo2);
  };
  r.seconds = timed(fn, m == "ga" ? 1 : repeats, &r.peak_rss_bytes, &r.cpu_seconds);
  r.ok = b.ok;
  r.converged = b.converged;
  r.status = b.status;
  r.params = b.params;
  r.rows = b.rows;
  r.evaluations = b.evaluations;
  r.iterations = b.iterations;
  r.working_bytes = b.working_bytes;
  r.state_bytes = b.state_bytes;
  return r;
}

// ---------------------------------------------------------------------------
// Output helpers
// ---------------------------------------------------------------------------

std::string human_bytes(double b) {
  char buf[32];
  if (!(b >= 0)) return "n/a";
  if (b < 1024) std::snprintf(buf, sizeof buf, "%.0f B", b);
  else if (b < 1024.0 * 1024) std::snprintf(buf, sizeof buf, "%.1f KiB", b / 1024);
  else if (b < 1024.0 * 1024 * 1024) std::snprintf(buf, sizeof buf, "%.1f MiB", b / 1024 / 1024);
  else std::snprintf(buf, sizeof buf, "%.2f GiB", b / 1024 / 1024 / 1024);
  return buf;
}

std::string fmt(const char* f, double v) {
  if (!std::isfinite(v)) return "-";
  char buf[48];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

PlotSeries named(const std::string& label) {
  PlotSeries s;
  s.label = label;
  return s;
}

json jnum(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json params_json(const DriveParams& p) {
  json j = model_json(p);
  j.erase("units");
  return j;
}

json run_json(const MethodRun& r) {
  json j = {{"ran", r.ran}, {"skipped", r.skipped}, {"extrapolated", r.extrapolated},
            {"ok", r.ok}, {"converged", r.converged}, {"status", r.status},
            {"seconds", jnum(r.seconds)}, {"cpu_seconds", jnum(r.cpu_seconds)},
            {"peak_rss_bytes", r.peak_rss_bytes >= 0 ? json(r.peak_rss_bytes) : json(nullptr)},
            {"working_bytes", r.working_bytes}, {"state_bytes", r.state_bytes}, {"rows", r.rows},
            {"evaluations", r.evaluations}, {"iterations", r.iterations},
            {"max_rel_error", jnum(r.max_rel_error)},
            {"worst_parameter", r.worst >= 0 ? json(kParamNames[r.worst]) : json(nullptr)},
            {"friction_r2", jnum(r.friction_r2)}};
  if (r.ok) j["params"] = params_json(r.params);
  if (r.method == "streaming") {
    j["core_seconds"] = jnum(r.core_seconds);
    j["core_float_seconds"] = jnum(r.core_float_seconds);
    j["flags"] = r.flags;
  }
  return j;
}

std::string read_first(const std::string& path, const std::string& key) {
  std::ifstream f(path);
  std::string line;
  while (std::getline(f, line))
    if (key.empty() || line.rfind(key, 0) == 0) {
      const auto c = key.empty() ? std::string::npos : line.find(':');
      std::string v = c == std::string::npos ? line : line.substr(c + 1);
      v.erase(0, v.find_first_not_of(" \t"));
      return v;
    }
  return "";
}

json machine_json() {
  json j;
  j["cpu"] = read_first("/proc/cpuinfo", "model name");
  j["hardware_threads"] = std::thread::hardware_concurrency();
  j["compiler"] = std::string("g++ ") + __VERSION__;
#ifdef __OPTIMIZE__
  j["optimized"] = true;
#else
  j["optimized"] = false;
#endif
#ifdef NDEBUG
  j["ndebug"] = true;
#else
  j["ndebug"] = false;
#endif
  j["load_average"] = read_first("/proc/loadavg", "");
  j["kernel"] = read_first("/proc/sys/kernel/osrelease", "");
  char host[128] = {};
  gethostname(host, sizeof host - 1);
  j["hostname"] = host;
  const std::time_t now = std::time(nullptr);
  char ts[64];
  std::strftime(ts, sizeof ts, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  j["date_utc"] = ts;
  return j;
}

/// Writes `text` to path (and says so), or records why not.
void write_text(const std::string& path, const std::string& text, RunEnd& end, const std::vector<std::string>& inputs = {}) {
  const std::string err = write_whole_file(path, text, inputs);
  end.written(err);
  if (err.empty()) std::printf("wrote %s\n", path.c_str());
}

/// The methods --methods names (all when empty), or why not.
Outcome<std::vector<std::string>> parse_methods(const std::string& s) {
  Outcome<std::vector<std::string>> parsed;
  std::vector<std::string>& out = parsed.value;
  out.clear();
  if (s.empty()) {
    out.assign(std::begin(kAllMethods), std::end(kAllMethods));
    return parsed;
  }
  std::stringstream ss(s);
  std::string m;
  while (std::getline(ss, m, ',')) {
    if (m.empty()) continue;
    if (std::find(std::begin(kAllMethods), std::end(kAllMethods), m) == std::end(kAllMethods))
      return refused<std::vector<std::string>>("--methods: unknown method '" + m + "' (streaming, batch_lm, ga, rls)");
    out.push_back(m);
  }
  if (out.empty()) parsed.error = "--methods names no method (streaming, batch_lm, ga, rls)";
  return parsed;
}

json budgets_json(const BenchOptions& o) {
  const BaselineOptions b = baseline_options(o);
  return {
      {"timing", {{"repeats", o.repeats}, {"rule", "fastest of `repeats` runs; ga runs once; memory from the first run"}}},
      {"batch_lm", {{"solver", "Eigen 3 unsupported NonLinearOptimization LevenbergMarquardt::minimizeOptimumStorage (MINPACK lmstr)"},
                    {"max_evaluations", b.lm_max_evaluations}, {"ftol_xtol", b.lm_tolerance},
                    {"derivative", "velocity difference across each sample interval (central about its midpoint), paired with the interval force by the core's alignment rule"},
                    {"lowpass_hz", b.filter_hz}, {"lowpass", b.filter_hz > 0 ? "zero-phase 4th-order Butterworth on velocity and force" : "none"},
                    {"start", b.lm_naive_start ? "linear least squares with Fs = 0, then Fs = 0.2 Fc, vs = median moving speed"
                                               : "linear least squares with Fs = 0, then Fs and vs from the low-speed residual"}}},
      {"ga", {{"algorithm", "differential evolution DE/rand/1/bin, F = 0.6, CR = 0.9"},
              {"population", b.ga_population}, {"generations", b.ga_generations},
              {"evaluations", b.ga_population * (b.ga_generations + 1)},
              {"box", "m, sigma in [0.5, 2] x start; Fc, Fs in [0, 2|Fc start| + 1 N]; ln vs over [v_min/2, v_max/4]"}}},
      {"rls", {{"filters", b.rls_filters}, {"memory_s", b.rls_memory_s},
               {"vs", "bank of parallel filters on a log grid of vs over [v_min/2, v_max/4]; best by forgotten a-priori error, parabola in ln vs"},
               {"acceleration", "raw velocity difference per interval (causal, no filter)"}}},
  };
}

// ---------------------------------------------------------------------------
// --core-only
// ---------------------------------------------------------------------------

RunEnd run_core_only(const BenchOptions& o) {
  if (o.samples < 1) return RunEnd::refused("--samples must be >= 1");
  if (o.precision != "float" && o.precision != "double")
    return RunEnd::refused("--precision must be float or double, not '" + o.precision + "'");
  RunEnd end;
  std::fprintf(stderr, "core-only: simulating a 30 s loop of the default drive\n");
  const CoreLoop l = make_core_loop(30.0);
  CoreRun r;
  std::size_t state = 0;
  if (o.precision == "float") {
    r = run_core<float>(core_samples<float>(l.signals, l.length), l.config, o.samples, 1);
    state = sizeof(feedid::Estimator<float>);
  } else {
    r = run_core<double>(core_samples<double>(l.signals, l.length), l.config, o.samples, 1);
    state = sizeof(feedid::Estimator<double>);
  }
  const double ns = 1e9 * r.push_s / static_cast<double>(o.samples);
  std::printf("core-only (%s): %ld samples (loop of %zu) pushed in %.4f s = %.2f ns/sample; %ld rejected\n",
              o.precision.c_str(), o.samples, l.length, r.push_s, ns, r.rejected);
  std::printf("solve: %.1f us, status %s; state %zu bytes\n", 1e6 * r.solve_s, feedid::status_name(r.status), state);
  std::printf("estimate: m %.6g kg; + sigma %.6g Fc %.6g Fs %.6g vs %.6g; - sigma %.6g Fc %.6g Fs %.6g vs %.6g\n",
              r.params.mass_kg, r.params.pos.viscous_Ns_m, r.params.pos.coulomb_N, r.params.pos.breakaway_N,
              r.params.pos.stribeck_velocity_m_s, r.params.neg.viscous_Ns_m, r.params.neg.coulomb_N,
              r.params.neg.breakaway_N, r.params.neg.stribeck_velocity_m_s);
  if (!o.json_path.empty()) {
    json j = {{"mode", "core_only"}, {"machine", machine_json()}, {"precision", o.precision},
              {"samples", o.samples}, {"loop_samples", l.length}, {"rejected", r.rejected},
              {"push_seconds", r.push_s}, {"ns_per_sample", ns}, {"solve_us", 1e6 * r.solve_s},
              {"status", feedid::status_name(r.status)}, {"state_bytes", state},
              {"estimate", params_json(r.params)}};
    write_text(o.json_path, j.dump(2) + "\n", end);
  }
  return end;
}

// ---------------------------------------------------------------------------
// Default set
// ---------------------------------------------------------------------------

void print_trace_table(const TraceRun& t) {
  std::printf("\n%s: %zu samples (%.0f s at %.0f Hz); truth m %.4g kg, vs+ %.3g m/s, vs- %.3g m/s\n",
              t.c.name.c_str(), t.samples, t.c.sim.motion.duration_s, t.c.sim.controller.servo_rate_hz,
              t.c.sim.drive.mass_kg, t.c.sim.drive.pos.stribeck_velocity_m_s, t.c.sim.drive.neg.stribeck_velocity_m_s);
  std::printf("  %-10s %10s %10s %9s %-7s %10s %11s  %s\n", "method", "time (s)", "vs stream", "max err", "worst",
              "R^2", "peak mem", "status");
  const MethodRun* s = t.find("streaming");
  for (const auto& r : t.runs) {
    const double ratio = s && std::isfinite(s->seconds) ? r.seconds / s->seconds : kNaN;
    std::printf("  %-10s %10s %10s %8s%% %-7s %10s %11s  %s\n", r.method.c_str(), fmt("%.4g", r.seconds).c_str(),
                fmt("%.3gx", ratio).c_str(), fmt("%.3g", 100 * r.max_rel_error).c_str(),
                r.worst >= 0 ? kParamNames[r.worst] : "-", fmt("%.6f", r.friction_r2).c_str(),
                human_bytes(static_cast<double>(r.peak_rss_bytes)).c_str(), r.status.substr(0, 60).c_str());
    if (r.method == "streaming")
      std::printf("  %-10s %10s %10s  (core alone, push + solve: double; float %s s)\n", "  core",
                  fmt("%.4g", r.core_seconds).c_str(), fmt("%.3gx", r.core_seconds / r.seconds).c_str(),
                  fmt("%.4g", r.core_float_seconds).c_str());
  }
  std::fflush(stdout);
}

double median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

/// Simulates every case and runs every method on it, printing each trace's table.
std::vector<TraceRun> run_cases(const std::vector<Case>& cases, const BenchOptions& oo,
                                const std::vector<std::string>& methods) {
  std::vector<TraceRun> runs;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    TraceRun t;
    t.c = cases[i];
    std::fprintf(stderr, "[%zu/%zu] %s: simulating ...", i + 1, cases.size(), t.c.name.c_str());
    const auto t0 = Clock::now();
    const Trace tr = simulate(t.c.sim);
    t.sim_seconds = since(t0);
    t.samples = tr.samples.size();
    const IdentifyOptions io = bench_identify_options(tr, oo.stated_conventions);
    const Signals sig = simulated_signals(tr, io);
    const feedid::Config<double> cfg = auto_config(sig, io);
    t.v_lo = cfg.velocity_min_m_s;
    t.v_hi = cfg.velocity_max_m_s;
    std::fprintf(stderr, " %zu samples in %.2f s\n", t.samples, t.sim_seconds);
    for (const auto& m : methods) {
      std::fprintf(stderr, "[%zu/%zu] %s: %-9s ...", i + 1, cases.size(), t.c.name.c_str(), m.c_str());
      MethodRun r = run_method(m, tr, sig, cfg, oo, oo.repeats);
      score(r, t.c.sim.drive, t.v_lo, t.v_hi);
      std::fprintf(stderr, " %.3g s, max error %s %%\n", r.seconds, fmt("%.3g", 100 * r.max_rel_error).c_str());
      t.runs.push_back(r);
    }
    print_trace_table(t);
    runs.push_back(std::move(t));
  }
  return runs;
}

/// The core alone, from the streaming runs: push per sample (summed over
/// the traces) and solve, float and double.
struct CoreTiming {
  double push_f = 0, push_d = 0, solve_f = 0, solve_d = 0;  ///< summed seconds
  double ns_f = kNaN, ns_d = kNaN, solve_f_us = kNaN, solve_d_us = kNaN;
  long samples = 0;
};
CoreTiming core_timing(const std::vector<TraceRun>& runs) {
  CoreTiming c;
  int n_core = 0;
  for (const auto& t : runs)
    if (const MethodRun* r = t.find("streaming")) {
      c.push_f += r->core_push_f; c.push_d += r->core_push_d; c.solve_f += r->core_solve_f; c.solve_d += r->core_solve_d;
      c.samples += static_cast<long>(t.samples);
      ++n_core;
    }
  if (n_core == 0) return c;
  c.ns_f = 1e9 * c.push_f / static_cast<double>(c.samples);
  c.ns_d = 1e9 * c.push_d / static_cast<double>(c.samples);
  c.solve_f_us = 1e6 * c.solve_f / n_core;
  c.solve_d_us = 1e6 * c.solve_d / n_core;
  return c;
}

json core_json(const CoreTiming& c) {
  return {{"state_bytes_float", sizeof(feedid::Estimator<float>)},
          {"state_bytes_double", sizeof(feedid::Estimator<double>)},
          {"ns_per_sample", jnum(c.ns_f)}, {"ns_per_sample_float", jnum(c.ns_f)}, {"ns_per_sample_double", jnum(c.ns_d)},
          {"solve_us_float", jnum(c.solve_f_us)}, {"solve_us_double", jnum(c.solve_d_us)},
          {"samples_timed", c.samples},
          {"rule", "push of every trace sample from a prepared array (fastest of `repeats` runs), summed over the traces; ns_per_sample is float, the firmware precision"}};
}

/// Per method over all traces: the summary table and its JSON.
json method_summary(const std::vector<TraceRun>& runs, const std::vector<std::string>& methods, const CoreTiming& c) {
  long n_all = 0;
  for (const auto& t : runs) n_all += static_cast<long>(t.samples);
  json jm;
  std::printf("\n== summary over %zu traces (%ld samples)\n", runs.size(), n_all);
  std::printf("  %-10s %11s %11s %10s %13s %13s %10s %9s %12s\n", "method", "time (s)", "CPU (s)", "vs stream", "worst err",
              "median err", "min R^2", "converged", "peak mem");
  const double stream_total = [&] {
    double s = 0;
    for (const auto& t : runs) if (const auto* r = t.find("streaming")) s += r->seconds;
    return s;
  }();
  for (const auto& m : methods) {
    double secs = 0, cpu = 0, worst = 0, r2 = HUGE_VAL;
    long long peak = -1;
    int conv = 0, n = 0;
    std::vector<double> errs;
    for (const auto& t : runs) {
      const MethodRun* r = t.find(m);
      if (!r) continue;
      ++n;
      secs += r->seconds;
      cpu += r->cpu_seconds;
      errs.push_back(r->max_rel_error);
      worst = std::max(worst, std::isfinite(r->max_rel_error) ? r->max_rel_error : HUGE_VAL);
      if (std::isfinite(r->friction_r2)) r2 = std::min(r2, r->friction_r2);
      peak = std::max(peak, r->peak_rss_bytes);
      conv += r->converged ? 1 : 0;
    }
    jm[m] = {{"seconds", secs}, {"cpu_seconds", cpu}, {"seconds_rule", "wall time, summed over the traces"},
             {"max_rel_error", jnum(worst)}, {"median_max_rel_error", jnum(median(errs))},
             {"friction_r2", jnum(r2)}, {"friction_r2_rule", "smallest over traces and directions"},
             {"converged", conv}, {"traces", n},
             {"peak_rss_bytes", peak >= 0 ? json(peak) : json(nullptr)}};
    std::printf("  %-10s %11.4g %11.4g %10s %12s%% %12s%% %10s %6d/%-2d %12s\n", m.c_str(), secs, cpu,
                fmt("%.3gx", secs / stream_total).c_str(), fmt("%.3g", 100 * worst).c_str(),
                fmt("%.3g", 100 * median(errs)).c_str(), fmt("%.6f", r2).c_str(), conv, n,
                human_bytes(static_cast<double>(peak)).c_str());
  }
  if (jm.contains("streaming")) {
    jm["streaming"]["core_seconds"] = c.push_d + c.solve_d;
    jm["streaming"]["core_float_seconds"] = c.push_f + c.solve_f;
    jm["streaming"]["state_bytes"] = sizeof(Core);
  }
  return jm;

}

/// The bars: speed and accuracy against batch_lm where it converged, and the state size.
json targets(const std::vector<TraceRun>& runs, const json& jm, const CoreTiming& c) {
  json tg;
  if (jm.contains("streaming") && jm.contains("batch_lm")) {
    double lm_s = 0, st_s = 0, core_s = 0, lm_cpu = 0, st_cpu = 0, ratio_worst = 0, lm_worst = 0, st_worst = 0;
    int conv = 0;
    json not_conv = json::array();
    for (const auto& t : runs) {
      const MethodRun* lm = t.find("batch_lm");
      const MethodRun* st = t.find("streaming");
      lm_s += lm->seconds;
      st_s += st->seconds;
      lm_cpu += lm->cpu_seconds;
      st_cpu += st->cpu_seconds;
      core_s += st->core_seconds;
      if (!lm->converged || !std::isfinite(lm->max_rel_error)) { not_conv.push_back(t.c.name); continue; }
      ++conv;
      lm_worst = std::max(lm_worst, lm->max_rel_error);
      st_worst = std::max(st_worst, st->max_rel_error);
      ratio_worst = std::max(ratio_worst, st->max_rel_error / lm->max_rel_error);
    }
    tg = {{"speedup_pipeline_vs_batch_lm", lm_s / st_s},
          {"speedup_pipeline_vs_batch_lm_cpu", lm_cpu / st_cpu},
          {"speedup_core_vs_batch_lm", lm_s / core_s},
          {"speedup_target", 100},
          {"error_ratio_worst_trace", ratio_worst},
          {"error_ratio_of_worst", lm_worst > 0 ? st_worst / lm_worst : kNaN},
          {"error_ratio_target", 1.5},
          {"batch_lm_converged_traces", conv}, {"batch_lm_not_converged", not_conv},
          {"state_bytes_float", sizeof(feedid::Estimator<float>)}, {"state_bytes_float_target", feedid::fw::estimator_float_ram_budget}};
    std::printf("\n== targets\n");
    std::printf("  speed: batch_lm / streaming pipeline = %.3gx (CPU time %.3gx); batch_lm / core alone (push + solve, double) = %.3gx  (target >= 100x)\n",
                lm_s / st_s, lm_cpu / st_cpu, lm_s / core_s);
    std::printf("  accuracy (traces where batch_lm converged: %d of %zu): streaming worst %.3g %% against batch_lm worst %.3g %% (ratio %.3g); worst per-trace ratio %.3g  (target <= 1.5)\n",
                conv, runs.size(), 100 * st_worst, 100 * lm_worst, lm_worst > 0 ? st_worst / lm_worst : kNaN, ratio_worst);
  }
  std::printf("  state: float core %zu bytes (target <= %zu), double %zu bytes; push %.1f ns/sample float, %.1f ns/sample double; solve %.0f us float, %.0f us double\n",
              sizeof(feedid::Estimator<float>), static_cast<std::size_t>(feedid::fw::estimator_float_ram_budget), sizeof(feedid::Estimator<double>), c.ns_f, c.ns_d,
              c.solve_f_us, c.solve_d_us);
  return tg;

}

json traces_json(const std::vector<TraceRun>& runs) {
  json jt = json::array();
  for (const auto& t : runs) {
    json j = {{"name", t.c.name}, {"drive", t.c.drive}, {"seed", t.c.sim.seed}, {"samples", t.samples},
              {"duration_s", t.c.sim.motion.duration_s}, {"rate_hz", t.c.sim.controller.servo_rate_hz},
              {"simulate_seconds", t.sim_seconds},
              {"truth", params_json(t.c.sim.drive)}, {"r2_speed_range_m_s", {t.v_lo, t.v_hi}}};
    for (const auto& r : t.runs) j["methods"][r.method] = run_json(r);
    jt.push_back(j);
  }
  return jt;
}

/// bench_time_vs_error.svg in the plot folder, or why it cannot be written.
void plot_time_vs_error(const BenchOptions& o, const std::vector<TraceRun>& runs, const std::vector<std::string>& methods,
                        const json& machine, RunEnd& end) {
    PlotSpec p;
    p.title = "Wall time against worst parameter error (one point per trace)";
    p.x = {"wall time per trace (s)", true};
    p.y = {"worst relative error over the nine parameters (%)", true};
    p.legend = "top-right";
    p.note = machine["cpu"].get<std::string>() + ", " + machine["date_utc"].get<std::string>();
    for (const auto& m : methods) {
      PlotSeries s;
      s.label = m;
      s.line = false;
      for (const auto& t : runs)
        if (const MethodRun* r = t.find(m)) { s.x.push_back(r->seconds); s.y.push_back(100 * r->max_rel_error); }
      p.series.push_back(s);
    }
    std::string err;
    const std::string path = o.plot_dir + "/bench_time_vs_error.svg";
    if (!write_svg(path, p, err)) end.written(err);
    else std::printf("wrote %s\n", path.c_str());
}

RunEnd run_default(const BenchOptions& o, const std::vector<std::string>& methods) {
  const auto t_all = Clock::now();
  json out;
  out["mode"] = o.quick ? "quick" : "default";
  out["stated_conventions"] = o.stated_conventions;
  out["machine"] = machine_json();
  BenchOptions oo = o;
  if (o.quick) { oo.ga_generations = std::min(o.ga_generations, 40); oo.ga_population = std::min(o.ga_population, 24); }
  out["budgets"] = budgets_json(oo);
  const std::vector<Case> cases = default_cases(o.quick);
  std::fprintf(stderr, "bench: %zu traces x %zu methods; ga budget %d x %d evaluations per trace\n", cases.size(),
               methods.size(), oo.ga_population, oo.ga_generations + 1);
  const std::vector<TraceRun> runs = run_cases(cases, oo, methods);
  const CoreTiming timing = core_timing(runs);
  out["core"] = core_json(timing);
  out["methods"] = method_summary(runs, methods, timing);
  out["targets"] = targets(runs, out["methods"], timing);
  if (o.stated_conventions)
    std::printf("  (--stated-conventions: no method searched the force lag or the velocity cut-off; the bars are read on a run without it)\n");
  out["traces"] = traces_json(runs);
  out["machine"]["load_average_end"] = read_first("/proc/loadavg", "");
  out["total_seconds"] = since(t_all);
  std::printf("\nbench finished in %.1f s\n", since(t_all));
  RunEnd end;
  if (!o.plot_dir.empty()) plot_time_vs_error(o, runs, methods, out["machine"], end);
  if (!o.json_path.empty()) write_text(o.json_path, out.dump(2) + "\n", end);
  return end;
}

// ---------------------------------------------------------------------------
// --scaling
// ---------------------------------------------------------------------------

/// One trace length of --scaling: every method's run (or the GA's
/// extrapolation past --ga-max-samples) and the core's own time.
struct ScalingPoint {
  long n = 0;
  double duration_s = 0;
  std::vector<MethodRun> runs;
  double core_d = kNaN, core_f = kNaN;
};
/// The GA's cost per (row x evaluation) and rows per sample, from its largest run.
struct GaCost {
  double per_row_eval = kNaN, rows_per_sample = kNaN;
};

MethodRun extrapolated_ga(long n, const BenchOptions& o, const GaCost& ga) {
  MethodRun r;
  r.method = "ga";
  r.skipped = true;
  r.extrapolated = std::isfinite(ga.per_row_eval);
  const double rows_est = static_cast<double>(n) * ga.rows_per_sample;
  r.seconds = ga.per_row_eval * rows_est * o.ga_population * (o.ga_generations + 1);
  r.status = "not run (--ga-max-samples); time extrapolated from the largest GA run";
  return r;
}

void print_scaling_row(long n, const std::string& m, const MethodRun& r) {
  std::printf("  %-10ld %-10s %11s %12s %8s%% %-7s  %s\n", n, m.c_str(),
              (fmt("%.4g", r.seconds) + (r.extrapolated ? "*" : "")).c_str(),
              human_bytes(static_cast<double>(r.peak_rss_bytes)).c_str(), fmt("%.3g", 100 * r.max_rel_error).c_str(),
              r.worst >= 0 ? kParamNames[r.worst] : "-", r.skipped ? "skipped, * = extrapolated" : r.converged ? "" : "not converged");
  std::fflush(stdout);
}

ScalingPoint run_scaling_point(long n, const BenchOptions& o, const std::vector<std::string>& methods, GaCost& ga) {
  SimConfig sc = drive_config("default", 1, static_cast<double>(n - 1) / 2000.0);
  std::fprintf(stderr, "scaling: %ld samples: simulating ...", n);
  const auto t0 = Clock::now();
  const Trace tr = simulate(sc, [](double) {});
  std::fprintf(stderr, " %.1f s\n", since(t0));
  const IdentifyOptions io = bench_identify_options(tr, o.stated_conventions);
  const Signals sig = simulated_signals(tr, io);
  const feedid::Config<double> cfg = auto_config(sig, io);
  ScalingPoint pt;
  pt.n = n;
  pt.duration_s = sc.motion.duration_s;
  const int reps = n <= 100000 ? o.repeats : 1;
  for (const auto& m : methods) {
    MethodRun r;
    if (m == "ga" && n > o.ga_max_samples) {
      r = extrapolated_ga(n, o, ga);
    } else {
      std::fprintf(stderr, "scaling: %ld samples: %-9s ...", n, m.c_str());
      r = run_method(m, tr, sig, cfg, o, reps);
      score(r, sc.drive, cfg.velocity_min_m_s, cfg.velocity_max_m_s);
      std::fprintf(stderr, " %.3g s\n", r.seconds);
      if (m == "ga" && r.rows > 0 && r.evaluations > 0) {
        ga.per_row_eval = r.seconds / (static_cast<double>(r.rows) * static_cast<double>(r.evaluations));
        ga.rows_per_sample = static_cast<double>(r.rows) / static_cast<double>(n);
      }
      if (m == "streaming") { pt.core_d = r.core_seconds; pt.core_f = r.core_float_seconds; }
    }
    print_scaling_row(n, m, r);
    pt.runs.push_back(r);
  }
  return pt;
}

json scaling_row_json(const ScalingPoint& pt) {
  json jr = {{"samples", pt.n}, {"duration_s", pt.duration_s}};
  for (const auto& r : pt.runs) jr["methods"][r.method] = run_json(r);
  jr["core"] = {{"seconds_double", jnum(pt.core_d)}, {"seconds_float", jnum(pt.core_f)},
                {"state_bytes_float", sizeof(feedid::Estimator<float>)},
                {"state_bytes_double", sizeof(feedid::Estimator<double>)}};
  return jr;
}

/// A series against trace length, one point per scaling point.
PlotSeries against_length(const std::string& label, const std::vector<ScalingPoint>& pts,
                          const std::function<double(const ScalingPoint&)>& y) {
  PlotSeries s = named(label);
  for (const auto& p : pts) {
    s.x.push_back(static_cast<double>(p.n));
    s.y.push_back(y(p));
  }
  return s;
}

const char* const kScalingPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b"};

/// Wall time against trace length: each method, the GA's extrapolation
/// dashed in its colour, and the streaming core alone.
PlotSpec scaling_time_plot(const std::vector<ScalingPoint>& pts, const std::vector<std::string>& methods,
                           const std::string& note) {
  PlotSpec pt_time;
  pt_time.title = "Wall time against trace length";
  pt_time.x = {"trace length (samples)", true};
  pt_time.y = {"wall time (s)", true};
  pt_time.note = note;
  for (std::size_t mi = 0; mi < methods.size(); ++mi) {
    PlotSeries st = against_length(methods[mi], pts, [mi](const ScalingPoint& p) {
      return p.runs[mi].skipped ? kNaN : p.runs[mi].seconds;
    });
    st.color = kScalingPalette[mi % 6];
    PlotSeries ext;
    ext.dashed = true;
    ext.markers = true;
    for (const auto& p : pts)
      if (p.runs[mi].extrapolated) { ext.x.push_back(static_cast<double>(p.n)); ext.y.push_back(p.runs[mi].seconds); }
    if (!ext.x.empty()) {  // continue the measured line into its extrapolation
      for (std::size_t k = st.y.size(); k-- > 0;)
        if (std::isfinite(st.y[k])) { ext.x.insert(ext.x.begin(), st.x[k]); ext.y.insert(ext.y.begin(), st.y[k]); break; }
      ext.color = st.color;
      ext.label = methods[mi] + " (extrapolated)";
    }
    pt_time.series.push_back(st);
    if (!ext.x.empty()) pt_time.series.push_back(ext);
  }
  PlotSeries core = against_length("streaming core alone (push + solve, float)", pts, [](const ScalingPoint& p) { return p.core_f; });
  core.dashed = true;
  core.color = "#1f77b4";
  if (std::find(methods.begin(), methods.end(), "streaming") != methods.end()) pt_time.series.push_back(core);
  return pt_time;
}

/// Peak memory against trace length: each method, the core's state and the RLS bank's.
PlotSpec scaling_memory_plot(const std::vector<ScalingPoint>& pts, const std::vector<std::string>& methods,
                             const std::string& note) {
  PlotSpec pt_mem;
  pt_mem.title = "Peak memory against trace length";
  pt_mem.x = {"trace length (samples)", true};
  pt_mem.y = {"peak resident memory above the loaded trace (bytes)", true};
  pt_mem.note = note;
  pt_mem.legend = "bottom-right";
  for (std::size_t mi = 0; mi < methods.size(); ++mi) {
    PlotSeries sm = against_length(methods[mi], pts, [mi](const ScalingPoint& p) {
      return p.runs[mi].peak_rss_bytes > 0 ? static_cast<double>(p.runs[mi].peak_rss_bytes) : kNaN;
    });
    sm.color = kScalingPalette[mi % 6];
    pt_mem.series.push_back(sm);
  }
  PlotSeries sf = against_length("core state, float", pts, [](const ScalingPoint&) { return static_cast<double>(sizeof(feedid::Estimator<float>)); });
  PlotSeries sd = against_length("core state, double", pts, [](const ScalingPoint&) { return static_cast<double>(sizeof(feedid::Estimator<double>)); });
  sf.color = "#555555";
  sd.color = "#999999";
  sf.markers = sd.markers = false;
  sd.dashed = true;
  pt_mem.series.push_back(sf);
  pt_mem.series.push_back(sd);
  const auto rls_it = std::find(methods.begin(), methods.end(), "rls");
  if (rls_it != methods.end()) {
    const auto ri = static_cast<std::size_t>(rls_it - methods.begin());
    PlotSeries sr = against_length("rls filter bank state", pts, [ri](const ScalingPoint& p) { return static_cast<double>(p.runs[ri].state_bytes); });
    sr.color = "#ff7f0e";
    sr.markers = false;
    sr.dashed = true;
    pt_mem.series.push_back(sr);
  }
  return pt_mem;
}

RunEnd run_scaling(const BenchOptions& o, const std::vector<std::string>& methods) {
  const auto t_all = Clock::now();
  std::vector<long> lengths;
  for (double l : {1e4, 3e4, 1e5, 3e5, 1e6, 3e6, 1e7, 3e7, 1e8})
    if (l <= static_cast<double>(o.max_samples) * 1.0000001) lengths.push_back(static_cast<long>(l));
  if (lengths.empty()) return RunEnd::refused("--max-samples must be >= 10000");
  json out;
  out["mode"] = "scaling";
  out["stated_conventions"] = o.stated_conventions;
  out["machine"] = machine_json();
  out["budgets"] = budgets_json(o);
  out["drive"] = "default";
  std::printf("  %-10s %-10s %11s %12s %9s %-7s  %s\n", "samples", "method", "time (s)", "peak mem", "max err", "worst", "note");
  std::vector<ScalingPoint> pts;
  GaCost ga;
  json rows = json::array();
  for (long n : lengths) {
    pts.push_back(run_scaling_point(n, o, methods, ga));
    rows.push_back(scaling_row_json(pts.back()));
  }
  out["scaling"] = rows;
  out["machine"]["load_average_end"] = read_first("/proc/loadavg", "");
  out["total_seconds"] = since(t_all);
  RunEnd end;
  if (!o.plot_dir.empty()) {
    const std::string note = out["machine"]["cpu"].get<std::string>() + ", " + out["machine"]["date_utc"].get<std::string>() +
                             "; default drive, 2 kHz; dashed: extrapolated or constant";
    std::string err;
    for (const auto& [name, spec] : {std::pair<std::string, PlotSpec>{"bench_scaling_time.svg", scaling_time_plot(pts, methods, note)},
                                     {"bench_scaling_memory.svg", scaling_memory_plot(pts, methods, note)}}) {
      const std::string path = o.plot_dir + "/" + name;
      if (!write_svg(path, spec, err)) end.written(err);
      else std::printf("wrote %s\n", path.c_str());
    }
  }
  if (!o.json_path.empty()) write_text(o.json_path, out.dump(2) + "\n", end);
  if (o.stated_conventions)
    std::printf("(--stated-conventions: no method searched the force lag or the velocity cut-off)\n");
  std::printf("scaling finished in %.1f s\n", since(t_all));
  return end;
}

}  // namespace

CoreLoop make_core_loop(double seconds) {
  const SimConfig sc = drive_config("default", 1, seconds);
  const Trace tr = simulate(sc);
  CoreLoop l;
  IdentifyOptions io;
  l.signals = simulated_signals(tr, io);
  l.config = auto_config(l.signals, io);
  // End the loop in the last dwell (velocity zero for 3 samples) so the wrap
  // to the first sample (at rest) is a continuous stream.
  const std::vector<double>& v = l.signals.v;
  l.length = v.size();
  for (std::size_t k = v.size() - 1; k >= 3; --k)
    if (v[k] == 0.0 && v[k - 1] == 0.0 && v[k - 2] == 0.0) { l.length = k + 1; break; }
  return l;
}

/// One CLI-like run: read the CSV, then `work` on the trace; wall time and
/// CPU time (the fastest of `repeats` runs) and the peak memory above the
/// process before the read (the first run's).
struct CostRun {
  double seconds = 0.0, cpu_seconds = 0.0;
  long long peak_rss_bytes = -1;
  std::string error;  ///< the read's, where it failed
};
template <typename F> CostRun cost_of(const std::string& csv, const CsvColumns& columns, int repeats, F&& work) {
  CostRun r;
  r.seconds = timed(
      [&] {
        const CsvResult in = read_trace_csv(csv, columns);
        r.error = in.error;
        if (r.error.empty()) work(in.trace);
      },
      repeats, &r.peak_rss_bytes, &r.cpu_seconds);
  return r;
}

/// The simulated trace --diagnose-cost measures on (a 3 N ripple), written
/// to a temporary CSV; "" and `error` set where it cannot be.
std::string simulated_cost_trace(const BenchOptions& o, std::string& error) {
  SimConfig c;
  c.controller.servo_rate_hz = o.cost_rate_hz;
  c.motion.duration_s = o.cost_duration_s;
  c.effects.ripple_amplitude_N = 3.0;
  error = sim_config_error(c);  // --cost-rate, --cost-duration
  if (!error.empty()) return "";
  std::fprintf(stderr, "diagnose cost: simulating %.0f s at %.0f Hz ...\n", o.cost_duration_s, o.cost_rate_hz);
  const std::string csv = "/tmp/feedid_cost_" + std::to_string(getpid()) + ".csv";
  if (!write_trace_csv(csv, simulate(c), error)) return "";
  return csv;
}

RunEnd run_diagnose_cost(const BenchOptions& o) {
  const bool simulated = o.cost_csv.empty();
  std::string error;
  const std::string csv = simulated ? simulated_cost_trace(o, error) : o.cost_csv;
  RunEnd end;
  if (csv.empty()) {
    end.written(error);
    return end;
  }
  const CsvColumns columns = simulated ? CsvColumns{} : o.cost_columns;
  const int repeats = std::max(1, o.repeats);
  std::fprintf(stderr, "diagnose cost: reading alone ...\n");
  const CostRun rd = cost_of(csv, columns, repeats, [](const Trace&) {});
  if (!rd.error.empty()) {
    if (simulated) std::remove(csv.c_str());
    return RunEnd::refused(rd.error);
  }
  std::fprintf(stderr, "diagnose cost: identify ...\n");
  double core_passes = 0.0, duration_s = 0.0, rate_hz = 0.0;
  std::string refused;  // a trace either command refuses: its early return is no measure of its cost
  const CostRun id = cost_of(csv, columns, repeats, [&](const Trace& t) {
    const IdentifyResult r = identify(t, IdentifyOptions{});
    if (!r.error.empty()) refused = "identify: " + r.error;
    core_passes = r.core_passes;
    rate_hz = r.signals.sample_rate_hz;
    duration_s = r.signals.t.empty() ? 0.0 : r.signals.t.back() - r.signals.t.front();
  });
  std::fprintf(stderr, "diagnose cost: diagnose ...\n");
  const CostRun dg = cost_of(csv, columns, repeats, [&](const Trace& t) {
    const DiagnoseResult r = diagnose(t, DiagnoseOptions{});
    if (!r.error.empty() && refused.empty()) refused = "diagnose: " + r.error;
  });
  if (simulated) std::remove(csv.c_str());
  if (!refused.empty()) return RunEnd::refused("--diagnose-cost: " + refused);
  const double t_ratio = dg.seconds / id.seconds;
  const double m_ratio = id.peak_rss_bytes > 0 && dg.peak_rss_bytes >= 0
                             ? static_cast<double>(dg.peak_rss_bytes) / static_cast<double>(id.peak_rss_bytes) : NAN;
  std::printf("diagnose against identify, %s: %.0f s at %.0f Hz (CSV read included), fastest of %d runs each:\n",
              simulated ? "one simulated trace" : o.cost_csv.c_str(), duration_s, rate_hz, repeats);
  std::printf("  %-9s %9s %9s %11s\n", "command", "wall s", "cpu s", "peak mem");
  std::printf("  %-9s %9.3f %9.3f %11s\n", "read", rd.seconds, rd.cpu_seconds, human_bytes(static_cast<double>(rd.peak_rss_bytes)).c_str());
  std::printf("  %-9s %9.3f %9.3f %11s\n", "identify", id.seconds, id.cpu_seconds, human_bytes(static_cast<double>(id.peak_rss_bytes)).c_str());
  std::printf("  %-9s %9.3f %9.3f %11s\n", "diagnose", dg.seconds, dg.cpu_seconds, human_bytes(static_cast<double>(dg.peak_rss_bytes)).c_str());
  const double cpu_ratio = dg.cpu_seconds / id.cpu_seconds;
  // diagnose searches its families on the machine's threads, as the CLI
  // does; identify runs on one: the wall ratio is the user's, the CPU one
  // the work's.
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::printf("  ratio     %8.2fx %8.2fx %9.2fx   (bar: <= 3x time, <= 2x memory; diagnose on %u threads)\n", t_ratio,
              cpu_ratio, m_ratio, threads);
  // The searches' cost: identify against the read it starts with, and the
  // core's passes over the trace (IdentifyResult::core_passes).
  std::printf("  identify / read alone: %.2fx wall; %.3g core passes over the trace\n", id.seconds / rd.seconds, core_passes);
  if (!o.json_path.empty()) {
    const json j = {{"mode", "diagnose_cost"}, {"machine", machine_json()}, {"trace", simulated ? "simulated" : o.cost_csv},
                    {"rate_hz", rate_hz}, {"duration_s", duration_s}, {"repeats", repeats},
                    {"identify", {{"seconds", id.seconds}, {"cpu_seconds", id.cpu_seconds}, {"peak_rss_bytes", id.peak_rss_bytes}}},
                    {"diagnose", {{"seconds", dg.seconds}, {"cpu_seconds", dg.cpu_seconds}, {"peak_rss_bytes", dg.peak_rss_bytes}}},
                    {"read", {{"seconds", rd.seconds}, {"cpu_seconds", rd.cpu_seconds}, {"peak_rss_bytes", rd.peak_rss_bytes}}},
                    {"identify_over_read", id.seconds / rd.seconds}, {"identify_core_passes", core_passes},
                    {"time_ratio", t_ratio}, {"cpu_time_ratio", cpu_ratio}, {"diagnose_threads", threads},
                    {"memory_ratio", std::isfinite(m_ratio) ? json(m_ratio) : json(nullptr)}};
    write_text(o.json_path, j.dump(2) + "\n", end, simulated ? std::vector<std::string>{} : std::vector<std::string>{o.cost_csv});
  }
  return end;
}

RunEnd run_bench(const BenchOptions& o) {
  if (o.stated_conventions && (o.core_only || o.diagnose_cost))
    return RunEnd::refused("--stated-conventions applies to the default set and --scaling, not to --core-only or --diagnose-cost");
  if (o.core_only) return run_core_only(o);
  if (o.diagnose_cost) return run_diagnose_cost(o);
  const Outcome<std::vector<std::string>> methods = parse_methods(o.methods);
  if (!methods.ok()) return RunEnd::refused(methods.error);
  if (o.repeats < 1 || o.ga_population < 5 || o.ga_generations < 0)
    return RunEnd::refused("--repeats must be >= 1, --ga-population >= 5, --ga-generations >= 0");
  return o.scaling ? run_scaling(o, methods.value) : run_default(o, methods.value);
}

}  // namespace feedid::host
