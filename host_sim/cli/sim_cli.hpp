// Command-line options for the simulator's sim-to-real effects and for
// `feedid blind-bench`. Header-only so the library stays free of CLI11; only
// main.cpp includes it. Every option is in SI units; each effect is off until
// its first option is non-zero (drive_sim.hpp, struct Effects, has the equations).
#pragma once
#include <CLI/CLI.hpp>

#include "bench/blind_bench.hpp"
#include "sim/drive_sim.hpp"

namespace feedid::host {

/// Effect options of `simulate` (and `demo`): --offset, --ripple-*, ...
inline void add_effect_options(CLI::App* c, Effects& e) {
  const char* g = "Sim-to-real effects (SI; each off at zero)";
  c->add_option("--offset", e.load.offset_N,
                "constant load force F0 (N): the drive needs +F0 more in both directions and at rest "
                "(gravity on an axis inclined uphill in +, cable drag, sensor offset)")->group(g)->capture_default_str();
  c->add_option("--ripple-amplitude", e.ripple_amplitude_N,
                "position ripple A (N): load force A sin(2 pi x / P + phi) (cogging, screw pitch error)")->group(g)->capture_default_str();
  c->add_option("--ripple-period", e.ripple_period_m, "ripple period P (m)")->group(g)->capture_default_str();
  c->add_option("--ripple-phase", e.ripple_phase_rad, "ripple phase phi (rad)")->group(g)->capture_default_str();
  c->add_option("--position-friction", e.position_friction_N,
                "extra friction dF (N) on [--position-friction-min, --position-friction-max], sign following the direction")->group(g)->capture_default_str();
  c->add_option("--position-friction-min", e.position_friction_x_min_m, "start x_min of the position-friction range (m)")->group(g)->capture_default_str();
  c->add_option("--position-friction-max", e.position_friction_x_max_m, "end x_max of the position-friction range (m)")->group(g)->capture_default_str();
  c->add_option("--drift-fraction", e.drift_fraction,
                "thermal drift D (-): viscous x (1 + D e^(-t/tau)), Coulomb x (1 + 0.3 D e^(-t/tau)); friction falls as it warms")->group(g)->capture_default_str();
  c->add_option("--drift-time-constant", e.drift_time_constant_s, "thermal drift time constant tau (s)")->group(g)->capture_default_str();
  c->add_option("--quadratic-c2", e.quadratic_c2_Ns2_m2, "velocity-squared damping c2 (N s^2/m^2): friction + c2 v|v|")->group(g)->capture_default_str();
  c->add_option("--presliding-force", e.presliding_force_N,
                "presliding Fp (N): after a reversal friction is -2 Fp sign(v) e^(-r/d) below the Coulomb model, r = distance since the reversal")->group(g)->capture_default_str();
  c->add_option("--presliding-distance", e.presliding_distance_m, "presliding distance d (m)")->group(g)->capture_default_str();
  c->add_option("--compliance-frequency", e.compliance_frequency_hz,
                "free resonance (Hz) of a two-mass plant: load behind a spring, encoder on the motor side")->group(g)->capture_default_str();
  c->add_option("--compliance-mass-fraction", e.compliance_mass_fraction, "share of the mass behind the spring (-), in (0, 1)")->group(g)->capture_default_str();
  c->add_option("--compliance-damping", e.compliance_damping_ratio, "damping ratio of the spring mode (-)")->group(g)->capture_default_str();
  c->add_option("--delay", e.delay_s, "recorded force lags the applied one by this (s); fractional samples interpolated")->group(g)->capture_default_str();
  c->add_option("--disturbance-amplitude", e.disturbance_amplitude_N,
                "outside the catalogue: time-periodic load force B sin(2 pi f t + psi) (N)")->group(g)->capture_default_str();
  c->add_option("--disturbance-frequency", e.disturbance_frequency_hz, "disturbance frequency f (Hz)")->group(g)->capture_default_str();
  c->add_option("--disturbance-phase", e.disturbance_phase_rad, "disturbance phase psi (rad)")->group(g)->capture_default_str();
  c->add_option("--wander-force", e.wander_force_N,
                "outside the catalogue: slowly wandering load force, std (N) of an Ornstein-Uhlenbeck process")->group(g)->capture_default_str();
  c->add_option("--wander-time-constant", e.wander_time_constant_s, "correlation time of the wandering force (s)")->group(g)->capture_default_str();
}

/// A change in service (`simulate --change-time ...`; drive_sim.hpp, ServiceChange).
inline void add_change_options(CLI::App* c, ServiceChange& ch) {
  const char* g = "Change in service (friction health; closed-loop plant)";
  c->add_option("--change-time", ch.time_s, "time of a step change in the drive (s); off when negative")->group(g)->capture_default_str();
  c->add_option("--change-coulomb-fraction", ch.coulomb_fraction, "Coulomb friction x (1 + this) from --change-time")->group(g)->capture_default_str();
  c->add_option("--change-viscous-fraction", ch.viscous_fraction, "viscous friction x (1 + this) from --change-time")->group(g)->capture_default_str();
  c->add_option("--change-mass-fraction", ch.mass_fraction, "plant mass x (1 + this) from --change-time")->group(g)->capture_default_str();
  c->add_option_function<std::string>("--change-direction", [&ch](const std::string& v) { ch.direction = v == "pos" ? 1 : v == "neg" ? -1 : 0; },
                                      "direction whose friction changes: pos, neg or both (default)")
      ->group(g)->check(CLI::IsMember({"pos", "neg", "both"}));
  c->add_option("--warmup-drop", ch.warmup_drop,
                "warm-up: Coulomb and viscous friction fall by this share as the temperature rises 20 -> 45 C "
                "(simulate writes it as column temperature_C)")
      ->group(g)->capture_default_str()->check(CLI::Range(0.0, 0.9));
  c->add_option_function<double>("--warmup-minutes", [&ch](double m) { ch.warmup_s = 60.0 * m; }, "length of the warm-up (min)")
      ->group(g)->check(CLI::PositiveNumber);
}

/// Options of `blind-bench`.
inline void add_blind_bench_options(CLI::App* c, BlindOptions& o) {
  c->add_option("--cases", o.cases, "number of traces (labels cycle through none, the 8 effects, unexplained)")->capture_default_str();
  c->add_option("--seed", o.seed, "seed of the case draws")->capture_default_str();
  c->add_option("--json", o.json_path, "write every case, truth, verdict and the scores as JSON");
  c->add_option("--markdown", o.markdown_path, "write the report tables (with the command and machine) as Markdown");
  c->add_option("--threads", o.threads, "worker threads (0: hardware threads, at most 8); results do not depend on it")->capture_default_str();
  c->add_flag("--quiet", o.quiet, "no per-case lines");
  c->add_option("--labels", o.labels, "only these labels, comma-separated (e.g. none, to calibrate false alarms)");
  c->add_option("--plants", o.plants, "plants to draw from, comma-separated: closed (the drive under its controller), open (independent inverse dynamics)")->capture_default_str();
  c->add_option("--programs", o.programs, "motion programs to draw from, comma-separated: ladder, sine, production")->capture_default_str();
  c->add_option("--write-case", o.write_case, "only write case N's trace to --case-csv (and its truth beside it), to diagnose it alone");
  c->add_option("--case-csv", o.case_path, "CSV path for --write-case");
}

}  // namespace feedid::host
