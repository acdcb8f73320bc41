// Host tool, run by the firmware build: simulate a feed drive, round the
// samples to float exactly as the firmware will hold them in flash, and
// write them as a C++ header together with
//   * the core configuration the host pipeline picks for this trace
//     (feedid::host::auto_config, each field rounded to float),
//   * the host reference: feedid::host::Core (Estimator<double>)
//     run on the SAME float-rounded samples with the same configuration,
//     solved once mid-stream (at the sample where the firmware is asked to
//     solve) and once at the end,
//   * for information, the same run in float on the host, and the truth.
//
// Usage: gen_trace OUT.h [duration_s] [rate_hz]
// Host only (standard library, simulator); never linked into the firmware.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "sim/drive_sim.hpp"
#include "feedid/feedid.hpp"
#include "firmware_header.hpp"
#include "identify/identify.hpp"

namespace {

using feedid::host::Core;
using feedid::host::firmware::hex;

struct FloatSample {
  float dt_s, velocity_m_s, force_N;
};

template <typename T> struct Run {
  feedid::Status mid_status{}, final_status{};
  feedid::Estimate<T> mid{}, fin{};
  feedid::Diagnostics diag{};
};

/// Streams the samples through an Estimator<T>, asks for a solve after
/// sample `solve_at` (as the firmware does), continues, and solves at the end.
template <typename T>
Run<T> run(const std::vector<FloatSample>& s, const feedid::Config<T>& cfg, std::size_t solve_at) {
  Run<T> r;
  auto est = std::make_unique<feedid::Estimator<T>>();
  if (est->init(cfg) != feedid::Status::ok) {
    std::fprintf(stderr, "gen_trace: invalid config: %s\n", est->config_error());
    std::exit(2);
  }
  for (std::size_t k = 0; k < s.size(); ++k) {
    feedid::Sample<T> x;
    x.dt_s = T(s[k].dt_s);
    x.velocity_m_s = T(s[k].velocity_m_s);
    x.force_N = T(s[k].force_N);
    (void)est->push(x);  // rejections are counted in diagnostics
    if (k == solve_at) {
      r.mid_status = est->solve();
      r.mid = est->estimate();
    }
  }
  r.final_status = est->solve();
  r.fin = est->estimate();
  r.diag = est->diagnostics();
  return r;
}

template <typename T> std::string result_literal(const feedid::Estimate<T>& e) {
  auto dir = [](const feedid::DirectionEstimate<T>& d) {
    return "{" + hex(float(d.viscous_Ns_m)) + ", " + hex(float(d.coulomb_N)) + ", " + hex(float(d.breakaway_N)) +
           ", " + hex(float(d.stribeck_velocity_m_s)) + ", " + std::to_string(d.flags) + "u}";
  };
  return "{" + hex(float(e.mass_kg)) + ", " + std::to_string(e.mass_flags) + "u, " + dir(e.pos) + ", " +
         dir(e.neg) + "}";
}

std::string truth_literal(const feedid::host::DriveParams& p) {
  auto dir = [](const feedid::host::DirectionFriction& d) {
    return "{" + hex(float(d.viscous_Ns_m)) + ", " + hex(float(d.coulomb_N)) + ", " + hex(float(d.breakaway_N)) +
           ", " + hex(float(d.stribeck_velocity_m_s)) + ", 0u}";
  };
  return "{" + hex(float(p.mass_kg)) + ", 0u, " + dir(p.pos) + ", " + dir(p.neg) + "}";
}

template <typename T> void print_result(const char* what, feedid::Status st, const feedid::Estimate<T>& e) {
  std::fprintf(stderr,
               "gen_trace: %-12s %-17s m %.6g | + sigma %.6g Fc %.6g Fs %.6g vs %.6g flags %u"
               " | - sigma %.6g Fc %.6g Fs %.6g vs %.6g flags %u | m flags %u\n",
               what, feedid::status_name(st), double(e.mass_kg), double(e.pos.viscous_Ns_m),
               double(e.pos.coulomb_N),
               double(e.pos.breakaway_N), double(e.pos.stribeck_velocity_m_s), e.pos.flags,
               double(e.neg.viscous_Ns_m), double(e.neg.coulomb_N), double(e.neg.breakaway_N),
               double(e.neg.stribeck_velocity_m_s), e.neg.flags, e.mass_flags);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: gen_trace OUT.h [duration_s] [rate_hz]\n");
    return 2;
  }
  const std::string out_path = argv[1];
  feedid::host::SimConfig sim;  // the default 100 kg drive
  sim.motion.duration_s = argc > 2 ? std::atof(argv[2]) : 30.0;
  sim.controller.servo_rate_hz = argc > 3 ? std::atof(argv[3]) : 1000.0;
  const feedid::host::Trace tr = feedid::host::simulate(sim);
  const std::size_t n = tr.samples.size();

