#pragma once
// The tests' own LCM client (not tscd code): listens on every channel over real udpm:// inside
// the test's private network namespace, decodes each message with the generated type its
// channel carries, and keeps what it decoded.

#include <atomic>
#include <chrono>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "jaguar/motor_command_t.hpp"
#include "jaguar/motor_state_t.hpp"
#include "test/support/namespace_bus.h"
#include "tsc/announce_t.hpp"
#include "tsc/memory_portion_v2_t.hpp"
#include "tsc/memory_request_t.hpp"
#include "tsc/place_event_t.hpp"
#include "tsc/stats_t.hpp"

namespace tsc::testing_support {

class BusListener {
 public:
  /// Listens on the channels matching `channels` (an LCM regular expression): a test that
  /// moves large memories can leave TSC_MEMORY_* out rather than keep every portion.
  explicit BusListener(const std::string& channels = ".*") : lcm_(kNamespaceBusUrl) {
    if (!lcm_.good())
      throw std::runtime_error("LCM cannot start on " + std::string(kNamespaceBusUrl));
    // The function form: with Debian's LCM 1.3.1 the handler-method form hands its callback
    // another object than its subscription (UBSan: "invalid vptr" at lcm-cpp-impl.hpp:108).
    lcm_.subscribeFunction(channels, &BusListener::Dispatch, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(50);
    });
  }
  ~BusListener() {
    stop_ = true;
    thread_.join();
  }

  lcm::LCM& lcm() { return lcm_; }

  /// Waits up to `timeout` for `predicate` (evaluated under the lock) to hold.
  bool WaitFor(const std::function<bool(const BusListener&)>& predicate,
               std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      {
        std::lock_guard lock(mutex_);
        if (predicate(*this)) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::lock_guard lock(mutex_);
    return predicate(*this);
  }
  /// Runs `f` under the lock.
  void Inspect(const std::function<void(const BusListener&)>& f) {
    std::lock_guard lock(mutex_);
    f(*this);
  }

  // Decoded messages by channel. Under the lock (WaitFor / Inspect).
  std::map<std::string, std::vector<announce_t>> announces;
  std::map<std::string, std::vector<place_event_t>> events;
  std::map<std::string, std::vector<memory_portion_v2_t>> portions;
  std::map<std::string, std::vector<memory_request_t>> requests;
  std::map<std::string, std::vector<stats_t>> stats;
  std::map<std::string, int> undecodable;  ///< messages on a tsc channel that did not decode
  std::map<std::string, int> received;     ///< every message by channel

 private:
  template <typename T>
  bool Decode(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
              std::map<std::string, std::vector<T>>& into) {
    T msg;
    const int n = msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size));
    if (n < 0 || static_cast<uint32_t>(n) != rbuf->data_size) return false;
    into[channel].push_back(std::move(msg));
    return true;
  }
  static void Dispatch(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                       BusListener* self) {
    self->OnMessage(rbuf, channel);
  }
  void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    std::lock_guard lock(mutex_);
    ++received[channel];
    bool ok = true;
    if (channel == "TSC_ANNOUNCE") {
      ok = Decode(rbuf, channel, announces);
    } else if (channel.rfind("TSC_EVENT_", 0) == 0) {
      ok = Decode(rbuf, channel, events);
    } else if (channel.rfind("TSC_MEMORY_", 0) == 0) {
      ok = Decode(rbuf, channel, portions);
    } else if (channel.rfind("TSC_REQUEST_", 0) == 0) {
      ok = Decode(rbuf, channel, requests);
    } else if (channel.rfind("TSC_STATS_", 0) == 0) {
      ok = Decode(rbuf, channel, stats);
    }
    if (!ok) ++undecodable[channel];
  }

  lcm::LCM lcm_;
  std::mutex mutex_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

/// Skips the current test when no private network namespace could be made (test/support/
/// in_netns says so), so multicast never goes anywhere else.
#define TSCD_REQUIRE_PRIVATE_NETNS()                                                      \
  do {                                                                                    \
    if (std::getenv("TSCD_NETNS_UNAVAILABLE") != nullptr ||                               \
        std::getenv("TSCD_IN_NETNS") == nullptr) {                                        \
      GTEST_SKIP() << "no private network namespace (run through test/support/in_netns)"; \
    }                                                                                     \
  } while (0)

/// The last message on one JAGUAR_STATE_<robot> channel (tscd's motor channel: link state,
/// odometry), decoded on its own LCM thread.
class MotorStateSink {
 public:
  explicit MotorStateSink(const std::string& channel) : lcm_(kNamespaceBusUrl) {
    if (!lcm_.good())
      throw std::runtime_error("LCM cannot start on " + std::string(kNamespaceBusUrl));
    // The function form, as in BusListener (LCM 1.3.1's handler-method form is broken).
    lcm_.subscribeFunction(channel, &MotorStateSink::On, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(20);
    });
  }
  ~MotorStateSink() {
    stop_ = true;
    thread_.join();
  }
  std::optional<jaguar::motor_state_t> last() {
    std::lock_guard lock(mutex_);
    return last_;
  }

 private:
  static void On(const lcm::ReceiveBuffer*, const std::string&, const jaguar::motor_state_t* s,
                 MotorStateSink* self) {
    std::lock_guard lock(self->mutex_);
    self->last_ = *s;
  }
  lcm::LCM lcm_;
  std::mutex mutex_;
  std::optional<jaguar::motor_state_t> last_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace tsc::testing_support
