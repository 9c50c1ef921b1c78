#include "daemon/team_bus.h"

#include <spdlog/spdlog.h>

#include <vector>

#include "daemon/log_throttle.h"
#include "tsc/announce_t.hpp"
#include "tsc/memory_portion_v2_t.hpp"
#include "tsc/memory_request_t.hpp"
#include "tsc/place_event_t.hpp"
#include "tsc/stats_t.hpp"

namespace tsc {

const char* ChannelFamilyName(ChannelFamily family) {
  switch (family) {
    case ChannelFamily::kAnnounce:
      return "TSC_ANNOUNCE";
    case ChannelFamily::kMemory:
      return "TSC_MEMORY";
    case ChannelFamily::kRequest:
      return "TSC_REQUEST";
    case ChannelFamily::kEvent:
      return "TSC_EVENT";
    case ChannelFamily::kStats:
      return "TSC_STATS";
  }
  return "?";
}

TeamBus::TeamBus(LcmBus& bus, std::optional<TeamKey> team_key, DaemonCounters& counters)
    : bus_(bus), team_key_(std::move(team_key)), counters_(counters) {}

template <typename T>
std::optional<T> TeamBus::Authentic(const std::string& channel, const uint8_t* data, size_t size,
                                    const char* what) {
  std::optional<T> msg = LcmBus::Decode<T>(data, size);
  const char* problem = nullptr;
  if (!msg) {
    problem = "a malformed";
  } else if (team_key_ &&
             !VerifyMessage(*team_key_, *msg, [](const T& m) { return LcmBus::Encode(m); })) {
    problem = msg->hmac_size == 0 ? "an unsigned" : "a forged";
  }
  if (problem == nullptr) return msg;
  const int64_t n = ++counters_.messages_rejected;
  if (ShouldLog(n)) spdlog::warn("{}: dropped {} {} ({} bytes)", channel, problem, what, size);
  return std::nullopt;
}

template <typename T>
bool TeamBus::PublishSigned(ChannelFamily family, const std::string& channel, T msg) {
  if (team_key_) {
    SignMessage(*team_key_, msg, [](const T& m) { return LcmBus::Encode(m); });
  }
  return PublishCounted(family, channel, msg);
}

template <typename T>
bool TeamBus::PublishCounted(ChannelFamily family, const std::string& channel, const T& msg) {
  const std::vector<uint8_t> bytes = LcmBus::Encode(msg);
  if (!bus_.PublishRaw(channel, bytes)) return false;
  ChannelTraffic& t = traffic_[static_cast<size_t>(family)];
  ++t.sent;
  t.sent_bytes += static_cast<int64_t>(bytes.size());
  return true;
}

// The messages tscd exchanges with its team.
template std::optional<announce_t> TeamBus::Authentic(const std::string&, const uint8_t*, size_t,
                                                      const char*);
template std::optional<memory_portion_v2_t> TeamBus::Authentic(const std::string&, const uint8_t*,
                                                               size_t, const char*);
template std::optional<memory_request_t> TeamBus::Authentic(const std::string&, const uint8_t*,
                                                            size_t, const char*);
template bool TeamBus::PublishSigned(ChannelFamily, const std::string&, announce_t);
template bool TeamBus::PublishSigned(ChannelFamily, const std::string&, memory_portion_v2_t);
template bool TeamBus::PublishSigned(ChannelFamily, const std::string&, memory_request_t);
template bool TeamBus::PublishCounted(ChannelFamily, const std::string&, const place_event_t&);

void TeamBus::PublishFailed(const std::string& channel) {
  // A packet filter that drops datagrams makes every such send fail (EPERM): log the first
  // and then one in a hundred, so a lossy network cannot fill the journal.
  const int64_t n = ++counters_.publish_failures;
  if (ShouldLog(n)) spdlog::warn("LCM: cannot publish on {} ({} failed sends so far)", channel, n);
}

void TeamBus::CountReceived(ChannelFamily family, size_t bytes) {
  ChannelTraffic& t = traffic_[static_cast<size_t>(family)];
  ++t.received;
  t.received_bytes += static_cast<int64_t>(bytes);
}

void TeamBus::PublishStats(const std::string& channel, stats_t s) {
  // The stats message counts itself: it is sent right after.
  ChannelTraffic& own = traffic_[static_cast<size_t>(ChannelFamily::kStats)];
  ++own.sent;
  for (int f = 0; f < kChannelFamilies; ++f) {
    const ChannelTraffic& t = traffic_[static_cast<size_t>(f)];
    s.channel.push_back(ChannelFamilyName(static_cast<ChannelFamily>(f)));
    s.sent.push_back(t.sent);
    s.sent_bytes.push_back(t.sent_bytes);
    s.received.push_back(t.received);
    s.received_bytes.push_back(t.received_bytes);
  }
  s.num_channels = static_cast<int16_t>(kChannelFamilies);
  const std::vector<uint8_t> bytes = LcmBus::Encode(s);
  if (bus_.PublishRaw(channel, bytes)) {
    own.sent_bytes += static_cast<int64_t>(bytes.size());
  } else {
    --own.sent;
    PublishFailed(channel);
  }
}

}  // namespace tsc
