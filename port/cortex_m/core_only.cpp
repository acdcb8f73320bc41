// Footprint probe: the smallest firmware that uses the whole core as the
// drive builds it (init, push, solve with the bands method, estimate; the
// paper method is not built, FEEDID_PAPER_METHOD=0) and nothing else. Its size minus
// that of baseline.cpp (same start-up, empty main) is the core's flash and
// RAM on a Cortex-M4F (docs/firmware.md). Never run; only linked and measured.
#include "feedid/feedid.hpp"

namespace {
feedid::Estimator<float> g_axis;
}

// Inputs and outputs the optimiser cannot see through.
volatile float g_in[3];
volatile float g_out;

extern "C" void SysTick_Handler() {}

int main() {
  feedid::Config<float> cfg;
  cfg.velocity_min_m_s = g_in[0];
  if (g_axis.init(cfg) != feedid::Status::ok) return 1;
  for (int k = 0; k < 4; ++k) {
    feedid::Sample<float> s;
    s.dt_s = g_in[0];
    s.velocity_m_s = g_in[1];
    s.force_N = g_in[2];
    (void)g_axis.push(s);
  }
  feedid::Status st = g_axis.solve();
  g_out = g_axis.estimate().mass_kg + float(st) + float(g_axis.diagnostics().samples_rejected);
  return 0;
}
