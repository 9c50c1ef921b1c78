#pragma once
// What tscd sends to and takes from its team on LCM (DESIGN §4): exchange messages signed with
// the team key and checked on receipt, and the traffic per channel family that
// TSC_STATS_<robot> reports. Event loop thread only.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "daemon/daemon_counters.h"
#include "daemon/lcm_bus.h"
#include "daemon/team_key.h"

namespace tsc {

class stats_t;

/// The channel families tscd publishes on, for its traffic counters (TSC_STATS_<robot>).
enum class ChannelFamily { kAnnounce, kMemory, kRequest, kEvent, kStats };
inline constexpr int kChannelFamilies = 5;
/// "TSC_ANNOUNCE", "TSC_MEMORY", … (the channel without its robot suffix).
const char* ChannelFamilyName(ChannelFamily family);

/// Messages and bytes sent and received on one channel family.
struct ChannelTraffic {
  int64_t sent = 0;
  int64_t sent_bytes = 0;
  int64_t received = 0;  ///< authentic messages of other robots
  int64_t received_bytes = 0;
};

class TeamBus {
 public:
  /// Sends and receives on `bus`. `team_key`, when given, signs every exchange message sent
  /// and is required of every one received; without it nothing is signed or checked.
  /// `counters` count the messages dropped and the sends LCM refused.
  TeamBus(LcmBus& bus, std::optional<TeamKey> team_key, DaemonCounters& counters);

  bool signs() const { return team_key_.has_value(); }
  LcmBus& lcm() { return bus_; }

  /// Decodes an exchange message (announce_t, memory_portion_v2_t, memory_request_t) and checks
  /// its signature; counts and logs what it drops (`what` names the message in the log).
  template <typename T>
  std::optional<T> Authentic(const std::string& channel, const uint8_t* data, size_t size,
                             const char* what);
  /// Signs (with a team key) and publishes an exchange message, counted in `family`.
  template <typename T>
  bool PublishSigned(ChannelFamily family, const std::string& channel, T msg);
  /// Publishes and counts the message in its family's traffic.
  template <typename T>
  bool PublishCounted(ChannelFamily family, const std::string& channel, const T& msg);
  /// Counts an authentic message of another robot received in `family`.
  void CountReceived(ChannelFamily family, size_t bytes);
  /// Counts a send LCM refused and logs the first ones, then one in a hundred.
  void PublishFailed(const std::string& channel);
  /// Publishes `s` on `channel` with the traffic of every family, this message included.
  void PublishStats(const std::string& channel, stats_t s);

 private:
  LcmBus& bus_;
  const std::optional<TeamKey> team_key_;
  DaemonCounters& counters_;
  std::array<ChannelTraffic, kChannelFamilies> traffic_{};
};

}  // namespace tsc
