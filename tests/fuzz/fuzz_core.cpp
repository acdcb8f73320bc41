// libFuzzer target: arbitrary configurations and sample streams into the
// float and double estimators (docs/reference.md has the contract).
// Invariants checked on every input, besides ASan/UBSan:
//   - every call returns a Status the enum names;
//   - a rejected sample leaves the statistics exactly as they were;
//   - solve() returns (its work is bounded), and either the running sums are
//     finite or it reports numerical_error;
//   - a published estimate is always finite.
// Build: cmake -DFEEDID_FUZZ=ON with clang (docs/reference.md, "Fuzzing").
#include <fuzzer/FuzzedDataProvider.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "feedid/feedid.hpp"
#include "fuzz_inputs.hpp"

namespace {

/// The object's bytes (padding included, so a byte comparison is exact).
template <typename T> std::vector<unsigned char> bytes_of(const T& a) {
  std::vector<unsigned char> b(sizeof(T));
  std::memcpy(b.data(), &a, sizeof(T));
  return b;
}

template <typename T> bool finite(const feedid::Estimate<T>& e) {
  return feedid::Estimator<T>::finite_estimate(e);
}

template <typename T> void run(FuzzedDataProvider& in) {
  auto est = std::make_unique<feedid::Estimator<T>>();
  const feedid::Status s0 = est->init(config<T>(in));
  require(named(s0));
  if (s0 != feedid::Status::ok) {
    require(est->push(feedid::Sample<T>{}) == feedid::Status::not_initialized);
    return;
  }
  T x = T(0);
  while (in.remaining_bytes() > 0) {
    const feedid::Sample<T> smp = sample(in, x);
    const std::vector<unsigned char> before = bytes_of(est->statistics());
    const feedid::Status s = est->push(smp);
    require(named(s));
    if (s != feedid::Status::ok) require(before == bytes_of(est->statistics()));
    if (in.ConsumeIntegralInRange<int>(0, 255) == 0) {
      const feedid::Status st = est->solve(in.ConsumeBool() ? feedid::Method::paper : feedid::Method::bands);
      require(named(st));
      require(finite(est->estimate()));
    }
  }
  const feedid::Status st = est->solve();
  require(named(st));
  require(feedid::finite_statistics(est->statistics()) || st == feedid::Status::numerical_error);
  require(finite(est->estimate()));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  if (in.ConsumeBool()) run<float>(in);
  else run<double>(in);
  return 0;
}
