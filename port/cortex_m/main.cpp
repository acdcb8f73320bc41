// Firmware example: the float core on a Cortex-M4F (QEMU mps2-an386).
//
//   qemu-system-arm -M mps2-an386 -nographic -semihosting -kernel build-m4/feedid_m4.elf
//
// 1. Servo run. SysTick stands in for the drive's servo interrupt: every
//    tick the ISR takes the next recorded sample (here from a simulated
//    drive's trace in flash) and hands it over with push_from_isr() - no
//    lock, no wait. The background task (main loop) drains the queue into
//    Estimator<float>, and solves when asked: once mid-stream (the request
//    travels with the sample after which it arrived, so the task solves at a
//    defined point of the stream while the ISR keeps filling the queue) and
//    once at the end.
// 2. The result is compared with the host's Estimator<double> on the same
//    float samples (generated/trace_data.h) within the tolerances below;
//    a line starting with PASS, or FAIL naming what differed, is printed and
//    semihosting ends QEMU with status 0 (PASS) or 1 (FAIL).
// 3. Cost: the same stream again without interrupts, each push() and solve()
//    timed with a 25 MHz counter. Under `-icount shift=0` QEMU advances
//    virtual time by 1 ns per executed instruction, so one tick is 40
//    instructions (docs/firmware.md).
#include <stddef.h>
#include <stdint.h>

#include "board.hpp"
#include "feedid/footprint_budget.hpp"
#include "feedid/feedid.hpp"
#include "feedid_port/spsc_queue.hpp"
#include "probe.hpp"
#include "trace_data.h"  // generated at build time by host_sim/firmware_traces/firmware_trace_gen.cpp

namespace fw = feedid::fw;
namespace board = feedid::fw::board;
namespace trace = feedid::fw::trace;

