#pragma once
// A teammate that serves one fixed memory through the real exchange protocol (DESIGN §4): it
// announces it on TSC_ANNOUNCE every 0.2 s and answers requests on TSC_REQUEST_<robot> with the
// portions asked for. Unlike a second tscd it never merges what it hears, so every run meets
// the same peer memory. It also records the other robots' announces with the instant it
// handled them (tscd_loop_latency times the announce period from them). Header-only, for the
// crash test and the loop-latency benchmark.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "daemon/memory_snapshot.h"
#include "test/support/namespace_bus.h"
#include "tsc/announce_t.hpp"
#include "tsc/memory_request_t.hpp"

namespace tsc::testing_support {

class ServingPeer {
 public:
  using Clock = std::chrono::steady_clock;
  /// Another robot's announce as the peer handled it.
  struct HeardAnnounce {
    Clock::time_point at;
    int32_t robot = 0;
    int64_t sequence = 0, memory_version = 0;
    int32_t places = 0;
  };

  /// Serves `snapshot` as robot `robot` on the LCM `url`; announces from the start unless
  /// `announcing` is false (then from StartAnnouncing on). Throws when LCM cannot start.
  ServingPeer(int32_t robot, MemorySnapshot snapshot, const std::string& url,
              bool announcing = true)
      : robot_(robot), snapshot_(std::move(snapshot)), lcm_(url), announcing_(announcing) {
    if (!lcm_.good()) throw std::runtime_error("LCM cannot start on " + url);
    lcm_.subscribeFunction("TSC_REQUEST_" + std::to_string(robot), &ServingPeer::OnRequest, this);
    lcm_.subscribeFunction("TSC_ANNOUNCE", &ServingPeer::OnAnnounce, this);
    thread_ = std::thread([this] { Loop(); });
  }
  ~ServingPeer() {
    stop_ = true;
    thread_.join();
  }
  ServingPeer(const ServingPeer&) = delete;
  ServingPeer& operator=(const ServingPeer&) = delete;

  void StartAnnouncing() { announcing_ = true; }
  /// Requests received so far.
  int64_t requests() const { return requests_; }
  /// The portions sent so far, by index (each once, however often asked for).
  std::set<int32_t> served() const {
    std::lock_guard lock(mutex_);
    return served_;
  }
  std::vector<HeardAnnounce> announces() const {
    std::lock_guard lock(mutex_);
    return announces_;
  }

 private:
  static void OnRequest(const lcm::ReceiveBuffer* rbuf, const std::string&, ServingPeer* self) {
    memory_request_t r;
    if (r.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
    ++self->requests_;
    if (r.version == self->snapshot_.version && !r.missing.empty()) {
      self->wanted_.insert(r.missing.begin(), r.missing.end());
    } else {
      for (int32_t i = 0; i < self->snapshot_.count(); ++i) self->wanted_.insert(i);
    }
  }
  static void OnAnnounce(const lcm::ReceiveBuffer* rbuf, const std::string&, ServingPeer* self) {
    const auto at = Clock::now();
    announce_t a;
    if (a.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
    if (a.robot == self->robot_) return;
    std::lock_guard lock(self->mutex_);
    self->announces_.push_back({at, a.robot, a.sequence, a.memory_version, a.places});
  }

  void Loop() {
    auto next_announce = Clock::now();
    int64_t sequence = 0;
    while (!stop_) {
      lcm_.handleTimeout(5);
      // Portions a little apart, as a loaded sender would: a burst of 60 KB datagrams
      // overflows the receiver's socket buffer and costs a retry round of 0.5 s. What arrives
      // meanwhile is handled at once (announces are timed when they arrive), and portions
      // asked for meanwhile go out in the next batch.
      const std::set<int32_t> batch = std::exchange(wanted_, {});
      for (int32_t i : batch) {
        const memory_portion_v2_t portion = snapshot_.Portion(i);
        lcm_.publish("TSC_MEMORY_" + std::to_string(robot_), &portion);
        {
          std::lock_guard lock(mutex_);
          served_.insert(i);
        }
        std::this_thread::sleep_for(std::chrono::microseconds(300));
        lcm_.handleTimeout(0);
      }
      if (announcing_ && Clock::now() >= next_announce) {
        Announce(++sequence);
        next_announce = Clock::now() + std::chrono::milliseconds(200);
      }
    }
  }

  void Announce(int64_t sequence) {
    announce_t a{};
    a.utime = 1;
    a.protocol = announce_t::PROTOCOL;
    a.robot = robot_;
    a.boot_id = 4242;
    a.sequence = sequence;
    DescribeInAnnounce(snapshot_, a);
    a.places = snapshot_.places;
    a.edges = snapshot_.edges;
    a.status = "running";
    a.hmac_size = 0;
    lcm_.publish("TSC_ANNOUNCE", &a);
  }

  const int32_t robot_;
  const MemorySnapshot snapshot_;
  lcm::LCM lcm_;
  std::set<int32_t> wanted_;  // the loop thread only (handlers run inside handleTimeout)
  std::atomic<int64_t> requests_{0};
  std::atomic<bool> stop_{false}, announcing_;
  mutable std::mutex mutex_;
  std::vector<HeardAnnounce> announces_;
  std::set<int32_t> served_;
  std::thread thread_;
};

}  // namespace tsc::testing_support
