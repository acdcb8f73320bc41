// `feedid blind-bench` (see blind_bench.hpp). Three separate stages:
//
//   1. make_case(): draws a drive, sensor, motion and one label (none, an
//      effect of the catalogue, or "unexplained": a disturbance outside it)
//      with its physical parameters, simulates, and returns the trace and the
//      truth as two separate things;
//   2. diagnose_blind(): gets the trace only (t, x, v, u and which columns
//      exist) and calls diagnose(trace, DiagnoseOptions{}) exactly as the CLI
//      does on a user's file (on one thread: the cases run in parallel);
//   3. the scorer: the only code that reads the truth (the answer key), after
//      all cases are diagnosed.
//
// Cases are independent and seeded from (seed, index), so the result does not
// depend on the number of threads.
#include "blind_bench.hpp"
#include "io/output_file.hpp"

#include "model/constants.hpp"

#include <sys/utsname.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/csv_trace.hpp"
#include "diagnose/diagnose.hpp"
#include "sim/drive_sim.hpp"
#include "identify/identify.hpp"
#include "io/trace.hpp"

namespace feedid::host {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Labels in table order: none, the catalogue, unexplained.
const std::vector<std::string>& labels() {
  static const std::vector<std::string> l = [] {
    std::vector<std::string> v{"none"};
    for (const std::string& k : effect_kinds()) v.push_back(k);
    v.push_back("unexplained");
    v.push_back("pair");  // two catalogue effects at once
    return v;
  }();
  return l;
}

bool catalogued(const std::string& label) {
  if (label == "pair") return true;
  const auto& k = effect_kinds();
  return std::find(k.begin(), k.end(), label) != k.end();
}

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : g_(seed) {}
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(g_); }
  double log_uniform(double lo, double hi) { return std::exp(uniform(std::log(lo), std::log(hi))); }
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(g_); }
  double sign() { return integer(0, 1) ? 1.0 : -1.0; }
  std::uint64_t next() { return g_(); }
  std::mt19937_64& engine() { return g_; }

 private:
  std::mt19937_64 g_;
};

/// Label of every case: the labels in a freshly shuffled order for each run of
/// 10 cases, so the counts are equal (within one) and the order is random.
std::vector<std::string> label_schedule(int cases, std::uint64_t seed, const std::vector<std::string>& deal) {
  Rng rng(splitmix64(seed ^ 0x5DEECE66Dull));
  std::vector<std::string> out;
  std::vector<std::string> deck;
  while (static_cast<int>(out.size()) < cases) {
    if (deck.empty()) {
      deck = deal;
      std::shuffle(deck.begin(), deck.end(), rng.engine());
    }
    out.push_back(deck.back());
    deck.pop_back();
  }
  return out;
}

// ---------------------------------------------------------------------------
// 1. Case generation. The ranges are documented in ranges_markdown() below
//    (and printed into the report); keep both in step.
// ---------------------------------------------------------------------------

/// What the scorer knows and diagnose() never sees.
struct Truth {
  std::string label;
  std::vector<std::string> pair;  ///< the two effects of a "pair" case, sorted
  nlohmann::json effect = nlohmann::json::object();  ///< true parameters, diagnosis names (SI); per effect for a pair
  nlohmann::json setup = nlohmann::json::object();   ///< drive, rate, noise, motion (for the report)
  double effect_rms_N = 0.0;  ///< RMS change of the recorded force the effect causes while moving (N)
};

struct BlindCase {
  Trace trace;  ///< the only thing that goes to the diagnosis
  Truth truth;  ///< the answer key entry
};

/// Where the axis spends its moving time: the 5th to 95th percentile of
/// position over the moving instants (every 5 ms) of the reference path.
/// Position effects are drawn inside it so the motion can show them.
struct Span {
  double lo = 0.0, width = 0.0;
};
Span visited_span(const MotionParams& m, std::uint64_t seed) {
  MotionPath path(m, seed);
  std::vector<double> x;
  for (double t = 0.0; t < m.duration_s; t += 5e-3) {
    const PathPoint p = path.at(t);
    if (p.v_m_s != 0.0) x.push_back(p.x_m);
  }
  if (x.size() < 20) return {0.0, m.max_travel_m};
  std::sort(x.begin(), x.end());
  const double lo = x[x.size() / 20], hi = x[x.size() * 19 / 20];
  return {lo, hi - lo};
}

/// What the effect strengths are scaled to.
struct EffectScale {
  double x_lo, travel, dt, sigma, fc, v_fast, duration;
};

/// Sets one effect's parameters in c.effects; returns its truth in the
/// diagnosis's names. Delays start at 1.5 periods: up to about one period
/// (0.6 beyond a held command's -1/2) a lag is what logging conventions
/// explain, and the diagnosis does not name it (docs/diagnosis.md, "Timing").
/// Draws an effect outside the catalogue: a vibrating auxiliary unit, or a load force that wanders.
void draw_unexplained(Rng& rng, Effects& e) {
  if (rng.integer(0, 1) == 0) {
    e.disturbance_amplitude_N = rng.uniform(3.0, 15.0);
    e.disturbance_frequency_hz = rng.log_uniform(0.7, 7.0);
    e.disturbance_phase_rad = rng.uniform(0.0, 2.0 * kPi);
  } else {
    e.wander_force_N = rng.uniform(3.0, 10.0);
    e.wander_time_constant_s = rng.uniform(1.0, 5.0);
  }
}

/// Draws one catalogue effect's parameters into e; the force at top speed
/// of a quadratic viscous term (0 for the others).
double draw_catalogue_effect(Effect which, Rng& rng, const EffectScale& s, Effects& e) {
  switch (which) {
    case Effect::offset: {
      const double sign = rng.sign();  // draws in a fixed order (operand order is unspecified)
      e.load.offset_N = sign * rng.uniform(3.0, 20.0);
      break;
    }
    case Effect::position_ripple:
      e.ripple_amplitude_N = rng.uniform(2.0, 10.0);
      e.ripple_period_m = rng.log_uniform(2e-3, std::min(20e-3, s.travel / 5.0));
      e.ripple_phase_rad = rng.uniform(0.0, 2.0 * kPi);
      break;
    case Effect::position_friction: {
      e.position_friction_N = rng.uniform(5.0, 20.0);
      const double width = rng.uniform(0.2, 0.4) * s.travel;
      e.position_friction_x_min_m = s.x_lo + rng.uniform(0.05 * s.travel, 0.95 * s.travel - width);
      e.position_friction_x_max_m = e.position_friction_x_min_m + width;
      break;
    }
    case Effect::thermal_drift:
      e.drift_fraction = rng.uniform(0.2, 0.6);
      e.drift_time_constant_s = rng.uniform(10.0, std::min(40.0, s.duration / 2.0));
      break;
    case Effect::quadratic_viscous: {
      // c2 v_fast^2 = r sigma v_fast, r in U(0.1, 0.25), and at least 8 N.
      const double top_speed_force = std::max(rng.uniform(0.1, 0.25) * s.sigma * s.v_fast, 8.0);
      e.quadratic_c2_Ns2_m2 = top_speed_force / (s.v_fast * s.v_fast);
      return top_speed_force;
    }
    case Effect::presliding_hysteresis:
      e.presliding_force_N = rng.uniform(0.3, 0.8) * s.fc;
      e.presliding_distance_m = rng.log_uniform(5e-6, 50e-6);
      break;
    case Effect::compliance:
      e.compliance_frequency_hz = rng.uniform(15.0, 60.0);
      e.compliance_mass_fraction = rng.uniform(0.2, 0.5);
      e.compliance_damping_ratio = rng.uniform(0.03, 0.08);
      break;
    case Effect::delay: e.delay_s = rng.uniform(1.5, 5.0) * s.dt; break;
    case Effect::disturbance:
    case Effect::wander: break;  // drawn by draw_unexplained
  }
  return 0.0;
}

