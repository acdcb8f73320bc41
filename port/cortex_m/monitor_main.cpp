// Firmware example: friction-health tracking on a Cortex-M4F (QEMU mps2-an386).
//
//   qemu-system-arm -M mps2-an386 -nographic -semihosting -icount shift=0,sleep=off
//                   -kernel build-m4/feedid_monitor_m4.elf
//
// A simulated drive's production motion (generated/monitor_trace_data.h,
// 16-bit velocity and force counts in flash) in which one direction's
// Coulomb force steps in service runs through feedid::HealthTracker<float>:
// every sample is pushed, every 10 s epoch is closed (solved alone, compared
// with the reference, CUSUM). PASS when
//   * the alarm names the changed parameter and direction, and nothing else
//     alarms,
//   * it is raised within 60 s of the change (docs/monitor.md),
//   * it matches the host's HealthTracker<double> on the same samples: same
//     parameter, direction and epoch, the change within its standard error.
// Each push() and close_epoch() is timed with the 25 MHz counter; under
// -icount shift=0 one tick is 40 instructions (docs/firmware.md). The
// servo-interrupt hand-off is feedid_m4.elf's subject and is not repeated.
#include <stddef.h>
#include <stdint.h>

#include "board.hpp"
#include "feedid/feedid.hpp"
#include "feedid/footprint_budget.hpp"
#include "monitor_trace_data.h"  // generated at build time by host_sim/firmware_traces/firmware_monitor_gen.cpp
#include "probe.hpp"

namespace fw = feedid::fw;
namespace board = feedid::fw::board;
namespace trace = feedid::fw::monitor_trace;

namespace {

using Console = fw::SemihostingConsole;
using Health = feedid::HealthTracker<float>;
static_assert(sizeof(Health) <= fw::health_tracker_float_ram_budget,
              "HealthTracker<float> exceeds its RAM budget (core/feedid/footprint_budget.hpp)");

/// The largest delay from the change to the alarm this run accepts (s): the
/// detection bar of docs/monitor.md.
constexpr float max_delay_s = 60.0f;

Health g_health;

feedid::Sample<float> sample_at(uint32_t k) {
  const fw::CountPoint& p = trace::points[k];
  feedid::Sample<float> s;
  s.dt_s = k == 0 ? 0.0f : trace::dt_s;
  s.velocity_m_s = float(p.velocity) * trace::velocity_lsb_m_s;
  s.force_N = float(p.force) * trace::force_lsb_N;
  return s;
}

/// Cost of the run in counter ticks.
struct Cost {
  uint32_t push_total = 0, push_max = 0;
  uint32_t close_total = 0, close_max = 0;
};

/// One line per closed epoch: both directions' Coulomb force as the epoch
/// carried it, and the alarms it raised.
void print_epoch(Console& out, feedid::Status solved, int fresh) {
  const feedid::Estimate<float>& e = g_health.last_epoch();
  out << "  epoch " << g_health.epochs() << " to ";
  out.real(g_health.time_s(), 4) << " s: " << feedid::status_name(solved);
  auto fc = [&](const char* name, int index) {
    float value = 0.0f, se = 0.0f;
    out << "  " << name << " ";
    if (feedid::tracked_value(e, index, value, se)) {
      out.real(value, 5) << " +- ";
      out.real(se, 2);
    } else {
      out << "(not carried)";
    }
  };
  fc("Fc+", 2);
  fc("Fc-", 6);
  out << (fresh > 0 ? "  ALARM\n" : "\n");
}

/// The tracking run: every sample pushed, every complete epoch closed.
bool run(Console& out, Cost& cost) {
  if (g_health.init(trace::config(), feedid::MonitorConfig<float>{}) != feedid::Status::ok) {
    out << "FAIL: HealthTracker init: " << (g_health.config_error() ? g_health.config_error() : "?") << "\n";
    return false;
  }
  for (uint32_t k = 0; k < trace::count; ++k) {
    const feedid::Sample<float> s = sample_at(k);
    uint32_t t0 = board::counter_now();
    (void)g_health.push(s);  // rejections are counted by the estimator
    uint32_t dt = board::counter_now() - t0;
    cost.push_total += dt;
    if (dt > cost.push_max) cost.push_max = dt;
    if (!g_health.epoch_complete()) continue;
    int fresh = 0;
    t0 = board::counter_now();
    const feedid::Status solved = g_health.close_epoch(fresh);
    dt = board::counter_now() - t0;
    cost.close_total += dt;
    if (dt > cost.close_max) cost.close_max = dt;
    print_epoch(out, solved, fresh);
  }
  return true;
}

const char* parameter_name(uint8_t p) { return feedid::tracked_name(static_cast<feedid::Tracked>(p)); }

void print_alarm(Console& out, const char* who, const feedid::ChangeAlarm<float>& a) {
  out << who << ": " << feedid::tracked_name(a.parameter) << (a.direction > 0 ? "+" : a.direction < 0 ? "-" : "")
      << " changed by ";
  out.real(a.change, 4) << " +- ";
  out.real(a.change_se, 2) << " from ";
  out.real(a.t_s, 4) << " s, raised at ";
  out.real(a.raised_t_s, 4) << " s\n";
}

/// Null when the alarms meet the PASS rules of the file comment, else why not.
const char* verdict(Console& out) {
  const auto& m = g_health.monitor();
  for (int i = 0; i < m.alarm_count(); ++i) print_alarm(out, "M4 alarm", m.alarm(i));
  for (int i = 0; i < trace::host_alarm_count; ++i) {
    const fw::AlarmResult& h = trace::host_alarms[i];
    out << "host alarm: " << parameter_name(h.parameter) << (h.direction > 0 ? "+" : "-") << " changed by ";
    out.real(h.change, 4) << " +- ";
    out.real(h.change_se, 2) << ", raised at ";
    out.real(h.raised_t_s, 4) << " s\n";
  }
  if (m.alarm_count() != 1) return "not exactly one alarm";
  const feedid::ChangeAlarm<float>& a = m.alarm(0);
  if (a.parameter != feedid::Tracked::coulomb || a.direction != trace::change_direction)
    return "the alarm names another parameter or direction than the change";
  if (!(a.raised_t_s >= trace::change_time_s && a.raised_t_s - trace::change_time_s <= max_delay_s))
    return "the alarm is not raised within 60 s after the change";
  if (trace::host_alarm_count != 1) return "the host reference did not raise exactly one alarm";
  const fw::AlarmResult& h = trace::host_alarms[0];
  const bool same_epoch = feedid::port::abs(a.raised_t_s - h.raised_t_s) < 0.5f * feedid::MonitorConfig<float>{}.epoch_s;
  const bool same_change = feedid::port::abs(a.change - h.change) <= h.change_se;
  if (uint8_t(a.parameter) != h.parameter || a.direction != h.direction || !same_epoch || !same_change)
    return "the alarm differs from the host double's";
  return nullptr;
}

void print_costs(Console& out, const Cost& cost) {
  constexpr uint32_t calibration_turns = 100'000;
  uint32_t calibration = 0;
  const float ipt = fw::measured_instructions_per_tick(calibration_turns, calibration);
  const float epochs = float(g_health.epochs() > 0 ? g_health.epochs() : 1);
  out << "cost (25 MHz counter ticks; ";
  out.real(ipt, 4) << " instructions per tick, exact under -icount shift=0):\n";
  fw::print_cost(out, "HealthTracker push() mean per sample", float(cost.push_total) / float(trace::count), ipt);
  fw::print_cost(out, "HealthTracker push() max", float(cost.push_max), ipt);
  fw::print_cost(out, "close_epoch() mean (solve + monitor update + init)", float(cost.close_total) / epochs, ipt);
  fw::print_cost(out, "close_epoch() max", float(cost.close_max), ipt);
  // The monitor's own share, on a copy so the run's state stays as it was.
  Health::Monitor scratch = g_health.monitor();
  int fresh = 0;
  const uint32_t t0 = board::counter_now();
  (void)scratch.update(g_health.last_epoch(), 0.0f, 1.0f, fresh);
  fw::print_cost(out, "ChangeMonitor update() alone", float(board::counter_now() - t0), ipt);
}

}  // namespace

