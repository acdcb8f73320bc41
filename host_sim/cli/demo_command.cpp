// `feedid demo` (cli_common.hpp: the shared options and the Command interface).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "diagnose/diagnose.hpp"
#include "report/report.hpp"
#include "sim_cli.hpp"
#include "cli_common.hpp"

namespace feedid::host::cli {
namespace {

struct DemoCommand : Command {
  SimConfig sim;
  std::string json_path, report_dir;
  DemoCommand() {
    // The built-in default has a 3 N screw-pitch ripple of 5 mm that the
    // model does not know, so the diagnosis has something to find.
    sim.effects.ripple_amplitude_N = 3.0;
    sim.effects.ripple_period_m = 0.005;
  }
  void add(CLI::App& parent) override {
    app = parent.add_subcommand("demo", "built-in default: simulate a drive (with a 3 N, 5 mm position ripple), identify it, diagnose it, compare with the truth");
    add_sim_options(app, sim);
    add_effect_options(app, sim.effects);
    app->add_option("--json", json_path, "write the identification result as JSON");
    app->add_option("--report", report_dir, "write the diagnosis pictures and page to this folder");
  }
  int run() override {
    std::printf("== simulate: %.3g kg drive, %.6g Hz, %.3g s, encoder %.3g m, force noise %.3g N (seed %llu)\n",
                sim.drive.mass_kg, sim.controller.servo_rate_hz, sim.motion.duration_s, sim.sensors.encoder_resolution_m,
                sim.sensors.force_noise_N, static_cast<unsigned long long>(sim.seed));
    const std::vector<std::string> fx = active_effects(sim.effects);
    std::printf("   unmodelled effects in the simulated drive (hidden from identify/diagnose): ");
    for (const auto& e : fx) std::printf("%s ", e.c_str());
    std::printf("%s\n   truth: %s\n", fx.empty() ? "none" : "", effects_json(sim.effects, sim.drive).dump().c_str());
    const Outcome<Trace> simulated = run_simulation(sim);
    if (!simulated.ok()) return bad_input(simulated.error);
    const Trace& t = simulated.value;
    std::printf("== identify (streaming core, double; the unmodelled effect biases some parameters):\n");
    const int rc = report_identify(identify(t, IdentifyOptions{}), json_path, &sim.drive);
    if (rc != 0) return rc;
    std::printf("== diagnose (base model on even time folds, judged on the odd ones):\n");
    const DiagnoseResult d = diagnose(t, DiagnoseOptions{});
    if (!d.error.empty()) return bad_input(d.error);
    std::cout << summary(d);
    if (d.has_augmented_model) print_against_truth(d, sim.drive);
    return write_report(d, report_dir, "feedid demo", "feedid demo --report " + report_dir);
  }
  static void print_against_truth(const DiagnoseResult& d, const DriveParams& t) {
    const DriveParams& a = d.augmented_model;
    std::printf("== the model with %s added (joint fit on the identification folds), against the truth:\n", d.effect.c_str());
    auto row = [](const char* n, const char* unit, double v, double tv) {
      std::printf("  %-22s %12.6g %-6s truth %-11.6g err %+7.3f %%\n", n, v, unit, tv, 100.0 * (v / tv - 1.0));
    };
    row("mass m", "kg", a.mass_kg, t.mass_kg);
    for (int dir = 0; dir < 2; ++dir) {
      const DirectionFriction& x = dir == 0 ? a.pos : a.neg;
      const DirectionFriction& y = dir == 0 ? t.pos : t.neg;
      const std::string sg = dir == 0 ? "+" : "-";
      row(("viscous sigma" + sg).c_str(), "N s/m", x.viscous_Ns_m, y.viscous_Ns_m);
      row(("Coulomb Fc" + sg).c_str(), "N", x.coulomb_N, y.coulomb_N);
      row(("break-away Fs" + sg).c_str(), "N", x.breakaway_N, y.breakaway_N);
      row(("Stribeck vel. vs" + sg).c_str(), "m/s", x.stribeck_velocity_m_s, y.stribeck_velocity_m_s);
    }
  }
};

}  // namespace

std::unique_ptr<Command> make_demo_command() { return std::make_unique<DemoCommand>(); }

}  // namespace feedid::host::cli
