// A position logged modulo a period: a single-turn angle in [-pi, pi) or
// [0, 2 pi), an encoder counter that overflows, or an axis re-homed once.
// Taken as logged, each wrap is a jump of a whole period within one sample:
// a rotary log wrapped to +-pi came out "not enough motion". Host only.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace feedid::host {

struct PositionWrap {
  double period = 0.0;    ///< the jump taken out at each wrap (position unit); 0: none found
  std::size_t wraps = 0;  ///< jumps taken out
  bool found() const { return wraps > 0; }
  std::string describe() const;  ///< for the position's origin in summaries and JSON
};

/// A step is a wrap when it covers more than half the position's span and
/// more than kWrapOverStep times the steps either side of it. Its period is
/// the step less the motion the neighbouring steps predict. All wraps must
/// agree on one period (within kWrapAgreement of their median) that the span
/// does not exceed by more than that, or none is taken out: a position that
/// really moved so far in one sample is not a convention to undo. A period
/// within kWrapTwoPiTolerance of 2 pi is taken as 2 pi exactly, so that
/// hundreds of wraps add no drift. Steps across a gap longer than
/// max_step_s are not continuous and never count.
constexpr double kWrapOverStep = 20.0;
constexpr double kWrapAgreement = 0.05;
constexpr double kWrapTwoPiTolerance = 1e-3;

PositionWrap find_position_wrap(const std::vector<double>& t, const std::vector<double>& x, double max_step_s);

/// Finds the wraps as above and takes them out, so that the position runs
/// on: the period is added or taken away from each wrap onwards.
PositionWrap unwrap_position(const std::vector<double>& t, std::vector<double>& x, double max_step_s);

}  // namespace feedid::host
