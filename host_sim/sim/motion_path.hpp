// Reference paths the simulated drives follow: a list of pieces (constant
// acceleration or half-cosine), built once per trace from MotionParams and
// read forward in time. Three programs (docs/diagnosis.md, "Motions"):
//
//   ladder      reciprocating trapezoid strokes at log-spaced peak speeds,
//               each followed by a dwell (the identification run);
//   sine        reciprocation by half-cosines between turning points; every
//               2-4 cycles the amplitude and the peak speed change;
//   production  a part program: rapids at the top speed, feeds at three feed
//               rates, short jogs and dwells, to random positions.
//
// Deterministic for a given MotionParams and seed. Host only.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "io/outcome.hpp"

namespace feedid::host {

enum class Program { ladder, sine, production };
const char* program_name(Program p);
/// "ladder", "sine", "production"; the error names --program.
Outcome<Program> parse_program(const std::string& s);

struct MotionParams {
  Program program = Program::ladder;
  double slowest_speed_m_s = 2.0e-4;  ///< lowest peak speed (ladder, sine) / jog speed floor (production)
  double fastest_speed_m_s = 0.15;    ///< highest peak speed; the rapid speed of production
  int speed_levels = 14;              ///< ladder: peak speeds log-spaced between slowest and fastest
  double acceleration_m_s2 = 1.0;     ///< reference acceleration (m/s^2); the sine's peak acceleration bound
  double cruise_time_s = 0.6;         ///< ladder: time at peak speed per stroke (s), capped by travel
  double max_travel_m = 0.4;          ///< the path stays in [0, max_travel] (m)
  double dwell_s = 0.15;              ///< ladder: rest between strokes (s)
  double duration_s = 60.0;           ///< total trace length (s); the program repeats or continues
};

/// The reference at one instant.
struct PathPoint {
  double x_m = 0.0;
  double v_m_s = 0.0;
  double a_m_s2 = 0.0;
};

/// One piece of the path, starting at t0_s and lasting duration_s.
struct PathPiece {
  enum class Shape { polynomial, half_cosine };
  Shape shape = Shape::polynomial;
  double t0_s = 0.0;
  double duration_s = 0.0;
  double x0_m = 0.0;      ///< position at the start
  double v0_m_s = 0.0;    ///< polynomial: velocity at the start
  double a_m_s2 = 0.0;    ///< polynomial: constant acceleration
  double x1_m = 0.0;      ///< half_cosine: position at the end (v = 0 at both ends)
  PathPoint at(double tau_s) const;  ///< tau_s in [0, duration_s]
};

class MotionPath {
 public:
  /// Builds the pieces up to m.duration_s; `seed` draws the sine and
  /// production programs (the ladder has no randomness). None where the
  /// speeds and travel allow no stroke (sim_config_error says so).
  MotionPath(const MotionParams& m, std::uint64_t seed);

  /// Reference at t_s; t_s must not decrease between calls (a cursor moves on).
  PathPoint at(double t_s);

  const std::vector<PathPiece>& pieces() const { return pieces_; }

 private:
  std::vector<PathPiece> pieces_;
  std::size_t cursor_ = 0;
};

}  // namespace feedid::host
