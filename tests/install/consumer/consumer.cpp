// Streams a few samples through the installed core and solves: the headers
// and the package config are enough to build and run it.
#include "feedid/feedid.hpp"

int main() {
  static feedid::Estimator<float> est;  // fixed memory, no heap
  feedid::Config<float> cfg;
  if (est.init(cfg) != feedid::Status::ok) return 1;
  feedid::Sample<float> s;
  s.dt_s = 1e-3f;
  for (int k = 0; k < 100; ++k) {
    s.velocity_m_s = 0.01f;
    s.force_N = 10.0f;
    if (est.push(s) != feedid::Status::ok) return 2;
  }
  return est.diagnostics().samples_accepted == 100 ? 0 : 3;
}
