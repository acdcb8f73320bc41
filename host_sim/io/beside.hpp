// A piece of work run beside the caller's, where a thread can be had.
// Host only.
#pragma once
#include <future>
#include <system_error>
#include <thread>
#include <utility>

namespace feedid::host {

/// f on a thread of its own when `allowed` (a caller's --threads other
/// than 1) and the machine has more than one hardware thread; otherwise,
/// and where no thread can be created, deferred: it runs in get(), on the
/// caller's thread. Either way get() returns f's result (or throws its
/// exception), so the result never depends on which.
template <class F>
auto run_beside(bool allowed, F&& f) -> std::future<decltype(f())> {
  try {
    const bool beside = allowed && std::thread::hardware_concurrency() > 1;
    return std::async(beside ? std::launch::async : std::launch::deferred, f);  // a copy: f stays for the fallback
  } catch (const std::system_error&) {
    return std::async(std::launch::deferred, std::forward<F>(f));
  }
}

}  // namespace feedid::host