  // The samples exactly as the firmware holds them: float dt, v, u.
  std::vector<FloatSample> fs(n);
  feedid::host::Trace rounded = tr;
  double t = tr.samples.front().t_s;
  for (std::size_t k = 0; k < n; ++k) {
    const auto& s = tr.samples[k];
    fs[k].dt_s = k == 0 ? 0.0f : static_cast<float>(s.t_s - tr.samples[k - 1].t_s);
    fs[k].velocity_m_s = static_cast<float>(s.v_m_s);
    fs[k].force_N = static_cast<float>(s.u_N);
    t += double(fs[k].dt_s);
    rounded.samples[k] = {t, s.x_m, double(fs[k].velocity_m_s), double(fs[k].force_N)};
  }

  // Configuration: what the host pipeline picks for this trace, each field
  // rounded to float once; the double reference runs with the same values.
  const feedid::Config<float> cf = feedid::host::firmware::float_config_for(rounded);
  const feedid::Config<double> cd = feedid::host::config_as<double>(cf);

  const std::size_t solve_at = n / 2;  // the mid-stream "identify now" request
  const Run<double> ref = run(fs, cd, solve_at);
  const Run<float> hf = run(fs, cf, solve_at);
  print_result("double mid", ref.mid_status, ref.mid);
  print_result("double final", ref.final_status, ref.fin);
  print_result("float mid", hf.mid_status, hf.mid);
  print_result("float final", hf.final_status, hf.fin);
  if (ref.final_status != feedid::Status::ok) {
    std::fprintf(stderr, "gen_trace: the host reference did not solve: %s\n",
                 feedid::status_name(ref.final_status));
    return 2;
  }

  FILE* f = std::fopen(out_path.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "gen_trace: cannot write %s\n", out_path.c_str());
    return 1;
  }
  std::fprintf(f,
               "// Generated by firmware/cortex_m/gen_trace.cpp at build time; do not edit.\n"
               "// Default simulated 100 kg drive (feedid::host::SimConfig{}), %.6g s at %.6g Hz, seed %llu.\n"
               "// Included by exactly one translation unit (main.cpp): the arrays live in flash.\n"
               "#pragma once\n\n#include \"feedid/types.hpp\"\n#include \"trace_format.hpp\"\n\n"
               "namespace feedid::fw::trace {\n\n",
               sim.motion.duration_s, sim.controller.servo_rate_hz, static_cast<unsigned long long>(sim.seed));
  std::fprintf(f, "constexpr uint32_t count = %zuu;\n", n);
  std::fprintf(f, "/// The (simulated) host asks for a solve right after this sample.\n");
  std::fprintf(f, "constexpr uint32_t solve_request_after = %zuu;\n", solve_at);
  std::fprintf(f, "constexpr float sample_rate_hz = %s;\n", hex(float(sim.controller.servo_rate_hz)).c_str());
  std::fprintf(f, "/// Samples the host double reference rejected (the firmware must agree).\n");
  std::fprintf(f, "constexpr uint32_t host_rejected = %lluu;\n\n",
               static_cast<unsigned long long>(ref.diag.samples_rejected));
  feedid::host::firmware::write_config(f, cf);
  std::fprintf(f, "/// Host Estimator<double> on these samples,\n"
                 "/// solved right after sample solve_request_after ...\n");
  std::fprintf(f, "constexpr Result host_double_mid = %s;\n", result_literal(ref.mid).c_str());
  std::fprintf(f, "/// ... and at the end of the trace.\n");
  std::fprintf(f, "constexpr Result host_double_final = %s;\n", result_literal(ref.fin).c_str());
  std::fprintf(f, "/// For information: Estimator<float> on the host, same samples (not compared).\n");
  std::fprintf(f, "constexpr Result host_float_final = %s;\n", result_literal(hf.fin).c_str());
  std::fprintf(f, "/// The simulated drive's true parameters.\n");
  std::fprintf(f, "constexpr Result truth = %s;\n\n", truth_literal(sim.drive).c_str());
  std::fprintf(f, "/// dt (s), v (m/s), u (N) per sample, exact float values.\n");
  std::fprintf(f, "constexpr TracePoint points[count] = {\n");
  for (std::size_t k = 0; k < n; ++k)
    std::fprintf(f, "{%s,%s,%s},\n", hex(fs[k].dt_s).c_str(), hex(fs[k].velocity_m_s).c_str(),
                 hex(fs[k].force_N).c_str());
  std::fprintf(f, "};\n\n}  // namespace feedid::fw::trace\n");
  if (std::fclose(f) != 0) {
    std::fprintf(stderr, "gen_trace: cannot write %s\n", out_path.c_str());
    return 1;
  }
  std::fprintf(stderr, "gen_trace: wrote %s: %zu samples (%.1f KB of flash)\n", out_path.c_str(), n,
               double(n * sizeof(FloatSample)) / 1024.0);
  return 0;
}