/// Unused here (no servo interrupt; see the file comment), but the vector table names it.
extern "C" void SysTick_Handler() {}

int main() {
  board::irq_disable();
  fw::paint_stack();
  board::counter_start();
  Console out;
  out << "feedid friction-health tracking on Cortex-M4F (QEMU mps2-an386): HealthTracker<float> = "
      << uint32_t(sizeof(Health)) << " B (budget " << uint32_t(fw::health_tracker_float_ram_budget)
      << "): Estimator<float, " << Health::Axis::bands << ", " << Health::Axis::candidates << "> "
      << uint32_t(sizeof(Health::Axis)) << " B + ChangeMonitor<float> " << uint32_t(sizeof(Health::Monitor)) << " B\n";
  out << trace::count << " samples at ";
  out.real(trace::sample_rate_hz, 6) << " Hz (production motion, 16-bit counts in flash); Fc"
                                     << (trace::change_direction > 0 ? "+" : "-") << " x (1 + ";
  out.real(trace::change_fraction, 3) << ") from ";
  out.real(trace::change_time_s, 4) << " s\n";

  Cost cost;
  if (!run(out, cost)) return 1;
  const char* why = verdict(out);
  print_costs(out, cost);
  out << "stack high-water mark: " << fw::stack_used_bytes() << " B of " << fw::stack_size_bytes() << " B\n";
  if (why == nullptr) {
    out << "PASS: Fc" << (trace::change_direction > 0 ? "+" : "-") << " change alarmed within ";
    out.real(max_delay_s, 2) << " s, nothing else alarmed, as the host double\n";
    out.flush();
    return 0;
  }
  out << "FAIL: " << why << "\n";
  out.flush();
  return 1;
}
