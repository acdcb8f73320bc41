// The servo-ISR -> task sample queue (port/feedid_port/include/feedid_port/spsc_queue.hpp):
// FIFO order, overflow counted without corrupting what is queued, the ISR
// path never locking (stub lock policy), a two-thread stress run, and the
// hand-off delivering exactly the stream the core would have seen directly.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>

#include "core/core_trace.hpp"
#include "feedid/feedid.hpp"
#include "feedid_port/spsc_queue.hpp"

namespace {

/// Stub lock policy: counts calls and whether the lock is held, so a test can
/// prove which operations lock.
struct CountingLock {
  static inline std::atomic<int> locks{0};
  static inline std::atomic<int> unlocks{0};
  static void lock() { ++locks; }
  static void unlock() { ++unlocks; }
  static void reset() { locks = 0; unlocks = 0; }
};

/// An item whose parts must stay consistent: a torn or overwritten slot shows.
struct Item {
  uint32_t seq = 0;
  uint32_t check = 0;  ///< ~seq
  double payload = 0;  ///< seq * 0.5
};
Item make_item(uint32_t seq) { return Item{seq, ~seq, seq * 0.5}; }
bool intact(const Item& it) { return it.check == ~it.seq && it.payload == it.seq * 0.5; }

}  // namespace

TEST(SpscQueue, EmptyPopFailsAndLeavesOutputUntouched) {
  // GIVEN an empty queue
  feedid::port::SpscQueue<Item, 8, CountingLock> q;
  Item out = make_item(77);
  // WHEN the consumer pops
  // THEN it gets nothing and its variable keeps its value
  EXPECT_FALSE(q.pop(out));
  EXPECT_EQ(out.seq, 77u);
  EXPECT_TRUE(q.empty());
  EXPECT_EQ(q.size(), 0u);
}

TEST(SpscQueue, FifoOrderAcrossManyWrapArounds) {
  // GIVEN a queue of 8
  feedid::port::SpscQueue<Item, 8, CountingLock> q;
  uint32_t next_in = 0, next_out = 0;
  // WHEN items go in and out in uneven bursts for many laps of the ring
  for (int round = 0; round < 1000; ++round) {
    const int burst = 1 + round % 8;
    for (int i = 0; i < burst; ++i) ASSERT_TRUE(q.push_from_isr(make_item(next_in++)));
    const int take = 1 + (round * 5) % burst;
    for (int i = 0; i < take; ++i) {
      Item it;
      ASSERT_TRUE(q.pop(it));
      // THEN they come out in order, whole
      ASSERT_EQ(it.seq, next_out++);
      ASSERT_TRUE(intact(it));
    }
    Item it;
    while (q.pop(it)) ASSERT_EQ(it.seq, next_out++);
  }
  EXPECT_EQ(next_in, next_out);
  EXPECT_EQ(q.overflow_count(), 0u);
}

TEST(SpscQueue, OverflowIsCountedAndNeverCorruptsQueuedItems) {
  // GIVEN a full queue of 4
  feedid::port::SpscQueue<Item, 4, CountingLock> q;
  for (uint32_t i = 0; i < 4; ++i) ASSERT_TRUE(q.push_from_isr(make_item(i)));
  ASSERT_TRUE(q.full());
  // WHEN the ISR pushes 10 more
  for (uint32_t i = 100; i < 110; ++i) EXPECT_FALSE(q.push_from_isr(make_item(i)));
  // THEN each refusal is counted and nothing queued changed
  EXPECT_EQ(q.overflow_count(), 10u);
  EXPECT_EQ(q.size(), 4u);
  for (uint32_t i = 0; i < 4; ++i) {
    Item it;
    ASSERT_TRUE(q.pop(it));
    EXPECT_EQ(it.seq, i);
    EXPECT_TRUE(intact(it));
  }
  Item it;
  EXPECT_FALSE(q.pop(it));
  // AND the queue works normally afterwards; the count stays until clear()
  EXPECT_TRUE(q.push_from_isr(make_item(200)));
  ASSERT_TRUE(q.pop(it));
  EXPECT_EQ(it.seq, 200u);
  EXPECT_EQ(q.overflow_count(), 10u);
}

TEST(SpscQueue, IsrPathAndPopNeverLock) {
  // GIVEN a queue with the counting stub policy
  CountingLock::reset();
  feedid::port::SpscQueue<Item, 4, CountingLock> q;
  // WHEN the ISR pushes (including into a full queue) and the task pops
  for (uint32_t i = 0; i < 6; ++i) (void)q.push_from_isr(make_item(i));
  Item it;
  while (q.pop(it)) {
  }
  (void)q.size();
  (void)q.overflow_count();
  // THEN no lock was ever taken
  EXPECT_EQ(CountingLock::locks.load(), 0);
  EXPECT_EQ(CountingLock::unlocks.load(), 0);
  // AND clear(), which touches the producer's end, locks exactly once
  ASSERT_TRUE(q.push_from_isr(make_item(9)));
  q.clear();
  EXPECT_EQ(CountingLock::locks.load(), 1);
  EXPECT_EQ(CountingLock::unlocks.load(), 1);
  EXPECT_TRUE(q.empty());
  EXPECT_EQ(q.overflow_count(), 0u);
}