namespace {

using Console = fw::SemihostingConsole;
using fw::print_cost;

/// The target's estimator: the host's Estimator<double> in float.
using Axis = feedid::Estimator<float>;

constexpr size_t axis_ram_budget = fw::estimator_float_ram_budget;
static_assert(sizeof(Axis) <= fw::estimator_float_ram_budget,
              "Estimator<float> exceeds its RAM budget (core/feedid/footprint_budget.hpp)");
static_assert(sizeof(feedid::Estimator<double>) <= fw::estimator_double_ram_budget,
              "Estimator<double> exceeds its RAM budget (core/feedid/footprint_budget.hpp)");

/// Comparison with the host double reference (relative, same trace).
constexpr float tol_mass = 0.005f;      ///< m: 0.5 %
constexpr float tol_linear = 0.005f;    ///< sigma, Fc: 0.5 %
constexpr float tol_stribeck = 0.03f;   ///< Fs, vs: 3 %

/// One servo sample in the queue, tagged with its trace index so the task
/// can prove that nothing was lost, duplicated or reordered, and with the
/// "identify now" request that arrived with it (solve after pushing it).
struct ServoItem {
  feedid::Sample<float> sample;
  uint32_t tag;  ///< trace index | solve_request_bit
  static constexpr uint32_t solve_request_bit = 1u << 31;
  uint32_t index() const { return tag & ~solve_request_bit; }
  bool solve_request() const { return (tag & solve_request_bit) != 0; }
};

/// SysTick period of the replay (core clocks at 25 MHz): 200 us, the 1 kHz
/// trace replayed five times faster than recorded, so that the plain QEMU
/// command (virtual time = host time) finishes in about 6 s.
constexpr uint32_t servo_period_cycles = 5000;

/// Queue depth: must hold the samples that arrive while the task is busy,
/// above all while it solves. Rule: capacity >= servo rate x worst-case
/// solve time, with margin. 512 ticks of 200 us are 100 ms: ten times the
/// mid-stream solve on plain QEMU here (~9 ms), and room for the emulator
/// being descheduled by its host. (On a 168 MHz M4 at a 1 kHz servo rate the
/// solve, ~1.6 M instructions, takes ~10-15 ms: 16 would do, 64 is safe.)
constexpr size_t queue_capacity = 512;
using SampleQueue = feedid::port::SpscQueue<ServoItem, queue_capacity, board::InterruptLock>;

Axis g_axis;
SampleQueue g_queue;

// Written only by the ISR (read by the task once the ISR is done).
volatile uint32_t g_isr_next = 0;    ///< next trace index to deliver
volatile bool g_isr_done = false;    ///< every trace sample was offered
float g_isr_lost_dt_s = 0.0f;        ///< time of samples lost to overflow, added to the next dt (s)

fw::Result to_result(const feedid::Estimate<float>& e) {
  auto dir = [](const feedid::DirectionEstimate<float>& d) {
    return fw::DirectionResult{d.viscous_Ns_m, d.coulomb_N, d.breakaway_N, d.stribeck_velocity_m_s, d.flags};
  };
  return fw::Result{e.mass_kg, e.mass_flags, dir(e.pos), dir(e.neg)};
}

bool same(const fw::Result& a, const fw::Result& b) {
  auto eq = [](const fw::DirectionResult& x, const fw::DirectionResult& y) {
    return x.viscous_Ns_m == y.viscous_Ns_m && x.coulomb_N == y.coulomb_N && x.breakaway_N == y.breakaway_N &&
           x.stribeck_velocity_m_s == y.stribeck_velocity_m_s && x.flags == y.flags;
  };
  return a.mass_kg == b.mass_kg && a.mass_flags == b.mass_flags && eq(a.pos, b.pos) && eq(a.neg, b.neg);
}

float rel_diff(float value, float reference) {
  return reference != 0.0f ? (value - reference) / feedid::port::abs(reference) : value;
}

/// Prints one comparison table and returns the number of failed checks.
/// `first_failure` receives the name of the first parameter out of tolerance.
int compare(Console& out, const char* label, const fw::Result& m4, const fw::Result& host,
            const fw::Result* host_float, const char*& first_failure) {
  struct Row {
    const char* name;
    float m4, host, host_float, tol;
  };
  const fw::Result& hf = host_float ? *host_float : host;
  const Row rows[] = {
      {"m (kg)", m4.mass_kg, host.mass_kg, hf.mass_kg, tol_mass},
      {"sigma+ (N s/m)", m4.pos.viscous_Ns_m, host.pos.viscous_Ns_m, hf.pos.viscous_Ns_m, tol_linear},
      {"Fc+ (N)", m4.pos.coulomb_N, host.pos.coulomb_N, hf.pos.coulomb_N, tol_linear},
      {"Fs+ (N)", m4.pos.breakaway_N, host.pos.breakaway_N, hf.pos.breakaway_N, tol_stribeck},
      {"vs+ (m/s)", m4.pos.stribeck_velocity_m_s, host.pos.stribeck_velocity_m_s, hf.pos.stribeck_velocity_m_s,
       tol_stribeck},
      {"sigma- (N s/m)", m4.neg.viscous_Ns_m, host.neg.viscous_Ns_m, hf.neg.viscous_Ns_m, tol_linear},
      {"Fc- (N)", m4.neg.coulomb_N, host.neg.coulomb_N, hf.neg.coulomb_N, tol_linear},
      {"Fs- (N)", m4.neg.breakaway_N, host.neg.breakaway_N, hf.neg.breakaway_N, tol_stribeck},
      {"vs- (m/s)", m4.neg.stribeck_velocity_m_s, host.neg.stribeck_velocity_m_s, hf.neg.stribeck_velocity_m_s,
       tol_stribeck},
  };
  int failed = 0;
  out << label << ": parameter, M4 float, host double, difference (tolerance)"
      << (host_float ? ", difference to host float" : "") << "\n";
  for (const Row& r : rows) {
    const float d = rel_diff(r.m4, r.host);
    const bool ok = feedid::port::is_finite(r.m4) && feedid::port::abs(d) <= r.tol;
    if (!ok && failed++ == 0) first_failure = r.name;
    out << "  " << r.name << "  " << r.m4 << "  " << r.host << "  ";
    out.real(100.0f * d, 3) << " % (" << 100.0f * r.tol << " %)";
    if (host_float) {
      out << "  ";
      out.real(100.0f * rel_diff(r.m4, r.host_float), 3) << " %";
    }
    out << (ok ? "" : "  OUT OF TOLERANCE") << "\n";
  }
  auto flags = [&](const char* name, uint32_t a, uint32_t b) {
    const bool ok = a == b;
    if (!ok && failed++ == 0) first_failure = name;
    out << "  " << name << "  " << a << "  " << b << (ok ? "  (must match)\n" : "  DIFFERENT\n");
  };
  flags("mass flags", m4.mass_flags, host.mass_flags);
  flags("flags+", m4.pos.flags, host.pos.flags);
  flags("flags-", m4.neg.flags, host.neg.flags);
  return failed;
}

feedid::Sample<float> sample_at(uint32_t k) {
  const fw::TracePoint& p = trace::points[k];
  feedid::Sample<float> s;
  s.dt_s = p.dt_s;
  s.velocity_m_s = p.velocity_m_s;
  s.force_N = p.force_N;
  return s;
}

}  // namespace

