// An open-loop plant, independent of the closed-loop simulator: the axis
// follows the reference path exactly and the force is its inverse dynamics,
//
//     u(t) = m1 a_ref + F_fric(t, x_ref, v_ref) + F_load(t, x_ref) + F_spring,
//
// so there is no controller, no tracking error and no stick/slip: at rest
// (v_ref = 0) friction is zero and the drive holds only the load. It shares
// the effect parameters of `Effects` but not their code, and several of its
// laws differ on purpose, as another simulator's would (drive_sim.hpp has the
// closed-loop laws):
//
//   thermal drift       Coulomb and viscous both scale by (1 + D e^(-t/tau));
//   position friction   the range's edges ramp over 10 % of its width;
//   presliding          a Dahl state z, dz/dx = (sign(v) - z)/d, starting at
//                       z = 0; friction adds Fp (z - sign(v));
//   compliance          the motor follows the reference; the load behind the
//                       spring rings, and its spring force adds to u;
//   delay               the logged force sequence is shifted by delta,
//                       interpolated linearly between samples.
//
// The force is logged from the continuous u(t) (16 Simpson substeps per
// period): held = its mean over [t_k, t_k+1], instant = u(t_k), averaged =
// its mean over [t_k-1, t_k]. Position is the encoder-quantised reference;
// velocity goes through the drive's filter (drive_log.hpp). Host only.
#pragma once
#include <functional>

#include "drive_sim.hpp"

namespace feedid::host {

/// Called by simulate() for SimConfig::plant == PlantKind::open_loop, after
/// the configuration has been validated; ControllerParams other than the
/// servo rate are not used.
Trace simulate_open_loop(const SimConfig& cfg, const std::function<void(double)>& progress);

}  // namespace feedid::host