/// Sets one effect's parameters in c.effects; returns its truth in the
/// diagnosis's names. Delays start at 1.5 periods: up to about one period
/// (0.6 beyond a held command's -1/2) a lag is what logging conventions
/// explain, and the diagnosis does not name it (docs/diagnosis.md, "Timing").
nlohmann::json draw_effect(const std::string& label, Rng& rng, const EffectScale& s, SimConfig& c) {
  Effects& e = c.effects;
  double top_speed_force = 0.0;
  if (label == "unexplained") draw_unexplained(rng, e);
  else if (const EffectInfo* info = find_effect(label)) top_speed_force = draw_catalogue_effect(info->effect, rng, s, e);
  const nlohmann::json on = effects_json(e, c.drive);
  const char* key = label != "unexplained" ? label.c_str()
                                           : effect_name(e.wander_force_N > 0 ? Effect::wander : Effect::disturbance);
  nlohmann::json truth = on.at(key);
  if (label == effect_name(Effect::quadratic_viscous)) truth["force_at_top_speed_N"] = top_speed_force;
  if (label == effect_name(Effect::delay)) truth["delay_samples"] = e.delay_s / s.dt;
  return truth;
}

/// How the drive logs: force held, instant or averaged over the period;
/// velocity as a backward difference, a moving average of 2-5 of them, or
/// a first-order low-pass of 0.5-2 periods (NOTES.md, "Logging conventions").
void draw_logging(Rng& rng, LoggingParams& l, double dt) {
  const int f = rng.integer(0, 2), v = rng.integer(0, 2);
  l.force = f == 0 ? ForceLog::held : (f == 1 ? ForceLog::instant : ForceLog::averaged);
  l.velocity = v == 0 ? VelocityLog::backward_difference : (v == 1 ? VelocityLog::moving_average : VelocityLog::low_pass);
  l.velocity_average_samples = rng.integer(2, 5);
  l.velocity_time_constant_s = rng.uniform(0.5, 2.0) * dt;
}

/// The plants and motion programs cases draw from (BlindOptions).
struct CaseMix {
  std::vector<PlantKind> plants;
  std::vector<Program> programs;
};

namespace {
// The draws of one case, in the order the generator makes them (the order
// fixes the case for a seed).

/// Drive: mass log-uniform 20..400 kg; each friction magnitude of the
/// default drive scaled by U(0.5, 1.5), vs U(1, 5) mm/s; the negative side
/// differs from the positive by U(0.9, 1.1) per parameter.
void draw_drive(Rng& rng, DriveParams& d) {
  d.mass_kg = rng.log_uniform(20.0, 400.0);
  d.pos.viscous_Ns_m = 700.0 * rng.uniform(0.5, 1.5);
  d.pos.coulomb_N = 25.0 * rng.uniform(0.5, 1.5);
  d.pos.breakaway_N = 8.0 * rng.uniform(0.5, 1.5);
  d.pos.stribeck_velocity_m_s = rng.uniform(1e-3, 5e-3);
  d.neg.viscous_Ns_m = d.pos.viscous_Ns_m * rng.uniform(0.9, 1.1);
  d.neg.coulomb_N = d.pos.coulomb_N * rng.uniform(0.9, 1.1);
  d.neg.breakaway_N = d.pos.breakaway_N * rng.uniform(0.9, 1.1);
  d.neg.stribeck_velocity_m_s = d.pos.stribeck_velocity_m_s * rng.uniform(0.9, 1.1);
}

/// Servo rate 1..8 kHz, loop bandwidth, encoder and force noise.
void draw_servo_and_sensors(Rng& rng, SimConfig& c) {
  c.controller.servo_rate_hz = 10.0 * std::round(rng.log_uniform(100.0, 800.0));
  c.controller.velocity_bandwidth_hz = rng.uniform(25.0, 50.0);
  c.sensors.encoder_resolution_m = rng.log_uniform(1e-8, 1e-7);
  c.sensors.force_noise_N = rng.uniform(0.1, 1.0);
}

/// Motion, the simulator's seed, the plant and the program.
void draw_motion(Rng& rng, SimConfig& c, const CaseMix& mix) {
  MotionParams& m = c.motion;
  m.duration_s = rng.uniform(40.0, 90.0);
  m.max_travel_m = rng.uniform(0.1, 0.4);
  m.fastest_speed_m_s = rng.uniform(0.08, 0.25);
  m.slowest_speed_m_s = rng.log_uniform(1e-4, 5e-4);
  m.speed_levels = rng.integer(10, 16);
  m.acceleration_m_s2 = rng.uniform(0.5, 2.0);
  m.cruise_time_s = rng.uniform(0.4, 1.0);
  m.dwell_s = rng.uniform(0.1, 0.3);
  c.seed = rng.next();
  c.plant = mix.plants[static_cast<std::size_t>(rng.integer(0, static_cast<int>(mix.plants.size()) - 1))];
  m.program = mix.programs[static_cast<std::size_t>(rng.integer(0, static_cast<int>(mix.programs.size()) - 1))];
}

/// The label's effect(s) into c and the truth: none, one, or a pair of two
/// different effects the diagnosis can see while the axis moves.
void draw_effects(Rng& rng, const std::string& label, const EffectScale& scale, SimConfig& c, Truth& t) {
  if (label == "pair") {
    std::vector<std::string> pool;
    for (const std::string& k : effect_kinds())
      if (k != effect_name(Effect::offset)) pool.push_back(k);
    const std::size_t a = static_cast<std::size_t>(rng.integer(0, static_cast<int>(pool.size()) - 1));
    std::size_t b = static_cast<std::size_t>(rng.integer(0, static_cast<int>(pool.size()) - 2));
    if (b >= a) ++b;
    t.pair = {pool[a], pool[b]};
    std::sort(t.pair.begin(), t.pair.end());
    for (const auto& k : t.pair) t.effect[k] = draw_effect(k, rng, scale, c);
  } else if (label != "none") {
    t.effect = draw_effect(label, rng, scale, c);
  }
}

nlohmann::json setup_json(const SimConfig& c, const Span& span) {
  const MotionParams& m = c.motion;
  return {{"plant", plant_name(c.plant)},
          {"program", program_name(m.program)},
          {"drive", model_json(c.drive)},
          {"rate_hz", c.controller.servo_rate_hz},
          {"velocity_bandwidth_hz", c.controller.velocity_bandwidth_hz},
          {"encoder_m", c.sensors.encoder_resolution_m},
          {"force_noise_N", c.sensors.force_noise_N},
          {"duration_s", m.duration_s},
          {"visited_m", {span.lo, span.lo + span.width}},
          {"fastest_speed_m_s", m.fastest_speed_m_s},
          {"slowest_speed_m_s", m.slowest_speed_m_s},
          {"speed_levels", m.speed_levels},
          {"acceleration_m_s2", m.acceleration_m_s2},
          {"cruise_time_s", m.cruise_time_s},
          {"dwell_s", m.dwell_s},
          {"max_travel_m", m.max_travel_m},
          {"sim_seed", c.seed},
          {"force_log", force_log_name(c.logging.force)},
          {"velocity_log", velocity_log_name(c.logging.velocity)},
          {"velocity_log_samples", c.logging.velocity_average_samples},
          {"velocity_log_tau_s", c.logging.velocity_time_constant_s}};
}

/// Size of the effects in the recorded force: RMS of the difference to the
/// same case simulated without them (same seed, same noise draws), over the
/// samples moving in both; for the scorer's report only.
double effect_rms_N(const SimConfig& c, const Trace& with) {
  SimConfig clean = c;
  clean.effects = Effects{};
  const Trace ref = simulate(clean);
  double ss = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < ref.samples.size() && k < with.samples.size(); ++k) {
    if (ref.samples[k].v_m_s == 0.0 || with.samples[k].v_m_s == 0.0) continue;
    const double dd = with.samples[k].u_N - ref.samples[k].u_N;
    ss += dd * dd;
    ++n;
  }
  return n ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
}

}  // namespace

