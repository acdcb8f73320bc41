// What both firmware trace generators (firmware_trace_gen.cpp,
// firmware_monitor_gen.cpp) write the same way: exact float literals and the
// core configuration the host pipeline picks for a trace. Host only.
#pragma once

#include <cstdio>
#include <string>

#include "feedid/types.hpp"
#include "identify/identify.hpp"

namespace feedid::host::firmware {

/// "0x1.8p+3f": the float value exactly, as a C++17 hexadecimal literal.
inline std::string hex(float x) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%af", static_cast<double>(x));
  return buf;
}

/// auto_config for this trace (as `feedid identify` picks it), each field
/// rounded to float once: the firmware runs with exactly these values and
/// the host reference with config_as<double> of them.
inline feedid::Config<float> float_config_for(const Trace& trace) {
  IdentifyOptions opt;
  const Signals sig = prepare_signals(trace, opt);
  return config_as<float>(auto_config(sig, opt));
}

/// `inline feedid::Config<float> config()` returning c, field by field.
inline void write_config(std::FILE* f, const feedid::Config<float>& c) {
  std::fprintf(f, "/// feedid::host::auto_config for this trace, rounded to float.\n");
  std::fprintf(f, "inline feedid::Config<float> config() {\n  feedid::Config<float> c;\n");
  std::fprintf(f, "  c.velocity_min_m_s = %s;\n", hex(c.velocity_min_m_s).c_str());
  std::fprintf(f, "  c.velocity_max_m_s = %s;\n", hex(c.velocity_max_m_s).c_str());
  std::fprintf(f, "  c.velocity_resolution_m_s = %s;\n", hex(c.velocity_resolution_m_s).c_str());
  std::fprintf(f, "  c.section_enter_m_s = %s;\n", hex(c.section_enter_m_s).c_str());
  std::fprintf(f, "  c.rest_samples = %u;\n", unsigned(c.rest_samples));
  std::fprintf(f, "  c.min_section_s = %s;\n", hex(c.min_section_s).c_str());
  std::fprintf(f, "  c.max_fold_s = %s;\n", hex(c.max_fold_s).c_str());
  std::fprintf(f, "  c.mass_window_s = %s;\n", hex(c.mass_window_s).c_str());
  std::fprintf(f, "  c.max_step_speed_ratio = %s;\n", hex(c.max_step_speed_ratio).c_str());
  std::fprintf(f, "  c.max_acceleration_m_s2 = %s;\n", hex(c.max_acceleration_m_s2).c_str());
  std::fprintf(f, "  c.max_speed_m_s = %s;\n", hex(c.max_speed_m_s).c_str());
  std::fprintf(f, "  c.max_force_N = %s;\n", hex(c.max_force_N).c_str());
  std::fprintf(f, "  c.max_gap_s = %s;\n", hex(c.max_gap_s).c_str());
  std::fprintf(f, "  c.stribeck_min_m_s = %s;\n", hex(c.stribeck_min_m_s).c_str());
  std::fprintf(f, "  c.stribeck_max_m_s = %s;\n", hex(c.stribeck_max_m_s).c_str());
  std::fprintf(f, "  c.max_vs_iterations = %u;\n", unsigned(c.max_vs_iterations));
  std::fprintf(f, "  c.velocity_source = static_cast<feedid::VelocitySource>(%d);\n", int(c.velocity_source));
  std::fprintf(f, "  c.force_lag_samples = %.9gf;\n", c.force_lag_samples);
  std::fprintf(f, "  return c;\n}\n\n");
}

}  // namespace feedid::host::firmware
