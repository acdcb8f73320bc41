// The closed-loop circle test. Host only.
#include "circle.hpp"
#include "io/output_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "feedid/feedforward.hpp"
#include "identify/identify.hpp"
#include "model/model_file.hpp"
#include "io/svg_plot.hpp"
#include "sim/drive_sim.hpp"

namespace feedid::host {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

/// The circle, centred at (-R, 0) so both axes start at 0. The angular speed
/// ramps up over the first quarter turn: the axes start without a step.
class CirclePath {
 public:
  CirclePath(double radius_m, double feed_m_s)
      : r_(radius_m), w_(feed_m_s / radius_m), ramp_s_(kPi / w_) {}  // 0.5 w ramp = a quarter turn

  double angle(double t) const { return t < ramp_s_ ? 0.5 * w_ * t * t / ramp_s_ : w_ * (t - 0.5 * ramp_s_); }
  /// Axis 0 (X) or 1 (Y) at time t.
  PathPoint axis(int a, double t) const {
    const double th = angle(t);
    const double dth = t < ramp_s_ ? w_ * t / ramp_s_ : w_;
    const double ddth = t < ramp_s_ ? w_ / ramp_s_ : 0.0;
    const double c = std::cos(th), s = std::sin(th);
    if (a == 0) return {r_ * c - r_, -r_ * s * dth, -r_ * c * dth * dth - r_ * s * ddth};
    return {r_ * s, r_ * c * dth, -r_ * s * dth * dth + r_ * c * ddth};
  }
  double radius() const { return r_; }

 private:
  double r_, w_, ramp_s_;
};

SimConfig axis_config(const DriveParams& drive, double rate_hz) {
  SimConfig c;
  c.drive = drive;
  c.controller.servo_rate_hz = rate_hz;
  return c;
}

/// Every friction magnitude scaled by k (the sensitivity runs); vs kept.
DriveParams scaled_friction(DriveParams m, double k) {
  for (DirectionFriction* d : {&m.pos, &m.neg}) {
    d->viscous_Ns_m *= k;
    d->coulomb_N *= k;
    d->breakaway_N *= k;
  }
  return m;
}

/// A drive identified from its own simulated speed-ladder trace.
Outcome<DriveParams> identified_on_the_spot(const DriveParams& drive, double rate_hz) {
  SimConfig c = axis_config(drive, rate_hz);
  c.motion.duration_s = 60.0;
  const std::string why = sim_config_error(c);  // --rate out of range, said as an input error
  if (!why.empty()) return refused<DriveParams>("simulating the drive to identify: " + why);
  const IdentifyResult r = identify(simulate(c), IdentifyOptions{});
  if (!r.error.empty()) return refused<DriveParams>("identifying the simulated drive: " + r.error);
  return {to_drive_params(r.estimate), ""};
}

/// The samples of the measured turn below which its glitches mean nothing.
constexpr std::size_t kMinTurnSamples = 360;
/// Most samples of one turn a run may take (about 10 minutes of this machine).
constexpr double kMaxTurnSamples = 2e7;

/// Wrapped difference a - b in (-pi, pi].
double wrap(double d) { return d - 2.0 * kPi * std::floor((d + kPi) / (2.0 * kPi)); }

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// Both axes around the circle with the given compensation models (null:
/// none); the second full turn is measured (no figures where fewer than
/// kMinTurnSamples sample it).
/// One of the four runs, the run_index-th (progress: its share of all four).
CircleRun run_once(const CircleOptions& opt, const std::string& name, const std::array<DriveParams, 2>* comp,
                   int run_index) {
  const CirclePath path(opt.radius_m, opt.feed_m_s);
  const double dt = 1.0 / opt.rate_hz;
  std::array<ServoAxis, 2> axes = {ServoAxis(axis_config(opt.drives[0], opt.rate_hz)),
                                   ServoAxis(axis_config(opt.drives[1], opt.rate_hz))};
  std::array<feedid::Estimate<double>, 2> model;
  if (comp) model = {to_estimate((*comp)[0]), to_estimate((*comp)[1])};
  const feedid::FeedforwardConfig<double> ff{opt.zero_band_m_s, 0.0};  // the controller adds m a itself

  CircleRun run;
  run.name = name;
  const double first = 2.0 * kPi - 45.0 * kDeg, last = first + 2.0 * kPi;
  for (std::size_t k = 0;; ++k) {
    const double t = static_cast<double>(k) * dt;
    const double th = path.angle(t);
    if (th >= last) break;
    if (opt.progress && k % 65536 == 0) opt.progress((run_index + th / last) / 4.0);
    if (th >= first) {
      const double ex = axes[0].position_m() + opt.radius_m, ey = axes[1].position_m();
      run.angle_rad.push_back(std::atan2(ey, ex));
      run.radial_error_um.push_back(1e6 * (std::hypot(ex, ey) - opt.radius_m));
    }
    for (int a = 0; a < 2; ++a) {
      const PathPoint r = path.axis(a, t), r_next = path.axis(a, t + dt);
      const double u_ff =
          comp ? feedid::feedforward(feedid::EstimateFriction<double>{model[a]}, ff, r.v_m_s, 0.0) : 0.0;
      axes[a].step(t, r, r_next, u_ff);
    }
  }
  if (run.angle_rad.size() < kMinTurnSamples) return run;
  // Glitch: the largest departure from the turn's median radius just after
  // each reversal (X at 0 and 180 degrees, Y at 90 and 270), where friction
  // changes sign and the loop lags behind it.
  const double base = median(run.radial_error_um);
  double ss = 0.0;
  for (std::size_t i = 0; i < run.angle_rad.size(); ++i) {
    const double e = run.radial_error_um[i];
    ss += e * e;
    for (int q = 0; q < 4; ++q) {
      const double d = wrap(run.angle_rad[i] - q * 0.5 * kPi);
      if (d >= -5.0 * kDeg && d <= 25.0 * kDeg) run.glitch_um[q] = std::max(run.glitch_um[q], std::fabs(e - base));
    }
  }
  run.rms_um = std::sqrt(ss / static_cast<double>(run.angle_rad.size()));
  return run;
}

double max_glitch(const CircleRun& r) { return *std::max_element(r.glitch_um.begin(), r.glitch_um.end()); }

}  // namespace