BlindCase make_case(std::uint64_t seed, int index, const std::string& label, const CaseMix& mix) {
  Rng rng(splitmix64(seed * 0x100000001B3ull + static_cast<std::uint64_t>(index) + 1));
  SimConfig c;
  draw_drive(rng, c.drive);
  draw_servo_and_sensors(rng, c);
  draw_motion(rng, c, mix);

  const Span span = visited_span(c.motion, c.seed);
  const double dt = 1.0 / c.controller.servo_rate_hz;
  const double sigma = 0.5 * (c.drive.pos.viscous_Ns_m + c.drive.neg.viscous_Ns_m);
  const double fc = 0.5 * (c.drive.pos.coulomb_N + c.drive.neg.coulomb_N);
  Truth t;
  t.label = label;
  draw_effects(rng, label, EffectScale{span.lo, span.width, dt, sigma, fc, c.motion.fastest_speed_m_s, c.motion.duration_s},
               c, t);
  draw_logging(rng, c.logging, dt);
  t.setup = setup_json(c, span);

  BlindCase out;
  out.trace = simulate(c);
  out.trace.source = "blind case " + std::to_string(index + 1);  // no hint of the label
  t.effect_rms_N = label != "none" ? effect_rms_N(c, out.trace) : 0.0;
  out.truth = std::move(t);
  return out;
}

// ---------------------------------------------------------------------------
// 2. The blind part: sees a Trace, nothing else.
// ---------------------------------------------------------------------------

struct Verdict {
  std::string effect;  ///< none, unexplained, an effect kind; "error" when diagnose failed
  std::string error;
  nlohmann::json parameters = nlohmann::json::object();
  double rms_base_N = kNaN, rms_augmented_N = kNaN, noise_floor_N = kNaN, closed_fraction = kNaN;
  double max_z = kNaN;  ///< largest z of a plausible candidate at the first step (calibration)
  std::vector<std::string> named;  ///< every effect forward selection named, in order (not unexplained)
  nlohmann::json ambiguous = nlohmann::json::array();  ///< the kinds of each of diagnose's ambiguities
};

Verdict diagnose_blind(const Trace& trace) {
  Verdict v;
  try {
    DiagnoseOptions opt;
    opt.threads = 1;  // the cases already share the machine's threads; a diagnosis is the same on any number
    const DiagnoseResult r = diagnose(trace, opt);
    if (!r.error.empty()) {
      v.effect = "error";
      v.error = r.error;
      return v;
    }
    v.effect = r.effect;
    if (r.effect_parameters.is_object()) v.parameters = r.effect_parameters;
    // An offset is reported as ambiguous with Coulomb friction that differs
    // by direction (the data cannot separate them): that report names it.
    for (const auto& a : r.ambiguities)
      if (r.effect == "none" && a.contains("offset_N")) {
        v.effect = effect_name(Effect::offset);
        v.parameters = {{"force_N", a["offset_N"]}};
      }
    for (const auto& e : r.effects) v.named.push_back(e.kind);
    for (const auto& a : r.ambiguities) v.ambiguous.push_back(a.value("kinds", nlohmann::json::array()));
    v.max_z = -std::numeric_limits<double>::infinity();
    for (const auto& c : r.candidates)
      if (!c.indistinguishable && c.note.rfind("not physical", 0) != 0) v.max_z = std::max(v.max_z, c.z_statistic);
    v.rms_base_N = r.rms_base_N;
    v.rms_augmented_N = r.rms_augmented_N;
    v.noise_floor_N = r.noise_floor_N;
    v.closed_fraction = r.closed_fraction;
  } catch (const std::exception& ex) {
    v.effect = "error";
    v.error = ex.what();
  }
  const auto& l = labels();
  if (v.effect != "error" && std::find(l.begin(), l.end(), v.effect) == l.end()) {
    v.error = "diagnose named an effect outside the labels: " + v.effect;
    v.effect = "error";
  }
  return v;
}

// ---------------------------------------------------------------------------
// 3. Scoring (reads the answer key).
// ---------------------------------------------------------------------------

/// The confusion matrix's column: two or more effects named count as "pair".
std::string verdict_column(const Verdict& v) { return v.named.size() >= 2 ? std::string("pair") : v.effect; }

/// Right: the true label, and no effect named that is not there (a pair:
/// both of its effects and no third).
bool named_right(const Truth& t, const Verdict& v) {
  if (t.label == "pair") {
    std::vector<std::string> named = v.named;
    std::sort(named.begin(), named.end());
    return named == t.pair;
  }
  return verdict_column(v) == t.label;
}

/// The verdict for the per-case line: named effects joined by "+".
std::string verdict_text(const Verdict& v) {
  if (v.named.size() < 2) return v.effect;
  std::string s;
  for (const auto& k : v.named) s += (s.empty() ? "" : "+") + k;
  return s;
}

struct CaseRecord {
  Truth truth;
  Verdict verdict;
  double generate_s = 0.0, diagnose_s = 0.0;
  std::size_t samples = 0;
};

double num(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return kNaN;
  return j[key].get<double>();
}

