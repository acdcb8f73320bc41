// The sign of a logged force, read from the work it does on the motion.
// Drives log force against their own positive direction: a reversing gear
// stage, a motor mounted the other way round, a torque logged as the load's
// reaction, or an encoder counting the other way all log the force with
// the opposite sign to the position. Identified as logged, such a trace
// gives a negative mass and negative friction. Host only.
#pragma once
#include <limits>
#include <string>
#include <vector>

namespace feedid::host {

/// How far beyond zero the sign's evidence must lie to count as known
/// (a ratio in [-1, 1], find_force_sign). Friction opposes the motion in
/// both directions, so the force over positive travel exceeds the force
/// over negative travel by Fc+ + Fc-, whatever constant offset (gravity on
/// a vertical axis) both carry; over their sum of magnitudes that is 1
/// without an offset (the EMPS and SysId logs, the simulator) and
/// Fc / offset with one: 0.2 is an offset up to five times the friction.
/// Inertia adds the kinetic energy a direction's travel ends with, which
/// from rest is positive too.
constexpr double kConclusiveSignRatio = 0.2;

/// Share of each direction's travel cut off at either end of its forces
/// before they are averaged (an interquartile mean): one force row of 1e12
/// in a log peaking at 152 N (EMPS) outweighed all the others in a plain
/// mean and negated every force. Samples holding less than a quarter of a
/// direction's travel, however far out, can move its trimmed mean only
/// within the range of the other forces; friction shifts the whole
/// distribution, which the trimmed mean keeps.
constexpr double kSignTrimmedShare = 0.25;

/// What the logged force was multiplied by, and why.
struct ForceSign {
  int sign = 1;  ///< +1: as logged; -1: negated
  /// The evidence, of the force as logged, in [-1, 1] (NaN: no motion).
  /// Means are over travel (weighted by |dx|) and interquartile
  /// (kSignTrimmedShare). With travel both ways: (f+ - f-) / (|f+| + |f-|),
  /// f+ and f- the mean force over positive and over negative travel.
  /// Travel one way only: the mean force along the motion, u sign(dx),
  /// over the mean of |u| (the net work over the absolute work, robustly).
  double ratio = std::numeric_limits<double>::quiet_NaN();
  bool both_directions = false;  ///< which of the two the ratio is
  /// The ratio is beyond +-kConclusiveSignRatio (or the sign was stated).
  bool conclusive = false;
  bool stated = false;  ///< given by the caller, not read from the data
  /// One line for the summary and the JSON.
  std::string describe() const;
};

/// The sign that makes the logged force oppose the motion as friction does:
/// -1 when the ratio over the position increments of x is below
/// -kConclusiveSignRatio, else +1 (as logged). A direction counts as
/// travelled when it holds a tenth of the travel. Steps longer than
/// max_step_s (gaps between recordings) are left out: a jump of position
/// there is no motion.
ForceSign find_force_sign(const std::vector<double>& t, const std::vector<double>& x, const std::vector<double>& u,
                          double max_step_s);

/// A sign the caller states (+1 or -1), e.g. the one found on a trace's first minute.
ForceSign stated_force_sign(int sign);

}  // namespace feedid::host
