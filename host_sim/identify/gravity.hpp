// A gravity term beside the friction (issue 31): a load that does not
// reverse with the motion. The core's model, u = m a + F(v), has no place
// for it, so it is fitted to what the friction fit leaves and taken off the
// force, and the friction identified again. Host only.
#pragma once
#include "identify/identify.hpp"

namespace feedid::host {

/// identify_prepared() with opt.gravity's term (identify_prepared() calls
/// this when it is not none):
/// - constant: G = (Fc+ - Fc-) / 2, the assumption being Coulomb friction
///   the same both ways (the data cannot tell a constant load from
///   asymmetric friction: SysId's kG makes the same assumption);
/// - angle: G cos(q - q0) on a rotary axis (q in rad), fitted by least
///   squares to the residual's block means with each direction's own
///   level, twice (the second on the friction fitted without the first);
/// - automatic: angle on a rotary axis that turns at least kGravityMinSpan_rad
///   where G is at least kGravityMinZ standard errors and a tenth of the
///   Coulomb friction; else none, said why.
/// Every round identifies the prepared signals with the load taken off
/// (identify_prepared): the conventions found once serve all of them.
IdentifyResult identify_with_gravity(Signals prepared, const IdentifyOptions& opt, const std::string& source,
                                     const std::vector<std::size_t>& run_starts);

/// Why --gravity angle is refused on a log without position: an angle
/// integrated from the velocity has no zero, so cos(q - q0) has no q.
constexpr const char* kGravityAngleNeedsPosition = "--gravity angle needs the arm's angle: give the position column";
constexpr double kGravityMinSpan_rad = 0.5;  ///< less, and cos(q - q0) is a tilted line: Coulomb and G trade
constexpr double kGravityMinZ = 5.0;         ///< an automatic term must stand this far above its error
/// ... and be worth a model term: on a simulated axis without a load the
/// fit found G = 0.13 +- 0.11 N m, against 25 N m Coulomb. The errors'
/// coverage, over 12 simulated arms with G = 30 N m at q0 = 0.4 rad: G
/// within 1.96 errors in 12 (mean 30.006, spread 0.016, error 0.115:
/// conservative), q0 in 12 (0.0042 rad low, error 0.0035). Block scatter
/// alone covered q0 in 3: the friction law's misfit at the travel's ends
/// shifts the load without scattering it, and differs by direction, so
/// the errors carry how far each direction's fit parts from the other's.
constexpr double kGravityMinShareOfCoulomb = 0.1;

const char* gravity_name(GravityTerm g);
/// The fitted term as a model's load (model/drive_model.hpp): a constant G
/// is a constant force, the angle form an arm's weight; none: no load.
ModelLoad gravity_load(const GravityFit& g);
/// The term named none, constant, angle or auto; false for another name.
bool gravity_from_name(const std::string& name, GravityTerm& g);

}  // namespace feedid::host