/// The servo interrupt's work for sample k: read it (here from the flash
/// trace; on a drive from the encoder and current loop) and hand it to the
/// task. Never waits, never locks, never touches the estimator. If the queue
/// is full the sample is dropped and counted by the queue, and its time is
/// added to the next one's dt, so the core's time base stays right and it
/// bridges the gap like a rejected sample. Context: servo ISR.
inline void offer(SampleQueue& q, uint32_t k, float& lost_dt_s) {
  const fw::TracePoint& p = trace::points[k];
  ServoItem item;
  item.sample.dt_s = p.dt_s + lost_dt_s;
  item.sample.position_m = 0.0f;  // the core uses the measured velocity
  item.sample.velocity_m_s = p.velocity_m_s;
  item.sample.force_N = p.force_N;
  item.tag = k | (k == trace::solve_request_after ? ServoItem::solve_request_bit : 0u);
  if (q.push_from_isr(item)) lost_dt_s = 0.0f;
  else lost_dt_s += p.dt_s;
}

/// SysTick: the servo interrupt. Gets called at the servo rate in interrupt
/// context and must run fast; one offer() per tick.
extern "C" void SysTick_Handler() {
  const uint32_t k = g_isr_next;
  if (k >= trace::count) return;
  offer(g_queue, k, g_isr_lost_dt_s);
  g_isr_next = k + 1;
  if (k + 1 == trace::count) g_isr_done = true;
}