CircleOptions::CircleOptions() {
  drives[1].mass_kg = 60.0;
  drives[1].pos = {500.0, 18.0, 6.0, 2.5e-3};
  drives[1].neg = {520.0, 19.5, 5.5, 2.2e-3};
}

double samples_per_turn(const CircleOptions& opt) { return 2.0 * kPi * opt.radius_m / opt.feed_m_s * opt.rate_hz; }

namespace {

/// Why the options describe no circle test, or empty.
std::string circle_refusal(const CircleOptions& opt) {
  if (!(opt.radius_m > 0) || !(opt.feed_m_s > 0) || !(opt.rate_hz > 0) || !std::isfinite(opt.radius_m) ||
      !std::isfinite(opt.feed_m_s) || !std::isfinite(opt.rate_hz))
    return "--radius, --feed and --rate must be positive and finite";
  // Each of the four runs goes about two turns and a quarter: a radius typed
  // in mm (100 for 0.1 m) ran for hours.
  const double turn_samples = samples_per_turn(opt);
  if (turn_samples > kMaxTurnSamples) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "--radius %g m at --feed %g m/s samples a turn %.3g times at --rate %g Hz, more than "
                  "%.0e (a radius in mm?)", opt.radius_m, opt.feed_m_s, turn_samples, opt.rate_hz, kMaxTurnSamples);
    return buf;
  }
  if (!(opt.wrong_fraction >= 0.0 && opt.wrong_fraction < 1.0))
    return "--wrong " + std::to_string(opt.wrong_fraction) + ": must be in [0, 1) (1 - it scales the friction of the "
           "'wrong_minus' run, which must stay positive)";
  if (!opt.model_paths.empty() && opt.model_paths.size() != 2)
    return "--model: give two (X, then Y), or none to identify the simulated drives";
  if (!opt.models.empty() && opt.models.size() != 2) return "models: give two (X, then Y)";
  return "";
}

/// Axis a's compensation model: given, read from its file, or identified
/// on the simulated drive.
Outcome<DriveParams> compensation_model(const CircleOptions& opt, int a) {
  const auto i = static_cast<std::size_t>(a);
  if (!opt.models.empty()) return {opt.models[i], ""};
  if (opt.model_paths.empty()) return identified_on_the_spot(opt.drives[i], opt.rate_hz);
  const ModelFile file = read_model_file(opt.model_paths[i]);
  if (!file.error.empty()) return {file.drive, file.error};
  // The circle's axes are linear, in m and N: a rotary model or one in volts is another axis's.
  const std::string why = model_units_mismatch({{"units", file.units}}, Units{}, "the circle's axes are linear, in", "");
  return {file.drive, why.empty() ? "" : opt.model_paths[i] + ": " + why};
}
}  // namespace