TEST(SpscQueue, ConcurrentProducerAndConsumerLoseNothingButOverflow) {
  // GIVEN a small queue, a producer thread standing in for the ISR and a
  // consumer thread standing in for the background task
  CountingLock::reset();
  auto q = std::make_unique<feedid::port::SpscQueue<Item, 64, CountingLock>>();
  constexpr uint32_t n = 200'000;
  std::atomic<bool> producer_done{false}, consumer_ready{false};
  uint32_t refused = 0;
  // WHEN the producer pushes n numbered items as fast as it can, yielding
  // after a refusal (the item stays lost) so the consumer runs even when both
  // threads share one core
  std::thread producer([&] {
    while (!consumer_ready.load()) std::this_thread::yield();
    for (uint32_t i = 0; i < n; ++i) {
      if (q->push_from_isr(make_item(i))) continue;
      ++refused;
      std::this_thread::yield();
    }
    producer_done = true;
  });
  consumer_ready = true;
  uint32_t received = 0, last = 0, bad = 0, out_of_order = 0;
  bool first = true;
  Item it;
  for (;;) {
    if (q->pop(it)) {
      if (!intact(it)) ++bad;
      if (!first && it.seq <= last) ++out_of_order;
      last = it.seq;
      first = false;
      ++received;
    } else if (!producer_done.load()) {
      std::this_thread::yield();
    } else {
      if (!q->pop(it)) break;
      if (!intact(it)) ++bad;
      if (!first && it.seq <= last) ++out_of_order;
      last = it.seq;
      ++received;
    }
  }
  producer.join();
  RecordProperty("received", static_cast<int>(received));
  RecordProperty("overflow", static_cast<int>(q->overflow_count()));
  // THEN every item is either received whole and in order or counted as overflow
  EXPECT_GT(received, 0u);
  EXPECT_EQ(bad, 0u);
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_EQ(received + q->overflow_count(), n);
  EXPECT_EQ(q->overflow_count(), refused);
  EXPECT_EQ(CountingLock::locks.load(), 0);
}

TEST(SpscQueue, HandOffFeedsTheCoreTheSameStreamAsDirectPushes) {
  // GIVEN a 1 kHz ladder of strokes, and two identical estimators
  const feedid::core_test::StrokeSpec spec;
  const auto samples = feedid::core_test::stroke_ladder(feedid::core_test::default_drive(), spec);
  const feedid::Config<double> cfg = feedid::core_test::default_config<double>(spec.encoder_m, spec.rate_hz);
  auto direct = std::make_unique<feedid::Estimator<double>>();
  auto via_queue = std::make_unique<feedid::Estimator<double>>();
  ASSERT_EQ(direct->init(cfg), feedid::Status::ok);
  ASSERT_EQ(via_queue->init(cfg), feedid::Status::ok);
  feedid::port::SpscQueue<feedid::Sample<double>, 16, CountingLock> q;
  CountingLock::reset();
  // WHEN one gets each sample directly and the other through the queue, the
  // "ISR" pushing up to 5 samples before the "task" drains
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const feedid::Sample<double>& s = samples[k];
    (void)direct->push(s);
    ASSERT_TRUE(q.push_from_isr(s));
    if (k % 5 == 4 || k + 1 == samples.size()) {
      feedid::Sample<double> out;
      while (q.pop(out)) (void)via_queue->push(out);
    }
  }
  ASSERT_EQ(direct->solve(), feedid::Status::ok);
  ASSERT_EQ(via_queue->solve(), feedid::Status::ok);
  // THEN both saw the same stream: identical counters and estimates, no locks
  EXPECT_EQ(direct->diagnostics().samples_accepted, via_queue->diagnostics().samples_accepted);
  EXPECT_EQ(direct->estimate().mass_kg, via_queue->estimate().mass_kg);
  EXPECT_EQ(direct->estimate().pos.coulomb_N, via_queue->estimate().pos.coulomb_N);
  EXPECT_EQ(direct->estimate().neg.stribeck_velocity_m_s, via_queue->estimate().neg.stribeck_velocity_m_s);
  EXPECT_EQ(q.overflow_count(), 0u);
  EXPECT_EQ(CountingLock::locks.load(), 0);
}
