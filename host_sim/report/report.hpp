// Pictures and a report page for people: the identified friction curve over
// the measured band means (like the seed paper's Fig. 1), the diagnosis
// residual before/after over velocity, position and time, and measured
// against predicted force of a cross-test. Host only.
#pragma once
#include <string>
#include <vector>

#include "diagnose/diagnose.hpp"
#include "gap/model_gap.hpp"
#include "io/svg_plot.hpp"
#include "identify/identify.hpp"
#include "replay/replay.hpp"
#include "validate/validate.hpp"

namespace feedid::host {

/// friction_curve.svg: measured mean friction per velocity band (points) and
/// the identified F(|v|) (lines), both directions, log speed axis.
bool write_friction_curve_svg(const IdentifyResult& r, const std::string& path, std::string& error);

/// The friction-curve figure (the plot write_friction_curve_svg writes).
PlotSpec friction_curve_plot(const IdentifyResult& r);

/// Writes report.html into dir (created if missing): one self-contained
/// page with inline SVG: the verdict, where the gap lies, the candidates,
/// the friction curve, the held-out residual before and after side by side
/// over velocity, position and time, and the base model with the digits
/// its standard errors justify.
/// `command` is the command line that made it, shown so that it can be rerun.
bool write_diagnosis_report(const DiagnoseResult& r, const std::string& dir, const std::string& source,
                            const std::string& command, std::string& error);

/// Measured and predicted force over time (the decimated validation series).
bool write_force_plot_svg(const ValidateResult& r, const std::string& path, const std::string& title,
                          std::string& error);

/// One signal of a replay over time: measured and simulated (`signal`:
/// "position", "velocity", "acceleration" or "force"; at most about 4000
/// points, evenly thinned).
PlotSpec replay_plot(const ReplayResult& r, const std::string& signal, const std::string& title);

/// The difference measured - simulated of one replay signal over time, one
/// series per replay (labels parallel to runs; at most about 4000 points each).
PlotSpec replay_residual_plot(const std::vector<const ReplayResult*>& runs, const std::vector<std::string>& labels,
                              const std::string& signal, const std::string& title);

/// Writes report.html into dir (created if missing) for `diagnose --model`:
/// with a replay, its held-out figures before and after the causes and the
/// overlay and residual of each signal; then the diagnosis's sections (the
/// verdict, where with its windows shaded on the residual, the gap step by
/// step, the candidates, the given model). `command`: the command line shown.
bool write_model_gap_report(const ModelGap& g, const std::string& dir, const std::string& source,
                            const std::string& command, std::string& error);

/// Writes report.html into dir (created if missing): the four relative
/// errors (published comparison, same processing on both sides, and the
/// processing's own share), and the overlay and residual of each signal over time.
bool write_replay_report(const ReplayResult& r, const std::string& dir, const std::string& source,
                         const std::string& command, std::string& error);

/// Writes report.html into dir (created if missing) for a fleet: every
/// axis's parameters side by side, a table (value +- standard error, status,
/// error) and one figure per parameter (m, sigma, fc, fs, vs) with each
/// axis's estimate and +-1 standard error per direction. `rows`: an array of
/// objects with the keys of feedid.fleet.identify_many's columns (path,
/// status, error, m, m_se, pos_sigma, pos_sigma_se, ..., units); a missing
/// or null figure is left blank. `command`: what made it, shown on the page.
bool write_fleet_report(const nlohmann::json& rows, const std::string& dir, const std::string& command,
                        std::string& error);

}  // namespace feedid::host
