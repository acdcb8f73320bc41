// Fixed-capacity single-producer / single-consumer queue for the servo
// interrupt -> background task hand-off of samples (ETL's queue_spsc_isr
// idea: capacity is a template parameter, full and empty are return values,
// interrupt-side calls are named ..._from_isr, locking is a policy type).
//
//   servo ISR (producer)                  background task (consumer)
//   if (!q.push_from_isr(s)) { ... }      while (q.pop(s)) (void)axis.push(s.sample);
//
// Data path: lock-free. The producer alone writes `write_` and the slots it
// owns, the consumer alone writes `read_`; each publishes with a release
// store and reads the other's index with an acquire load, so a slot is never
// read before it is completely written nor overwritten before it is read.
// Neither push_from_isr nor pop ever calls the lock policy: the ISR can never
// wait for the task, and the task never raises the ISR's latency.
//
// LockPolicy (static void lock(); static void unlock();) is used only by the
// task-side operations that touch both ends at once (clear()): on a
// Cortex-M it masks interrupts (port/cortex_m/board.hpp); a host test
// counts its calls to prove the ISR path takes none.
//
// Overflow: push_from_isr on a full queue stores nothing, returns false and
// counts the lost item in overflow_count(); items already queued are untouched.
//
// Single core (or one producer core and one consumer core with coherent
// memory). Freestanding: <atomic> and <stddef.h> only, no heap.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include <atomic>

namespace feedid::port {

/// A lock policy that does nothing, for a host where the queue's two sides
/// are plain threads and clear() is called only while both are quiet.
struct NoLock {
  static void lock() {}
  static void unlock() {}
};

template <typename T, size_t Capacity, typename LockPolicy> class SpscQueue {
  static_assert(Capacity >= 2, "capacity of at least 2 items");
  static_assert((Capacity & (Capacity - 1)) == 0,
                "capacity must be a power of two (indices run freely and wrap modulo 2^32)");
  static_assert(Capacity <= (size_t(1) << 31), "capacity must fit the 32-bit index arithmetic");
  static_assert(std::atomic<uint32_t>::is_always_lock_free, "needs lock-free 32-bit atomics");

 public:
  using value_type = T;
  static constexpr size_t capacity() { return Capacity; }

  /// Appends `item` unless the queue is full. Never blocks, never locks.
  /// Returns false (and counts one overflow) when full; nothing is stored then.
  /// Context: the single producer, normally the servo ISR. Runs fast: two
  /// atomic loads, one copy of T, one release store.
  [[nodiscard]] bool push_from_isr(const T& item) {
    const uint32_t w = write_.load(std::memory_order_relaxed);  // only we write it
    const uint32_t r = read_.load(std::memory_order_acquire);   // slot r is free once read_ moved past it
    if (w - r >= Capacity) {
      overflow_.store(overflow_.load(std::memory_order_relaxed) + 1u, std::memory_order_relaxed);
      return false;
    }
    slots_[w & mask] = item;
    write_.store(w + 1u, std::memory_order_release);  // publish the slot
    return true;
  }

  /// Takes the oldest item into `out`; false (and `out` untouched) if empty.
  /// Never locks. Context: the single consumer (background task).
  [[nodiscard]] bool pop(T& out) {
    const uint32_t r = read_.load(std::memory_order_relaxed);   // only we write it
    const uint32_t w = write_.load(std::memory_order_acquire);  // slots before w are complete
    if (w == r) return false;
    out = slots_[r & mask];
    read_.store(r + 1u, std::memory_order_release);  // hand the slot back
    return true;
  }

  /// Items waiting (a snapshot; exact when called by either side about its
  /// own end). Context: either side.
  size_t size() const {
    const uint32_t r = read_.load(std::memory_order_acquire);
    const uint32_t w = write_.load(std::memory_order_acquire);
    return static_cast<size_t>(w - r);
  }
  bool empty() const { return size() == 0; }
  bool full() const { return size() >= Capacity; }

  /// Items refused because the queue was full, since construction or clear().
  /// Context: either side (a 32-bit atomic read).
  uint32_t overflow_count() const { return overflow_.load(std::memory_order_relaxed); }

  /// Drops every queued item and zeroes the overflow count. Touches the
  /// producer's index, so it runs under LockPolicy (interrupts masked on a
  /// Cortex-M). Context: task only, never the ISR.
  void clear() {
    LockPolicy::lock();
    read_.store(write_.load(std::memory_order_relaxed), std::memory_order_release);
    overflow_.store(0u, std::memory_order_relaxed);
    LockPolicy::unlock();
  }

 private:
  static constexpr uint32_t mask = static_cast<uint32_t>(Capacity - 1);
  T slots_[Capacity] = {};
  std::atomic<uint32_t> write_{0};     ///< items ever pushed (mod 2^32); producer writes
  std::atomic<uint32_t> read_{0};      ///< items ever popped (mod 2^32); consumer writes
  std::atomic<uint32_t> overflow_{0};  ///< items refused while full; producer writes
};

}  // namespace feedid::port
