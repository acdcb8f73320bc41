// The one public header of the identification core.
//
//   feedid::Estimator<float> axis;               // one per axis, fixed memory
//   if (axis.init(config) != feedid::Status::ok) ...   // checks every field
//   (void)axis.push(sample);                     // each servo period
//   if (axis.solve() == feedid::Status::ok) use(axis.estimate());
//   u_cmd += feedid::feedforward(feedid::EstimateFriction<float>{axis.estimate()}, ff, v_ref, a_ref);
//
// Freestanding C++17: no heap, exceptions, RTTI, <cmath> or iostream.
#pragma once

#include "feedid/analysis.hpp"
#include "feedid/estimator.hpp"
#include "feedid/feedforward.hpp"
#include "feedid/health_tracker.hpp"
#include "feedid/monitor.hpp"
#include "feedid/statistics.hpp"
#include "feedid/thresholds.hpp"
#include "feedid/types.hpp"