namespace {

/// What the servo run delivered and the core made of it.
struct ServoRun {
  uint32_t delivered = 0, duplicated = 0, skipped = 0, rejected = 0, max_depth = 0, overflow = 0, ticks = 0;
  feedid::Status mid_status = feedid::Status::not_initialized, final_status = feedid::Status::not_initialized;
  fw::Result mid{}, fin{};
  feedid::Diagnostics diag{};
};

/// The task's side of one queued sample: check its order, push it, and
/// solve when the request travelled with it (the ISR keeps queueing).
void take(const ServoItem& item, uint32_t& expected, ServoRun& run) {
  ++run.delivered;
  if (item.index() < expected) ++run.duplicated;
  else run.skipped += item.index() - expected;
  expected = item.index() + 1;
  if (g_axis.push(item.sample) != feedid::Status::ok) ++run.rejected;
  if (item.solve_request()) {
    run.mid_status = g_axis.solve();
    run.mid = to_result(g_axis.estimate());
  }
}

/// 1. SysTick ISR -> queue -> task -> push(), a solve mid-stream and at the end.
ServoRun servo_run() {
  ServoRun run;
  uint32_t expected = 0;
  const uint32_t t0 = board::counter_now();
  board::systick_start(servo_period_cycles);
  board::irq_enable();
  for (;;) {
    const uint32_t depth = static_cast<uint32_t>(g_queue.size());
    if (depth > run.max_depth) run.max_depth = depth;
    ServoItem item;
    while (g_queue.pop(item)) {
      const uint32_t left = static_cast<uint32_t>(g_queue.size()) + 1u;  // incl. the one just taken
      if (left > run.max_depth) run.max_depth = left;
      take(item, expected, run);
    }
    if (g_isr_done && g_queue.empty()) break;
    board::sleep_while([] { return g_queue.empty() && !g_isr_done; });
  }
  board::systick_stop();
  run.ticks = board::counter_now() - t0;
  run.final_status = g_axis.solve();
  run.fin = to_result(g_axis.estimate());
  run.diag = g_axis.diagnostics();
  board::irq_disable();
  run.overflow = g_queue.overflow_count();
  return run;
}

void print_servo_run(Console& out, const ServoRun& run) {
  const uint32_t bands_pos = g_axis.estimate().pos.bands_used, bands_neg = g_axis.estimate().neg.bands_used;
  out << "servo: " << run.delivered << " of " << trace::count << " samples delivered, " << run.overflow
      << " lost to overflow, " << run.duplicated << " duplicated, max queue depth " << run.max_depth
      << "; core accepted " << uint32_t(run.diag.samples_accepted) << ", rejected " << run.rejected << " (host "
      << trace::host_rejected << "); " << run.diag.sections_complete[0] << "+" << run.diag.sections_complete[1]
      << " sections, " << run.diag.mass_windows << " mass windows, bands used " << bands_pos << "+" << bands_neg << "\n";
  out << "servo: whole run " << run.ticks << " ticks\n";
  out << "solve after sample " << trace::solve_request_after << ": " << feedid::status_name(run.mid_status)
      << "; final solve: " << feedid::status_name(run.final_status) << "\n";
}

void print_truth(Console& out) {
  const fw::Result& t = trace::truth;
  out << "truth: m " << t.mass_kg << " kg; + sigma " << t.pos.viscous_Ns_m << " Fc " << t.pos.coulomb_N << " Fs "
      << t.pos.breakaway_N << " vs " << t.pos.stribeck_velocity_m_s << "; - sigma " << t.neg.viscous_Ns_m << " Fc "
      << t.neg.coulomb_N << " Fs " << t.neg.breakaway_N << " vs " << t.neg.stribeck_velocity_m_s << "\n";
}

/// 3. Cost: counter ticks of the same stream without interrupts.
struct Cost {
  uint32_t calibration = 0;
  float ipt = 0.0f;  ///< instructions per tick, measured
  uint32_t push_max = 0, push_max_at = 0, push_total = 0, mid_solve = 0, final_solve = 0;
  uint32_t bucket[4] = {0, 0, 0, 0};  ///< push() within 1000 / 5000 / 20000 instructions, and more
  uint32_t loop_ticks = 0, handoff_ticks = 0, feedforward_ticks = 0, feedforward_vs_ticks = 0;
  bool reproducible = false;
  feedid::Estimate<float> bands{};  ///< the timed final bands solve, for the feed-forward timing
};
constexpr uint32_t calibration_turns = 100'000;

/// Each push() and solve() timed on their own; false if init fails.
bool time_each_call(const feedid::Config<float>& cfg, Cost& c) {
  if (g_axis.init(cfg) != feedid::Status::ok) return false;
  const uint32_t bucket_ticks[3] = {uint32_t(1000.0f / c.ipt), uint32_t(5000.0f / c.ipt), uint32_t(20000.0f / c.ipt)};
  for (uint32_t k = 0; k < trace::count; ++k) {
    const feedid::Sample<float> s = sample_at(k);
    const uint32_t t0 = board::counter_now();
    (void)g_axis.push(s);
    const uint32_t dt = board::counter_now() - t0;
    c.push_total += dt;
    if (dt > c.push_max) { c.push_max = dt; c.push_max_at = k; }
    ++c.bucket[dt <= bucket_ticks[0] ? 0 : dt <= bucket_ticks[1] ? 1 : dt <= bucket_ticks[2] ? 2 : 3];
    if (k == trace::solve_request_after) {
      const uint32_t s0 = board::counter_now();
      (void)g_axis.solve();
      c.mid_solve = board::counter_now() - s0;
    }
  }
  return true;
}

/// The final solve (bands; the paper method is not built here) after time_each_call, and whether it
/// reproduces the servo run's result bit for bit.
void time_final_solves(const ServoRun& run, Cost& c) {
  uint32_t t0 = board::counter_now();
  const feedid::Status st = g_axis.solve();
  c.final_solve = board::counter_now() - t0;
  c.bands = g_axis.estimate();
  c.reproducible = st == run.final_status && same(to_result(g_axis.estimate()), run.fin);
}

/// Means without per-call timer reads: push loop, hand-off, feed-forward.
/// The feed-forward runs on the copy of the bands estimate time_final_solves
/// kept (init() below clears the axis's own).
bool time_loops(const feedid::Config<float>& cfg, Cost& c) {
  const feedid::Estimate<float>& solved = c.bands;
  const feedid::EstimateFriction<float> model{solved};
  const feedid::FeedforwardConfig<float> ff{0.0005f, solved.mass_kg};
  const float vs = solved.pos.stribeck_velocity_m_s > 0.0f ? solved.pos.stribeck_velocity_m_s : 0.002f;
  if (g_axis.init(cfg) != feedid::Status::ok) return false;
  uint32_t t0 = board::counter_now();
  for (uint32_t k = 0; k < trace::count; ++k) (void)g_axis.push(sample_at(k));
  c.loop_ticks = board::counter_now() - t0;
  float lost_dt_s = 0.0f;  // hand-off per sample: the ISR's offer() plus the task's pop()
  t0 = board::counter_now();
  for (uint32_t k = 0; k < trace::count; ++k) {
    offer(g_queue, k, lost_dt_s);
    ServoItem item;
    (void)g_queue.pop(item);
  }
  c.handoff_ticks = board::counter_now() - t0;
  // Friction feed-forward at each sample's velocity as the reference, then
  // near the Stribeck velocity, where the exp is evaluated in full.
  volatile float ff_sink = 0.0f;  // keeps the loops from being optimised away
  t0 = board::counter_now();
  for (uint32_t k = 0; k < trace::count; ++k) ff_sink = ff_sink + feedid::feedforward(model, ff, sample_at(k).velocity_m_s, 0.1f);
  c.feedforward_ticks = board::counter_now() - t0;
  t0 = board::counter_now();
  for (uint32_t k = 0; k < trace::count; ++k) ff_sink = ff_sink + feedid::feedforward(model, ff, vs * (1.0f + 1e-5f * float(k & 63u)), 0.1f);
  c.feedforward_vs_ticks = board::counter_now() - t0;
  return true;
}

void print_costs(Console& out, const Cost& c) {
  const float n = float(trace::count);
  out << "cost (25 MHz counter ticks; a loop of " << 2 * calibration_turns << " instructions took " << c.calibration
      << " ticks = ";
  out.real(c.ipt, 4) << " instructions per tick; exact under qemu -icount shift=0 (" << fw::instructions_per_tick
                     << "), host-time noise without -icount):\n";
  print_cost(out, "push() mean per sample, loop over the trace", float(c.loop_ticks) / n, c.ipt);
  print_cost(out, "push() mean per sample, each call timed", float(c.push_total) / n, c.ipt);
  out << "  push() per sample <= 1000 / 5000 / 20000 / more instructions: " << c.bucket[0] << " / " << c.bucket[1]
      << " / " << c.bucket[2] << " / " << c.bucket[3] << " samples\n";
  print_cost(out, "push() max", float(c.push_max), c.ipt);
  out << "  push() max at sample " << c.push_max_at << "\n";
  print_cost(out, "solve() mid-stream", float(c.mid_solve), c.ipt);
  print_cost(out, "solve() final (bands method)", float(c.final_solve), c.ipt);
  print_cost(out, "hand-off per sample (ISR offer + push_from_isr + task pop)", float(c.handoff_ticks) / n, c.ipt);
  print_cost(out, "feedforward() per call, at the trace's velocities (sample read included)",
             float(c.feedforward_ticks) / n, c.ipt);
  print_cost(out, "feedforward() per call, at v = vs (the Stribeck exp in full)", float(c.feedforward_vs_ticks) / n,
             c.ipt);
  out << "stack high-water mark: " << fw::stack_used_bytes() << " B of " << fw::stack_size_bytes() << " B\n";
  out << "timed re-run reproduces the servo run bit for bit: " << (c.reproducible ? "yes" : "NO") << "\n";
}

/// Null when the run passes, else why not (first_failure: the comparison's).
const char* verdict(const ServoRun& run, int failed, const char* first_failure, bool reproducible) {
  if (run.mid_status != feedid::Status::ok || run.final_status != feedid::Status::ok) return "solve did not return ok";
  if (run.overflow != 0 || run.skipped != 0 || run.duplicated != 0 || run.delivered != trace::count)
    return "the queue lost, duplicated or reordered samples";
  if (uint32_t(run.diag.samples_rejected) != trace::host_rejected) return "rejected samples differ from the host";
  if (failed != 0) return first_failure;
  if (!reproducible) return "the timed re-run differs from the servo run";
  return nullptr;
}

void print_header(Console& out) {
  out << "feedid firmware on Cortex-M4F (QEMU mps2-an386): Estimator<float>, " << trace::count
      << " samples of a simulated 100 kg drive at ";
  out.real(trace::sample_rate_hz, 6) << " Hz in flash\n";
  out << "sizeof Estimator<float> = " << uint32_t(sizeof(Axis)) << " B (budget " << uint32_t(axis_ram_budget)
      << "), Estimator<double> = " << uint32_t(sizeof(feedid::Estimator<double>))
      << " B, sample queue = " << uint32_t(sizeof(SampleQueue)) << " B (" << uint32_t(queue_capacity)
      << " x " << uint32_t(sizeof(ServoItem)) << " B)\n";
  out << "servo: SysTick every " << servo_period_cycles << " cycles -> push_from_isr -> SpscQueue<"
      << uint32_t(queue_capacity) << "> -> task -> push(); solve asked after sample " << trace::solve_request_after
      << " and at the end\n";
}

}  // namespace

