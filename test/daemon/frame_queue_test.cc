#include "daemon/frame_queue.h"

#include <gtest/gtest.h>

#include <thread>

namespace tsc {
namespace {

using std::chrono::milliseconds;
using BasePoint = FrameQueue<int>::BasePoint;

// A sweep of `views` views numbered from `first`, as a camera delivers it: only the last view
// ends the base point.
void PushSweep(FrameQueue<int>& queue, int first, int views) {
  for (int v = 0; v < views; ++v) ASSERT_TRUE(queue.Push(first + v, v == views - 1));
}

TEST(FrameQueue, DropsTheOldestWhenFullAndCountsIt) {
  FrameQueue<int> dut(3);
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(dut.Push(i, true));
  EXPECT_EQ(dut.dropped(), 2);
  EXPECT_DOUBLE_EQ(dut.fill(), 1.0);
  EXPECT_EQ(dut.Pop(milliseconds(0)), BasePoint{2});
  EXPECT_EQ(dut.Pop(milliseconds(0)), BasePoint{3});
  EXPECT_EQ(dut.Pop(milliseconds(0)), BasePoint{4});
  EXPECT_FALSE(dut.Pop(milliseconds(1)).has_value());
}

TEST(FrameQueue, HandsOutASweepOnlyOnceItsLastViewArrived) {
  FrameQueue<int> dut(2);
  ASSERT_TRUE(dut.Push(10, false));
  ASSERT_TRUE(dut.Push(11, false));
  EXPECT_EQ(dut.size(), 0u);  // gathered, not waiting
  EXPECT_FALSE(dut.Pop(milliseconds(0)).has_value());
  ASSERT_TRUE(dut.Push(12, true));
  EXPECT_EQ(dut.size(), 1u);
  EXPECT_EQ(dut.Pop(milliseconds(0)), (BasePoint{10, 11, 12}));
}

TEST(FrameQueue, DropsEveryViewOfTheOldestSweepAndCountsTheBasePointOnce) {
  FrameQueue<int> dut(2);
  PushSweep(dut, 0, 3);   // base point 0: views 0 1 2
  PushSweep(dut, 10, 3);  // base point 1
  EXPECT_EQ(dut.dropped(), 0);
  PushSweep(dut, 20, 3);  // full: base point 0 goes, all three views
  EXPECT_EQ(dut.dropped(), 1);
  ASSERT_TRUE(dut.Push(30, false));  // a sweep under way drops nothing yet
  ASSERT_TRUE(dut.Push(31, false));
  EXPECT_EQ(dut.dropped(), 1);
  ASSERT_TRUE(dut.Push(32, true));  // now base point 1 goes
  EXPECT_EQ(dut.dropped(), 2);
  EXPECT_EQ(dut.Pop(milliseconds(0)), (BasePoint{20, 21, 22}));
  EXPECT_EQ(dut.Pop(milliseconds(0)), (BasePoint{30, 31, 32}));
  EXPECT_FALSE(dut.Pop(milliseconds(0)).has_value());
}

// A consumer that falls behind a sweeping producer still gets whole sweeps only, in order,
// and every sweep is either handed out or counted as dropped.
TEST(FrameQueue, ASlowConsumerOfSweepsGetsOnlyWholeSweeps) {
  constexpr int kViews = 6, kSweeps = 2000;
  FrameQueue<int> dut(2);
  std::thread producer([&] {
    for (int s = 0; s < kSweeps; ++s) PushSweep(dut, s * kViews, kViews);
    dut.PushEnd();
  });
  int popped = 0, last = -1;
  for (;;) {
    const std::optional<BasePoint> b = dut.Pop(milliseconds(60000));
    if (!b || b->empty()) break;  // the end (or a failure, caught below)
    EXPECT_EQ(b->size(), static_cast<size_t>(kViews));
    const int sweep = b->front() / kViews;
    for (size_t v = 0; v < b->size(); ++v) {
      EXPECT_EQ((*b)[v], sweep * kViews + static_cast<int>(v));
    }
    EXPECT_GT(sweep, last);
    last = sweep;
    ++popped;
    if (popped % 7 == 0) std::this_thread::sleep_for(milliseconds(1));  // fall behind
  }
  producer.join();
  EXPECT_EQ(popped + dut.dropped(), kSweeps);
}

TEST(FrameQueue, TheEndDiscardsASweepCutOffAndDropsNothing) {
  FrameQueue<int> dut(1);
  PushSweep(dut, 0, 2);
  ASSERT_TRUE(dut.Push(10, false));  // the source stops mid-sweep
  ASSERT_TRUE(dut.PushEnd());        // beyond the capacity: base point 0 stays
  ASSERT_TRUE(dut.PushEnd());        // a second end (shutdown after the camera ended)
  EXPECT_EQ(dut.dropped(), 0);
  EXPECT_EQ(dut.Pop(milliseconds(0)), (BasePoint{0, 1}));
  EXPECT_EQ(dut.Pop(milliseconds(0)), BasePoint{});
  EXPECT_EQ(dut.Pop(milliseconds(0)), BasePoint{});
  EXPECT_FALSE(dut.Pop(milliseconds(0)).has_value());  // view 10 was discarded
  // A full queue whose oldest entry is an end drops the oldest base point after it.
  FrameQueue<int> ended(1);
  ASSERT_TRUE(ended.PushEnd());
  ASSERT_TRUE(ended.Push(1, true));  // beyond the end: a source started again
  ASSERT_TRUE(ended.Push(2, true));
  EXPECT_EQ(ended.dropped(), 1);
  EXPECT_EQ(ended.Pop(milliseconds(0)), BasePoint{});
  EXPECT_EQ(ended.Pop(milliseconds(0)), BasePoint{2});
}

TEST(FrameQueue, CloseWakesAWaiterAndKeepsQueuedFrames) {
  FrameQueue<int> dut(2);
  ASSERT_TRUE(dut.Push(7, true));
  dut.Close();
  EXPECT_FALSE(dut.Push(8, true));
  EXPECT_FALSE(dut.PushEnd());
  EXPECT_EQ(dut.Pop(milliseconds(0)), BasePoint{7});
  EXPECT_FALSE(dut.Pop(milliseconds(0)).has_value());

  FrameQueue<int> waiting(1);
  std::thread closer([&] {
    std::this_thread::sleep_for(milliseconds(50));
    waiting.Close();
  });
  EXPECT_FALSE(waiting.Pop(milliseconds(60000)).has_value());  // returns at Close, not timeout
  closer.join();
  EXPECT_TRUE(waiting.closed());
}

TEST(FrameQueue, ProducerNeverBlocksOnASlowConsumer) {
  FrameQueue<int> dut(4);
  std::thread producer([&] {
    for (int i = 0; i < 10000; ++i) dut.Push(i, true);
  });
  producer.join();  // finishes although nobody pops
  EXPECT_EQ(dut.dropped(), 10000 - 4);
  EXPECT_EQ(dut.Pop(milliseconds(0)), BasePoint{9996});
}

// A replay waits for room: a slow consumer gets every base point in order, none dropped. (A
// dropping queue fails this: the producer runs thousands of pushes ahead of the pops.)
TEST(FrameQueue, AReplayWaitsForRoomAndLosesNothing) {
  FrameQueue<int> dut(2);
  constexpr int kFrames = 2000;
  std::thread producer([&] {
    for (int i = 0; i < kFrames; ++i) ASSERT_TRUE(dut.Push(i, true, /*wait_for_room=*/true));
  });
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_EQ(dut.Pop(milliseconds(60000)), BasePoint{i});
    EXPECT_LE(dut.size(), 2u);
  }
  producer.join();
  EXPECT_EQ(dut.dropped(), 0);
}

// Stopping a replay: a push waiting for room returns false at Close, and what was queued
// before stays (the worker drains it).
TEST(FrameQueue, CloseReleasesAPushWaitingForRoom) {
  FrameQueue<int> dut(1);
  ASSERT_TRUE(dut.Push(1, true, /*wait_for_room=*/true));
  bool pushed = true;
  std::thread producer([&] { pushed = dut.Push(2, true, /*wait_for_room=*/true); });
  dut.Close();
  producer.join();  // returns although nobody pops
  EXPECT_FALSE(pushed);
  EXPECT_EQ(dut.dropped(), 0);
  EXPECT_EQ(dut.Pop(milliseconds(0)), BasePoint{1});
  EXPECT_FALSE(dut.Pop(milliseconds(0)).has_value());
}

}  // namespace
}  // namespace tsc
