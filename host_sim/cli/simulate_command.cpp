// `feedid simulate` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "sim/drive_sim.hpp"
#include "sim_cli.hpp"
#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

/// The service change and warm-up of the run (--change-*, --warmup-*), for
/// the truth file; null where neither is on. The model beside it is the
/// drive before them.
nlohmann::json change_json(const ServiceChange& ch) {
  if (!ch.on() && !ch.warms_up()) return nullptr;
  nlohmann::json j;
  if (ch.on())
    j["step"] = {{"time_s", ch.time_s},
                 {"coulomb_fraction", ch.coulomb_fraction},
                 {"viscous_fraction", ch.viscous_fraction},
                 {"mass_fraction", ch.mass_fraction},
                 {"direction", ch.direction > 0 ? "positive" : ch.direction < 0 ? "negative" : "both"}};
  if (ch.warms_up())  // the nominal ramp; a run shorter than it ends part way (temperature_C column)
    j["warmup"] = {{"ramp_s", ch.warmup_s},
                   {"ramp_temperature_C", {20.0, 45.0}},
                   {"friction_drop_at_ramp_end", ch.warmup_drop},
                   {"column", "temperature_C"}};
  return j;
}

struct SimulateCommand : Command {
  SimConfig sim;
  std::string out_path, truth_path;
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("simulate", "simulate a closed-loop feed drive and write a trace CSV (t,x,v,u)");
    add_sim_options(app, sim);
    add_effect_options(app, sim.effects);
    add_change_options(app, sim.change);
    app->add_option("--out", out_path, "trace CSV to write")->required();
    app->add_option("--truth", truth_path, "also write the true parameters as JSON");
  }
  int run() override {
    const Outcome<Trace> simulated = run_simulation(sim);
    if (!simulated.ok()) return bad_input(simulated.error);
    const Trace& t = simulated.value;
    if (const std::string why = saturated_command(t, sim); !why.empty()) std::fprintf(stderr, "warning: %s\n", why.c_str());
    std::string err;
    const ServiceChange& ch = sim.change;
    const ExtraColumn temperature{"temperature_C", [&ch](double t_s) { return ch.temperature_C(t_s); }};
    if (!write_trace_csv(out_path, t, err, ch.warms_up() ? &temperature : nullptr)) return output_failed(err);
    if (!truth_path.empty()) {
      nlohmann::json tj = model_json(sim.drive);
      // A model file's "effects" is diagnose's list, which validate, replay
      // and diagnose --model read; the simulator's own, by name, go beside it.
      const nlohmann::json simulated = effects_json(sim.effects, sim.drive);
      tj["effects"] = nlohmann::json::array();
      if (!simulated.empty()) tj["simulated_effects"] = simulated;
      if (const nlohmann::json change = change_json(sim.change); !change.is_null()) tj["simulated_change"] = change;
      if (!write_json(truth_path, tj)) return 1;
    }
    std::printf("wrote %s: %zu samples, %.3g s at %.6g Hz\n", out_path.c_str(), t.samples.size(), sim.motion.duration_s,
                sim.controller.servo_rate_hz);
    return 0;
  }
};

}  // namespace

std::unique_ptr<Command> make_simulate_command() { return std::make_unique<SimulateCommand>(); }

}  // namespace feedid::host::cli
