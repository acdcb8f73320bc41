// The closed-loop circle test: two simulated axes (X and Y, each a drive
// with its own friction under the cascaded controller) follow a circle, with
// and without friction feed-forward, and the quadrant glitches at the axis
// reversals are measured. Host only.
#pragma once
#include <array>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/drive_model.hpp"
#include "io/svg_plot.hpp"

namespace feedid::host {

struct CircleOptions {
  double radius_m = 0.01;         ///< circle radius (m)
  double feed_m_s = 0.01;         ///< path speed (m/s): 600 mm/min
  double rate_hz = 2000.0;        ///< servo rate of both axes (Hz)
  double wrong_fraction = 0.2;    ///< the sensitivity runs scale every friction parameter by 1 +- this
  double zero_band_m_s = 1e-4;    ///< feed-forward zero band (core/feedid/feedforward.hpp)
  std::array<DriveParams, 2> drives;  ///< the plants of X and Y
  /// Compensation models (from identify JSON); empty: each axis's own drive,
  /// identified on the spot from a simulated speed-ladder trace.
  std::vector<std::string> model_paths;
  /// Compensation models given directly (X, Y); used before model_paths.
  std::vector<DriveParams> models;
  std::string json_path, plot_path;
  /// Called with the share of the four runs done (0 to 1); none: silent.
  std::function<void(double)> progress;
  CircleOptions();
};

struct CircleRun {
  std::string name;                  ///< none, identified, wrong_plus, wrong_minus
  std::array<double, 4> glitch_um{}; ///< at 0, 90, 180, 270 degrees (X, Y, X, Y reversing)
  double rms_um = 0.0;               ///< RMS radial error over the measured revolution
  std::vector<double> angle_rad, radial_error_um;  ///< the measured revolution
};

struct CircleResult {
  std::array<DriveParams, 2> models;  ///< the compensation models used
  std::vector<CircleRun> runs;        ///< none, identified, wrong_plus, wrong_minus
  double glitch_reduction = 0.0;      ///< 1 - max glitch identified / max glitch none
  std::string error;                  ///< why the test did not run (io/outcome.hpp); empty when it did
};

/// Runs the four cases; `error` for bad options or a model file that cannot be read.
CircleResult run_circle(const CircleOptions& opt);

/// Servo samples in one turn of the circle (each of the four runs goes about
/// two and a quarter): what the test's time grows with.
double samples_per_turn(const CircleOptions& opt);
nlohmann::json to_json(const CircleResult& r, const CircleOptions& opt);
/// The radial error of every run on a polar plot (error magnified).
PlotSpec circle_plot(const CircleResult& r, const CircleOptions& opt);
bool write_circle_plot(const CircleResult& r, const CircleOptions& opt, const std::string& path, std::string& error);

}  // namespace feedid::host