double rel_err(double fit, double truth) {
  if (!std::isfinite(fit) || !std::isfinite(truth) || truth == 0.0) return kNaN;
  return std::fabs(fit - truth) / std::fabs(truth);
}

/// Key and secondary parameter errors of a correctly named case (NaN: not reported).
struct ParamError {
  double key = kNaN, second = kNaN;
};

/// Name of the key and secondary parameter per effect (diagnosis JSON names; effects.hpp).
std::pair<std::string, std::string> param_names(const std::string& kind) {
  const EffectInfo* i = find_effect(kind);
  return i ? std::pair<std::string, std::string>{i->key, i->second} : std::pair<std::string, std::string>{"", ""};
}

ParamError parameter_error(const std::string& kind, const nlohmann::json& truth, const nlohmann::json& fit) {
  ParamError e;
  if (kind == "position_friction") {
    const double a = num(truth, "x_min_m"), b = num(truth, "x_max_m");
    const double fa = num(fit, "x_min_m"), fb = num(fit, "x_max_m");
    if (std::isfinite(fa) && std::isfinite(fb)) e.key = (std::fabs(fa - a) + std::fabs(fb - b)) / (b - a);
    e.second = rel_err(num(fit, "delta_N"), num(truth, "delta_N"));
    return e;
  }
  const auto names = param_names(kind);
  if (!names.first.empty()) e.key = rel_err(num(fit, names.first.c_str()), num(truth, names.first.c_str()));
  if (!names.second.empty()) e.second = rel_err(num(fit, names.second.c_str()), num(truth, names.second.c_str()));
  return e;
}

double median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string pct(double x, int decimals = 1) {
  if (!std::isfinite(x)) return "-";
  char b[32];
  std::snprintf(b, sizeof b, "%.*f %%", decimals, 100.0 * x);
  return b;
}

std::string fmt(const char* f, double x) {
  if (!std::isfinite(x)) return "-";
  char b[64];
  std::snprintf(b, sizeof b, f, x);
  return b;
}

/// Short column names for the confusion matrix.
std::string short_name(const std::string& l) {
  const EffectInfo* i = find_effect(l);
  return i ? i->short_name : l;
}

std::string machine_description() {
  struct utsname u {};
  std::string arch = uname(&u) == 0 ? u.machine : "unknown";
  return arch + ", " + std::to_string(std::thread::hardware_concurrency()) + " hardware threads";
}

/// The ranges make_case() draws from, as Markdown (keep in step with make_case).
std::string ranges_markdown() {
  return R"(| drawn | range |
| --- | --- |
| label | none, the 8 catalogue effects, unexplained, pair: each block of 11 cases holds every label once, in random order (`--labels` deals a subset) |
| mass | 20 .. 400 kg, log-uniform |
| friction (+ side) | default drive (sigma 700 N s/m, Fc 25 N, Fs 8 N) each scaled by U(0.5, 1.5); vs U(1, 5) mm/s |
| friction (- side) | each + side value times U(0.9, 1.1) |
| servo / sampling rate | 1 .. 4 kHz (10 Hz steps); velocity-loop bandwidth 25 .. 50 Hz |
| encoder resolution | 1e-8 .. 1e-7 m, log-uniform |
| logging | force held, instant or averaged over the period; velocity a backward difference, a moving average of 2 .. 5 of them, or a first-order low-pass of 0.5 .. 2 periods (each equally likely) |
| force noise | 0.1 .. 1 N std, white |
| motion | 40 .. 90 s; 10 .. 16 log-spaced peak speeds from 0.1 .. 0.5 mm/s (log-uniform) to 80 .. 250 mm/s; acceleration 0.5 .. 2 m/s^2; cruise 0.4 .. 1 s; dwell 0.1 .. 0.3 s; travel limit 0.1 .. 0.4 m (travel L below = longest stroke actually made) |
| offset | +-(3 .. 20) N, random sign |
| position_ripple | amplitude 2 .. 10 N; period 2 mm .. min(20 mm, L/5), log-uniform; phase 0 .. 2 pi |
| position_friction | 5 .. 20 N over a range 20 .. 40 % of L wide, inside 5 .. 95 % of L |
| thermal_drift | fraction 0.2 .. 0.6 (viscous x (1 + D e^-t/tau), Coulomb x (1 + 0.3 D e^-t/tau)); tau 10 s .. min(40 s, duration/2) |
| quadratic_viscous | c2 with c2 V^2 = max(r sigma V, 8 N), r 0.1 .. 0.25, V the fastest peak speed |
| presliding_hysteresis | Fp 0.3 .. 0.8 Fc; d 5 .. 50 um, log-uniform (extra force -2 Fp sign(v) e^-r/d after each reversal) |
| compliance | free resonance 15 .. 60 Hz; load share of the mass 0.2 .. 0.5; damping ratio 0.03 .. 0.08; encoder on the motor side |
| delay | 1.5 .. 5 sample periods (fractional, linear interpolation); below about one period a lag is a logging convention, not named |
| pair | two different catalogue effects other than offset, each drawn as in its own row; right when exactly those two are named |
| unexplained | time-periodic load force 3 .. 15 N at 0.7 .. 7 Hz (log-uniform), random phase: outside the catalogue |
)";
}

struct Scores {
  std::vector<std::vector<int>> confusion;  ///< [true label][named label or error]
  int correct = 0, total = 0;
  double accuracy = 0.0;
  double median_closed_catalogued = kNaN;        ///< over every case with a catalogued true effect
  double median_closed_named_right = kNaN;       ///< over those named right
  double median_gap_ratio_none = kNaN;           ///< base RMS / noise floor on the no-effect cases
  struct PerEffect {
    std::string label;
    int cases = 0, named_right = 0;
    double key_error = kNaN, second_error = kNaN, closed = kNaN, gap_ratio = kNaN, effect_rms = kNaN;
  };
  std::vector<PerEffect> per_effect;
  /// One cell of the matrix: a plant and a motion program.
  struct Cell {
    std::string plant, program;
    int cases = 0, right = 0;
  };
  std::vector<Cell> cells;  ///< sorted by plant, then program
  int none_cases = 0, false_alarms = 0;  ///< effect-free cases, and those where anything was named
  bool bar_accuracy = false, bar_closed = false, bar_false_alarms = false;
};

Scores::Cell& cell_of(Scores& s, const Truth& t) {
  const std::string plant = t.setup.value("plant", std::string("?")), program = t.setup.value("program", std::string("?"));
  for (auto& c : s.cells)
    if (c.plant == plant && c.program == program) return c;
  s.cells.push_back({plant, program, 0, 0});
  return s.cells.back();
}

