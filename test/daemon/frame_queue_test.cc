#include "daemon/frame_queue.h"

#include <gtest/gtest.h>

#include <thread>

namespace tsc {
namespace {

using std::chrono::milliseconds;

TEST(FrameQueue, DropsTheOldestWhenFullAndCountsIt) {
  FrameQueue<int> dut(3);
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(dut.Push(i));
  EXPECT_EQ(dut.dropped(), 2);
  EXPECT_DOUBLE_EQ(dut.fill(), 1.0);
  EXPECT_EQ(dut.Pop(milliseconds(0)), 2);
  EXPECT_EQ(dut.Pop(milliseconds(0)), 3);
  EXPECT_EQ(dut.Pop(milliseconds(0)), 4);
  EXPECT_FALSE(dut.Pop(milliseconds(1)).has_value());
}

TEST(FrameQueue, CloseWakesAWaiterAndKeepsQueuedFrames) {
  FrameQueue<int> dut(2);
  ASSERT_TRUE(dut.Push(7));
  dut.Close();
  EXPECT_FALSE(dut.Push(8));
  EXPECT_EQ(dut.Pop(milliseconds(0)), 7);
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
    for (int i = 0; i < 10000; ++i) dut.Push(i);
  });
  producer.join();  // finishes although nobody pops
  EXPECT_EQ(dut.dropped(), 10000 - 4);
  EXPECT_EQ(dut.Pop(milliseconds(0)), 9996);
}

}  // namespace
}  // namespace tsc