CircleResult run_circle(const CircleOptions& opt) {
  CircleResult out;
  out.error = circle_refusal(opt);
  for (int a = 0; a < 2 && out.error.empty(); ++a) {
    const Outcome<DriveParams> m = compensation_model(opt, a);
    out.models[a] = m.value;
    out.error = m.error;
  }
  if (!out.error.empty()) return out;
  const std::array<DriveParams, 2> plus = {scaled_friction(out.models[0], 1.0 + opt.wrong_fraction),
                                           scaled_friction(out.models[1], 1.0 + opt.wrong_fraction)};
  const std::array<DriveParams, 2> minus = {scaled_friction(out.models[0], 1.0 - opt.wrong_fraction),
                                            scaled_friction(out.models[1], 1.0 - opt.wrong_fraction)};
  out.runs.push_back(run_once(opt, "none", nullptr, 0));
  out.runs.push_back(run_once(opt, "identified", &out.models, 1));
  out.runs.push_back(run_once(opt, "wrong_plus", &plus, 2));
  out.runs.push_back(run_once(opt, "wrong_minus", &minus, 3));
  if (opt.progress) opt.progress(1.0);
  if (out.runs.front().angle_rad.size() < kMinTurnSamples) {
    out.error = "--rate " + std::to_string(opt.rate_hz) + " Hz samples the measured turn fewer than " +
                std::to_string(kMinTurnSamples) + " times";
    return out;
  }
  out.glitch_reduction = 1.0 - max_glitch(out.runs[1]) / max_glitch(out.runs[0]);
  return out;
}

nlohmann::json to_json(const CircleResult& r, const CircleOptions& opt) {
  nlohmann::json runs;
  for (const auto& run : r.runs)
    runs[run.name] = {{"glitch_um", run.glitch_um}, {"rms_um", run.rms_um}, {"max_glitch_um", max_glitch(run)}};
  return {{"runs", runs},
          {"glitch_reduction", r.glitch_reduction},
          {"models", {{"x", model_json(r.models[0])}, {"y", model_json(r.models[1])}}},
          {"options",
           {{"radius_m", opt.radius_m},
            {"feed_m_s", opt.feed_m_s},
            {"rate_hz", opt.rate_hz},
            {"wrong_fraction", opt.wrong_fraction},
            {"zero_band_m_s", opt.zero_band_m_s}}},
          {"glitch_rule", "largest |radial error - median radial error| from 5 degrees before to 25 degrees after each "
                          "axis reversal (0 and 180 degrees: X reverses; 90 and 270: Y), over the second full turn"}};
}

PlotSpec circle_plot(const CircleResult& r, const CircleOptions& opt) {
  double worst = 0.0;
  for (const auto& run : r.runs)
    for (double e : run.radial_error_um) worst = std::max(worst, std::fabs(e));
  // The radius is drawn as 1 and the error magnified so the worst reaches 0.4.
  const double per_um = worst > 0 ? 0.4 / worst : 0.0;
  PlotSpec p;
  p.title = "Circle test: radial error (magnified), R = " + std::to_string(static_cast<int>(std::lround(opt.radius_m * 1e3))) +
            " mm";
  p.x = {"X (radius 1; error scale: 0.1 = " + std::to_string(static_cast<int>(std::lround(0.1 / per_um))) + " um)", false, -1.5, 1.5};
  p.y = {"Y", false, -1.5, 1.5};
  p.width_px = 560;  // the plot area comes out about square
  p.height_px = 580;
  p.legend = "top-right";  // a corner the circle leaves empty
  PlotSeries ref;
  ref.label = "reference";
  ref.color = "#999999";
  ref.markers = false;
  ref.dashed = true;
  for (int i = 0; i <= 360; ++i) ref.x.push_back(std::cos(i * kDeg)), ref.y.push_back(std::sin(i * kDeg));
  p.series.push_back(ref);
  const char* colors[] = {"#d62728", "#2ca02c", "#1f77b4", "#ff7f0e"};
  for (std::size_t k = 0; k < r.runs.size(); ++k) {
    PlotSeries s;
    s.label = r.runs[k].name;
    s.color = colors[k % 4];
    s.markers = false;
    const auto& run = r.runs[k];
    for (std::size_t i = 0; i < run.angle_rad.size(); i += 4) {
      const double rad = 1.0 + per_um * run.radial_error_um[i];
      s.x.push_back(rad * std::cos(run.angle_rad[i]));
      s.y.push_back(rad * std::sin(run.angle_rad[i]));
    }
    p.series.push_back(s);
  }
  char note[160];
  std::snprintf(note, sizeof note, "largest glitch: none %.3g um, identified %.3g um (%.0f %% lower)",
                max_glitch(r.runs[0]), max_glitch(r.runs[1]), 100.0 * r.glitch_reduction);
  p.note = note;
  return p;
}

bool write_circle_plot(const CircleResult& r, const CircleOptions& opt, const std::string& path, std::string& error) {
  return write_svg(path, circle_plot(r, opt), error);
}

}  // namespace feedid::host