int main() {
  board::irq_disable();
  fw::paint_stack();
  board::counter_start();
  Console out;
  print_header(out);
  const feedid::Config<float> cfg = trace::config();
  if (g_axis.init(cfg) != feedid::Status::ok) {
    out << "FAIL: init: " << g_axis.config_error() << "\n";
    return 1;
  }
  const ServoRun run = servo_run();
  print_servo_run(out, run);

  // 2. Compare with the host double reference.
  const char* first_failure = nullptr;
  int failed = compare(out, "mid-stream solve", run.mid, trace::host_double_mid, nullptr, first_failure);
  failed += compare(out, "final solve", run.fin, trace::host_double_final, &trace::host_float_final, first_failure);
  print_truth(out);

  Cost cost;
  cost.ipt = fw::measured_instructions_per_tick(calibration_turns, cost.calibration);
  if (!time_each_call(cfg, cost)) return 1;
  time_final_solves(run, cost);
  if (!time_loops(cfg, cost)) return 1;
  print_costs(out, cost);

  const char* why = verdict(run, failed, first_failure, cost.reproducible);
  if (why == nullptr) {
    out << "PASS: M4 float matches host double on " << trace::count
        << " samples (m, sigma, Fc within 0.5 %, Fs, vs within 3 %, flags equal)\n";
    out.flush();
    return 0;
  }
  out << "FAIL: " << why;
  if (why == first_failure) {
    out << " differs from the host double result beyond its tolerance";
    if (failed > 1) out << " (and " << uint32_t(failed - 1) << " more)";
  }
  out << "\n";
  out.flush();
  return 1;
}