Scores score(const std::vector<CaseRecord>& recs) {
  const auto& l = labels();
  const std::size_t L = l.size();
  auto index_of = [&](const std::string& s) {
    const auto it = std::find(l.begin(), l.end(), s);
    return it == l.end() ? L : static_cast<std::size_t>(it - l.begin());  // L = error column
  };
  Scores s;
  s.confusion.assign(L, std::vector<int>(L + 1, 0));
  std::vector<double> closed_cat, closed_right, gap_none;
  std::vector<std::vector<double>> key(L), second(L), closed_by(L), gap_by(L), size_by(L);
  s.per_effect.resize(L);
  for (std::size_t i = 0; i < L; ++i) s.per_effect[i].label = l[i];
  for (const CaseRecord& r : recs) {
    const std::size_t ti = index_of(r.truth.label), ni = index_of(verdict_column(r.verdict));
    ++s.confusion[ti][ni];
    ++s.total;
    const bool right = named_right(r.truth, r.verdict);
    if (right) ++s.correct;
    Scores::Cell& cell = cell_of(s, r.truth);
    ++cell.cases;
    if (right) ++cell.right;
    if (r.truth.label == "none") {
      ++s.none_cases;
      if (!right) ++s.false_alarms;
    }
    Scores::PerEffect& pe = s.per_effect[ti];
    ++pe.cases;
    if (right) ++pe.named_right;
    const double gap = r.verdict.noise_floor_N > 0 ? r.verdict.rms_base_N / r.verdict.noise_floor_N : kNaN;
    gap_by[ti].push_back(gap);
    size_by[ti].push_back(r.truth.effect_rms_N);
    if (r.truth.label == "none") gap_none.push_back(gap);
    if (catalogued(r.truth.label)) {
      // A failed diagnosis closes nothing.
      const double c = r.verdict.effect == "error" ? 0.0 : r.verdict.closed_fraction;
      closed_cat.push_back(c);
      closed_by[ti].push_back(c);
      if (right) closed_right.push_back(c);
      if (right && r.truth.label != "pair") {
        const ParamError e = parameter_error(r.truth.label, r.truth.effect, r.verdict.parameters);
        key[ti].push_back(e.key);
        second[ti].push_back(e.second);
      }
    }
  }
  for (std::size_t i = 0; i < L; ++i) {
    s.per_effect[i].key_error = median(key[i]);
    s.per_effect[i].second_error = median(second[i]);
    s.per_effect[i].closed = median(closed_by[i]);
    s.per_effect[i].gap_ratio = median(gap_by[i]);
    s.per_effect[i].effect_rms = median(size_by[i]);
  }
  s.accuracy = s.total ? static_cast<double>(s.correct) / s.total : 0.0;
  s.median_closed_catalogued = median(closed_cat);
  s.median_closed_named_right = median(closed_right);
  s.median_gap_ratio_none = median(gap_none);
  std::sort(s.cells.begin(), s.cells.end(), [](const Scores::Cell& a, const Scores::Cell& b) {
    return a.plant != b.plant ? a.plant < b.plant : a.program < b.program;
  });
  s.bar_accuracy = s.accuracy >= 0.9;
  s.bar_false_alarms = 10 * s.false_alarms <= s.none_cases;
  s.bar_closed = closed_cat.empty() || s.median_closed_catalogued >= 0.8;  // no catalogued case: nothing to close
  return s;
}

// --- rendering ------------------------------------------------------------

std::string confusion_text(const Scores& s) {
  const auto& l = labels();
  std::ostringstream o;
  char b[64];
  std::snprintf(b, sizeof b, "%-12s", "true \\ named");
  o << b;
  for (const auto& x : l) {
    std::snprintf(b, sizeof b, " %11s", short_name(x).c_str());
    o << b;
  }
  o << "       error\n";
  for (std::size_t i = 0; i < l.size(); ++i) {
    std::snprintf(b, sizeof b, "%-12s", short_name(l[i]).c_str());
    o << b;
    for (std::size_t j = 0; j <= l.size(); ++j) {
      std::snprintf(b, sizeof b, " %11d", s.confusion[i][j]);
      o << b;
    }
    o << "\n";
  }
  return o.str();
}

std::string confusion_markdown(const Scores& s) {
  const auto& l = labels();
  std::ostringstream o;
  o << "| true \\ named |";
  for (const auto& x : l) o << " " << short_name(x) << " |";
  o << " error |\n| --- |";
  for (std::size_t j = 0; j <= l.size(); ++j) o << " ---: |";
  o << "\n";
  for (std::size_t i = 0; i < l.size(); ++i) {
    o << "| " << short_name(l[i]) << " |";
    for (std::size_t j = 0; j <= l.size(); ++j) {
      const int n = s.confusion[i][j];
      if (n == 0) o << " . |";
      else if (i == j) o << " **" << n << "** |";
      else o << " " << n << " |";
    }
    o << "\n";
  }
  return o.str();
}

std::string per_effect_text(const Scores& s) {
  std::ostringstream o;
  char b[256];
  std::snprintf(b, sizeof b, "%-22s %5s %6s %7s  %-34s %9s  %-20s %9s  %9s %9s\n", "true effect", "cases", "right",
                "size N", "key parameter", "med.err", "second", "med.err", "med.gap", "closed");
  o << b;
  for (const auto& p : s.per_effect) {
    const auto names = param_names(p.label);
    std::snprintf(b, sizeof b, "%-22s %5d %6d %7s  %-34s %9s  %-20s %9s  %9s %9s\n", p.label.c_str(), p.cases,
                  p.named_right, fmt("%.3g", p.effect_rms).c_str(),
                  names.first.empty() ? "-" : names.first.c_str(), pct(p.key_error).c_str(),
                  names.second.empty() ? "-" : names.second.c_str(), pct(p.second_error).c_str(),
                  fmt("%.2f", p.gap_ratio).c_str(), catalogued(p.label) ? pct(p.closed, 0).c_str() : "-");
    o << b;
  }
  return o.str();
}

std::string cells_text(const Scores& s) {
  std::ostringstream o;
  char b[128];
  std::snprintf(b, sizeof b, "%-8s %-11s %6s %6s %8s\n", "plant", "motion", "cases", "right", "share");
  o << b;
  for (const auto& c : s.cells) {
    std::snprintf(b, sizeof b, "%-8s %-11s %6d %6d %8s\n", c.plant.c_str(), c.program.c_str(), c.cases, c.right,
                  pct(c.cases ? static_cast<double>(c.right) / c.cases : kNaN, 0).c_str());
    o << b;
  }
  return o.str();
}

std::string cells_markdown(const Scores& s) {
  std::ostringstream o;
  o << "| plant | motion | cases | named right | share |\n| --- | --- | ---: | ---: | ---: |\n";
  for (const auto& c : s.cells)
    o << "| " << c.plant << " | " << c.program << " | " << c.cases << " | " << c.right << " | "
      << pct(c.cases ? static_cast<double>(c.right) / c.cases : kNaN, 0) << " |\n";
  return o.str();
}

