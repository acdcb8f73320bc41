// Pictures and a report page for people: the identified friction curve over
// the measured band means (like the seed paper's Fig. 1), the diagnosis
// residual before/after over velocity, position and time, and measured
// against predicted force of a cross-test. Host only.
#pragma once
#include <string>

#include "diagnose.hpp"
#include "identify.hpp"
#include "validate.hpp"

namespace feedid::host {

/// friction_curve.svg: measured mean friction per velocity band (points) and
/// the identified F(|v|) (lines), both directions, log speed axis.
bool write_friction_curve_svg(const IdentifyResult& r, const std::string& path, std::string& error);

/// Writes friction_curve.svg, residual_velocity.svg, residual_position.svg,
/// residual_time.svg and report.md into dir (created if missing).
bool write_diagnosis_report(const DiagnoseResult& r, const std::string& dir, const std::string& source,
                            std::string& error);

/// Measured and predicted force over time (the decimated validation series).
bool write_force_plot_svg(const ValidateResult& r, const std::string& path, const std::string& title,
                          std::string& error);

}  // namespace feedid::host
