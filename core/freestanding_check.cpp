// Compiled with -ffreestanding -fno-exceptions -fno-rtti on every host build:
// the core must need nothing from the hosted library.
#include "feedid/feedid.hpp"

namespace {
feedid::Estimator<float> axis_f;
feedid::Estimator<double> axis_d;
}  // namespace

int feedid_freestanding_check() {
  feedid::Config<float> cf;
  feedid::Config<double> cd;
  if (axis_f.init(cf) != feedid::Status::ok || axis_d.init(cd) != feedid::Status::ok) return 1;
  feedid::Sample<float> s;
  (void)axis_f.push(s);
  return axis_f.solve() == feedid::Status::ok ? 0 : 2;
}