std::string per_effect_markdown(const Scores& s) {
  std::ostringstream o;
  o << "| true effect | cases | named right | median effect size (N) | key parameter | median rel. error | second parameter "
       "| median rel. error | median base RMS / noise floor | median gap closed |\n";
  o << "| --- | ---: | ---: | ---: | --- | ---: | --- | ---: | ---: | ---: |\n";
  for (const auto& p : s.per_effect) {
    const auto names = param_names(p.label);
    o << "| " << p.label << " | " << p.cases << " | " << p.named_right << " | " << fmt("%.3g", p.effect_rms) << " | "
      << (names.first.empty() ? "-" : "`" + names.first + "`") << " | " << pct(p.key_error) << " | "
      << (names.second.empty() ? "-" : "`" + names.second + "`") << " | " << pct(p.second_error) << " | "
      << fmt("%.2f", p.gap_ratio) << " | " << (catalogued(p.label) ? pct(p.closed, 0) : "-") << " |\n";
  }
  return o.str();
}

nlohmann::json finite_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

nlohmann::json to_json(const std::vector<CaseRecord>& recs, const Scores& s, const BlindOptions& opt,
                       const std::string& command, double wall_s, int threads) {
  nlohmann::json j;
  j["command"] = command;
  j["machine"] = machine_description();
  j["threads"] = threads;
  j["wall_time_s"] = wall_s;
  j["cases"] = opt.cases;
  j["seed"] = opt.seed;
  j["labels"] = labels();
  nlohmann::json conf = nlohmann::json::object();
  const auto& l = labels();
  for (std::size_t i = 0; i < l.size(); ++i) {
    nlohmann::json row = nlohmann::json::object();
    for (std::size_t k = 0; k <= l.size(); ++k)
      if (s.confusion[i][k]) row[k < l.size() ? l[k] : "error"] = s.confusion[i][k];
    conf[l[i]] = row;
  }
  j["confusion"] = conf;
  j["accuracy"] = s.accuracy;
  j["median_closed_fraction_catalogued"] = finite_or_null(s.median_closed_catalogued);
  j["median_closed_fraction_named_right"] = finite_or_null(s.median_closed_named_right);
  j["median_gap_ratio_none"] = finite_or_null(s.median_gap_ratio_none);
  j["false_alarms"] = {{"effect_free_cases", s.none_cases}, {"false_alarms", s.false_alarms}};
  nlohmann::json cells = nlohmann::json::array();
  for (const auto& c : s.cells) cells.push_back({{"plant", c.plant}, {"program", c.program}, {"cases", c.cases}, {"named_right", c.right}});
  j["cells"] = cells;
  j["bar"] = {{"accuracy_min", 0.9},
              {"median_closed_min", 0.8},
              {"false_alarms_per_10_effect_free_max", 1},
              {"accuracy_met", s.bar_accuracy},
              {"closed_met", s.bar_closed},
              {"false_alarms_met", s.bar_false_alarms}};
  nlohmann::json pe = nlohmann::json::array();
  for (const auto& p : s.per_effect) {
    const auto names = param_names(p.label);
    pe.push_back({{"label", p.label},
                  {"cases", p.cases},
                  {"named_right", p.named_right},
                  {"key_parameter", names.first},
                  {"median_key_rel_error", finite_or_null(p.key_error)},
                  {"second_parameter", names.second},
                  {"median_second_rel_error", finite_or_null(p.second_error)},
                  {"median_gap_ratio", finite_or_null(p.gap_ratio)},
                  {"median_effect_rms_N", finite_or_null(p.effect_rms)},
                  {"median_closed_fraction", finite_or_null(p.closed)}});
  }
  j["per_effect"] = pe;
  nlohmann::json cs = nlohmann::json::array();
  for (std::size_t i = 0; i < recs.size(); ++i) {
    const CaseRecord& r = recs[i];
    nlohmann::json named = {{"effect", r.verdict.effect},
                            {"parameters", r.verdict.parameters},
                            {"rms_base_N", finite_or_null(r.verdict.rms_base_N)},
                            {"rms_augmented_N", finite_or_null(r.verdict.rms_augmented_N)},
                            {"noise_floor_N", finite_or_null(r.verdict.noise_floor_N)},
                            {"closed_fraction", finite_or_null(r.verdict.closed_fraction)},
                            {"max_z", finite_or_null(r.verdict.max_z)},
                            {"effects", r.verdict.named},
                            {"ambiguous", r.verdict.ambiguous}};
    if (!r.verdict.error.empty()) named["error"] = r.verdict.error;
    cs.push_back({{"case", i + 1},
                  {"truth", {{"effect", r.truth.label}, {"pair", r.truth.pair}, {"parameters", r.truth.effect}, {"effect_rms_N", r.truth.effect_rms_N}}},
                  {"setup", r.truth.setup},
                  {"named", named},
                  {"samples", r.samples},
                  {"generate_s", r.generate_s},
                  {"diagnose_s", r.diagnose_s}});
  }
  j["case_list"] = cs;
  return j;
}

std::string markdown(const Scores& s, const std::string& command, double wall_s, int threads, double gen_s,
                     double diag_s, const BlindOptions& opt) {
  std::ostringstream o;
  char b[512];
  o << "## Blind benchmark of the diagnosis\n\n";
  o << "Made with `" << command << "` on " << machine_description() << " (" << threads
    << " worker threads). Wall time " << fmt("%.0f", wall_s) << " s; summed over cases: simulation "
    << fmt("%.0f", gen_s) << " s, diagnosis " << fmt("%.0f", diag_s) << " s.\n\n";
  o << "Each case is a simulated trace (`feedid simulate` physics) with one randomly chosen label; `diagnose` "
       "gets only the trace (t, x, v, u) with default options, the labels stay in the scorer.\n\n";
  o << "| criterion | bar | result | |\n| --- | --- | --- | --- |\n";
  std::snprintf(b, sizeof b, "| right effect named (none, the catalogue, unexplained) | >= 90 %% | %s (%d of %d) | %s |\n",
                pct(s.accuracy).c_str(), s.correct, s.total, s.bar_accuracy ? "met" : "**missed**");
  o << b;
  std::snprintf(b, sizeof b,
                "| median held-out gap closed, of its excess over the noise floor (cases with a catalogued effect) | "
                ">= 80 %% | %s | %s |\n",
                pct(s.median_closed_catalogued).c_str(), s.bar_closed ? "met" : "**missed**");
  o << b;
  std::snprintf(b, sizeof b, "| false alarms on effect-free traces | <= 1 in 10 | %d of %d | %s |\n", s.false_alarms,
                s.none_cases, s.bar_false_alarms ? "met" : "**missed**");
  o << b;
  o << "\nBy cell of the matrix (plant: the closed-loop drive or the independent open-loop plant; motion program):\n\n"
    << cells_markdown(s);
  o << "\nConfusion matrix (rows: true label, columns: label named by `diagnose`; error: diagnose returned an error):\n\n";
  o << confusion_markdown(s) << "\n";
  o << "Parameters fitted by `diagnose` against the truth, on the cases whose effect it named right (relative error "
       "|fit - true| / |true|; for position_friction the key error is (|x_min error| + |x_max error|) / true width). "
       "Effect size: RMS change of the recorded force while moving, against the same case simulated without the "
       "effect (same seed). Gap: held-out RMS force residual of the base model over the noise floor; closed: the share of that gap's "
       "excess the named effect removes (0 when none or unexplained is named):\n\n";
  o << per_effect_markdown(s) << "\n";
  std::snprintf(b, sizeof b,
                "Median gap closed over the cases named right: %s. Median gap ratio on the no-effect cases: %s.\n\n",
                pct(s.median_closed_named_right).c_str(), fmt("%.2f", s.median_gap_ratio_none).c_str());
  o << b;
  o << "How the " << opt.cases << " cases are drawn (seed " << opt.seed << "; every case is reproducible from the seed "
    << "and its number):\n\n"
    << ranges_markdown();
  return o.str();
}

}  // namespace

nlohmann::json effects_json(const Effects& e, const DriveParams& d) {
  const double sigma = 0.5 * (d.pos.viscous_Ns_m + d.neg.viscous_Ns_m);
  const double fc = 0.5 * (d.pos.coulomb_N + d.neg.coulomb_N);
  nlohmann::json j = nlohmann::json::object();
  for (const EffectInfo& info : effect_table()) {
    if (!effect_on(e, info.effect)) continue;
    nlohmann::json& x = j[info.name];
    switch (info.effect) {
      case Effect::offset: x = {{"force_N", e.load.offset_N}}; break;
      case Effect::position_ripple:
        x = {{"period_m", e.ripple_period_m}, {"amplitude_N", e.ripple_amplitude_N}, {"phase_rad", e.ripple_phase_rad}};
        break;
      case Effect::position_friction:
        x = {{"x_min_m", e.position_friction_x_min_m}, {"x_max_m", e.position_friction_x_max_m},
             {"delta_N", e.position_friction_N}};
        break;
      case Effect::thermal_drift:
        x = {{"time_constant_s", e.drift_time_constant_s}, {"fraction", e.drift_fraction},
             {"viscous_change_Ns_m", e.drift_fraction * sigma}, {"coulomb_change_N", 0.3 * e.drift_fraction * fc}};
        break;
      case Effect::quadratic_viscous: x = {{"c2", e.quadratic_c2_Ns2_m2}, {"c2_unit", "N s^2/m^2"}}; break;
      case Effect::presliding_hysteresis:
        x = {{"distance_m", e.presliding_distance_m}, {"force_N", e.presliding_force_N}};
        break;
      case Effect::compliance: {
        const double mu = e.compliance_mass_fraction;
        x = {{"frequency_hz", e.compliance_frequency_hz},
             {"load_frequency_hz", e.compliance_frequency_hz * std::sqrt(1.0 - mu)},
             {"load_mass_kg", d.mass_kg * mu},
             {"mass_fraction", mu},
             {"damping_ratio", e.compliance_damping_ratio}};
        break;
      }
      case Effect::delay: x = {{"delay_s", e.delay_s}}; break;
      case Effect::disturbance:
        x = {{"disturbance_amplitude_N", e.disturbance_amplitude_N},
             {"disturbance_frequency_hz", e.disturbance_frequency_hz},
             {"disturbance_phase_rad", e.disturbance_phase_rad}};
        break;
      case Effect::wander:
        x = {{"wander_force_N", e.wander_force_N}, {"wander_time_constant_s", e.wander_time_constant_s}};
        break;
    }
  }
  return j;
}

/// --plants and --programs as lists; the error names a bad entry.
Outcome<CaseMix> parse_mix(const BlindOptions& opt) {
  Outcome<CaseMix> out;
  CaseMix& mix = out.value;
  auto items = [](const std::string& list) {
    std::vector<std::string> out;
    std::stringstream in(list);
    for (std::string item; std::getline(in, item, ',');)
      if (!item.empty()) out.push_back(item);
    return out;
  };
  for (const auto& p : items(opt.plants)) {
    const Outcome<PlantKind> plant = parse_plant(p);
    if (!plant.ok()) return refused<CaseMix>(plant.error);
    mix.plants.push_back(plant.value);
  }
  for (const auto& p : items(opt.programs)) {
    const Outcome<Program> program = parse_program(p);
    if (!program.ok()) return refused<CaseMix>(program.error);
    mix.programs.push_back(program.value);
  }
  if (mix.plants.empty() || mix.programs.empty()) return refused<CaseMix>("--plants and --programs need at least one entry each");
  return out;
}

/// One case's trace as CSV and its answer key as JSON, to look at a verdict.
RunEnd write_case(const BlindOptions& opt, const std::vector<std::string>& schedule, const CaseMix& mix) {
  if (opt.write_case > opt.cases || opt.case_path.empty())
    return RunEnd::refused("--write-case needs a case number in 1.." + std::to_string(opt.cases) + " and --case-csv");
  RunEnd end;
  const int i = opt.write_case - 1;
  const BlindCase bc = make_case(opt.seed, i, schedule[static_cast<std::size_t>(i)], mix);
  std::string error;
  if (!write_trace_csv(opt.case_path, bc.trace, error)) {
    end.written(error);
    return end;
  }
  const std::string err = write_whole_file(
      opt.case_path + ".truth.json",
      nlohmann::json{{"effect", bc.truth.label}, {"parameters", bc.truth.effect}, {"setup", bc.truth.setup}}.dump(2) + "\n");
  if (!err.empty()) {
    end.written(err);
    return end;
  }
  std::printf("wrote case %d (%s) to %s and its truth to %s.truth.json\n", opt.write_case, bc.truth.label.c_str(),
              opt.case_path.c_str(), opt.case_path.c_str());
  return end;
}

namespace {

/// The command line that repeats this run (printed and stored with the results).
std::string rerun_command(const BlindOptions& opt) {
  std::string command = "feedid blind-bench --cases " + std::to_string(opt.cases) + " --seed " + std::to_string(opt.seed);
  if (opt.plants != BlindOptions{}.plants) command += " --plants " + opt.plants;
  if (opt.programs != BlindOptions{}.programs) command += " --programs " + opt.programs;
  if (!opt.labels.empty()) command += " --labels " + opt.labels;
  return command;
}

/// The labels the cases are dealt from: all, or --labels; the error names an unknown one.
Outcome<std::vector<std::string>> label_deal(const BlindOptions& opt) {
  if (opt.labels.empty()) return {labels(), ""};
  Outcome<std::vector<std::string>> deal;
  std::stringstream list(opt.labels);
  for (std::string l; std::getline(list, l, ',');) {
    if (std::find(labels().begin(), labels().end(), l) == labels().end())
      return refused<std::vector<std::string>>("--labels: unknown label '" + l + "'");
    deal.value.push_back(l);
  }
  return deal;
}

/// The answer key (truths) and the verdicts live in separate vectors; a
/// worker moves each truth into the key before the trace goes to diagnosis.
struct BlindRun {
  std::vector<Truth> answer_key;
  std::vector<Verdict> verdicts;
  std::vector<CaseRecord> recs;
  double wall_s = 0.0;
};

/// Case i: generate, keep its truth in the key, diagnose the trace alone.
void run_case(int i, const BlindOptions& opt, const std::vector<std::string>& schedule, const CaseMix& mix, BlindRun& run) {
  const auto i_sz = static_cast<std::size_t>(i);
  const auto t0 = std::chrono::steady_clock::now();
  double gen_s = 0.0, diag_s = 0.0;
  std::size_t samples = 0;
  try {
    BlindCase bc = make_case(opt.seed, i, schedule[i_sz], mix);
    run.answer_key[i_sz] = std::move(bc.truth);
    const Trace trace = std::move(bc.trace);
    samples = trace.samples.size();
    const auto t1 = std::chrono::steady_clock::now();
    gen_s = std::chrono::duration<double>(t1 - t0).count();
    run.verdicts[i_sz] = diagnose_blind(trace);  // the trace only
    diag_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  } catch (const std::exception& ex) {
    run.answer_key[i_sz].label = schedule[i_sz];
    run.verdicts[i_sz].effect = "error";
    run.verdicts[i_sz].error = std::string("case generation failed: ") + ex.what();
  }
  run.recs[i_sz].generate_s = gen_s;
  run.recs[i_sz].diagnose_s = diag_s;
  run.recs[i_sz].samples = samples;
}

/// One line per case, printed by the scorer after the diagnosis.
void print_case_line(int i, int cases, const Truth& t, const Verdict& v, double seconds) {
  std::string truth = t.label;
  if (t.label == "pair") truth = t.pair[0] + "+" + t.pair[1];
  std::printf("%3d/%-3d %-22s %7.3g %-22s %3s %9s %9s %9s %7s %7.1f\n", i + 1, cases, truth.c_str(), t.effect_rms_N,
              verdict_text(v).c_str(), named_right(t, v) ? "ok" : "NO", fmt("%.3g", v.rms_base_N).c_str(),
              fmt("%.3g", v.rms_augmented_N).c_str(), fmt("%.3g", v.noise_floor_N).c_str(),
              catalogued(t.label) ? pct(v.closed_fraction, 0).c_str() : "-", seconds);
  if (!v.error.empty()) std::printf("        error: %s\n", v.error.c_str());
  std::fflush(stdout);
}

/// Every case on `threads` threads, each taking the next case number.
BlindRun run_cases(const BlindOptions& opt, const std::vector<std::string>& schedule, const CaseMix& mix, int threads) {
  const auto n = static_cast<std::size_t>(opt.cases);
  BlindRun run{std::vector<Truth>(n), std::vector<Verdict>(n), std::vector<CaseRecord>(n), 0.0};
  std::atomic<int> next{0}, done{0};
  std::mutex print_mutex;
  const auto t_start = std::chrono::steady_clock::now();
  auto worker = [&] {
    for (int i; (i = next.fetch_add(1)) < opt.cases;) {
      run_case(i, opt, schedule, mix, run);
      const int n_done = done.fetch_add(1) + 1;
      std::lock_guard<std::mutex> lock(print_mutex);
      const auto i_sz = static_cast<std::size_t>(i);
      if (!opt.quiet)
        print_case_line(i, opt.cases, run.answer_key[i_sz], run.verdicts[i_sz],
                        run.recs[i_sz].generate_s + run.recs[i_sz].diagnose_s);
      if (opt.progress) opt.progress(static_cast<double>(n_done) / opt.cases);
    }
  };
  std::vector<std::thread> pool;
  for (int k = 1; k < threads; ++k) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return run;
}

void print_scores(const Scores& s, double wall_s, int threads, double gen_total, double diag_total,
                  const std::string& command) {
  std::printf("\nconfusion matrix (rows: true, columns: named)\n%s", confusion_text(s).c_str());
  std::printf("\n%s", per_effect_text(s).c_str());
  std::printf("\n%s", cells_text(s).c_str());
  std::printf("\nright effect named: %s (%d of %d)  bar >= 90 %%: %s\n", pct(s.accuracy).c_str(), s.correct, s.total,
              s.bar_accuracy ? "met" : "MISSED");
  std::printf("false alarms on effect-free traces: %d of %d  bar <= 1 in 10: %s\n", s.false_alarms, s.none_cases,
              s.bar_false_alarms ? "met" : "MISSED");
  std::printf("median held-out gap closed (catalogued effects): %s  bar >= 80 %%: %s   (named right only: %s)\n",
              pct(s.median_closed_catalogued).c_str(), s.bar_closed ? "met" : "MISSED",
              pct(s.median_closed_named_right).c_str());
  std::printf("wall time %.1f s on %s, %d threads (simulation %.1f s, diagnosis %.1f s summed over cases)\n", wall_s,
              machine_description().c_str(), threads, gen_total, diag_total);
  std::printf("command: %s\n", command.c_str());
}

}  // namespace

RunEnd run_blind_bench(const BlindOptions& opt) {
  if (opt.cases < 1) return RunEnd::refused("--cases (count) must be >= 1, got " + std::to_string(opt.cases));
  const std::string command = rerun_command(opt);
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const int threads = std::max(1, std::min(opt.cases, opt.threads > 0 ? opt.threads : static_cast<int>(std::min(hw, 8u))));
  const Outcome<std::vector<std::string>> deal = label_deal(opt);
  if (!deal.ok()) return RunEnd::refused(deal.error);
  const std::vector<std::string> schedule = label_schedule(opt.cases, opt.seed, deal.value);
  const Outcome<CaseMix> parsed = parse_mix(opt);
  if (!parsed.ok()) return RunEnd::refused(parsed.error);
  const CaseMix& mix = parsed.value;
  if (opt.write_case > 0) return write_case(opt, schedule, mix);

  std::printf("blind benchmark: %d cases, seed %llu, %d threads\n", opt.cases,
              static_cast<unsigned long long>(opt.seed), threads);
  if (!opt.quiet)
    std::printf("%6s  %-22s %7s %-22s %3s %9s %9s %9s %7s %7s\n", "case", "true", "size N", "named", "ok", "base N",
                "aug N", "floor N", "closed", "time s");
  BlindRun run = run_cases(opt, schedule, mix, threads);

  // Scoring: join the answer key with the verdicts.
  double gen_total = 0.0, diag_total = 0.0;
  for (std::size_t i = 0; i < run.recs.size(); ++i) {
    run.recs[i].truth = run.answer_key[i];
    run.recs[i].verdict = run.verdicts[i];
    gen_total += run.recs[i].generate_s;
    diag_total += run.recs[i].diagnose_s;
  }
  const Scores s = score(run.recs);
  print_scores(s, run.wall_s, threads, gen_total, diag_total, command);

  RunEnd end;
  end.bar_missed = !(s.bar_accuracy && s.bar_closed && s.bar_false_alarms);
  if (!opt.json_path.empty())
    end.written(write_whole_file(opt.json_path, to_json(run.recs, s, opt, command, run.wall_s, threads).dump(2) + "\n"));
  if (!opt.markdown_path.empty())
    end.written(write_whole_file(opt.markdown_path, markdown(s, command, run.wall_s, threads, gen_total, diag_total, opt)));
  return end;
}

}  // namespace feedid::host
