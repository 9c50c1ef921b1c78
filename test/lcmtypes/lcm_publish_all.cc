// lcm_publish_all — publishes one message of every tscd LCM type on its channel, with fixed,
// recognisable values (test/lcmtypes/expected_fields.txt lists them as the Java dumper prints
// them). Used by java_decode_test.sh and tools/lcm-spy-screenshot, always inside a private
// network namespace.
//
//   lcm_publish_all --url URL [--robot N] [--wait-for-file PATH] [--repeat-seconds S]
//                   [--garbage]
//
// --wait-for-file: first publish a ping on TSCD_TEST_PING every 50 ms until PATH is not empty
//   (lcm-logger has started and flushed), at most 10 s.
// --repeat-seconds: publish the set every 200 ms for S seconds (for lcm-spy) instead of once.
// --garbage: publish messages that must NOT decode (junk bytes on TSC_EVENT_<robot>, an
//   announce_t on TSC_MEMORY_<robot>) instead of the valid set.
// Exit status: 0 ok, 1 publish or wait failure, 2 usage error.
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "jaguar/motor_command_t.hpp"
#include "jaguar/motor_state_t.hpp"
#include "tsc/announce_t.hpp"
#include "tsc/learned_place_t.hpp"
#include "tsc/learned_place_v2_t.hpp"
#include "tsc/map_edge_t.hpp"
#include "tsc/memory_node_t.hpp"
#include "tsc/memory_portion_t.hpp"
#include "tsc/memory_portion_v2_t.hpp"
#include "tsc/memory_request_t.hpp"
#include "tsc/place_event_t.hpp"
#include "tsc/place_ref_t.hpp"
#include "tsc/stats_t.hpp"

namespace {

struct Options {
  std::string url;
  int32_t robot = 7;
  std::string wait_for_file;
  double repeat_seconds = 0.0;
  bool garbage = false;
};

constexpr int64_t kUtime = 1700000000000000;  // µs, 2023-11-14T22:13:20Z

tsc::place_ref_t Ref(int32_t robot, int32_t local) {
  tsc::place_ref_t ref{};
  ref.robot = robot;
  ref.local = local;
  return ref;
}

std::vector<uint8_t> Hmac() { return {0xde, 0xad, 0xbe, 0xef}; }

tsc::announce_t Announce(int32_t robot) {
  tsc::announce_t m{};
  m.utime = kUtime + 1;
  m.protocol = tsc::announce_t::PROTOCOL;
  m.robot = robot;
  m.boot_id = 123456789012345;
  m.sequence = 42;
  m.memory_version = 5;
  m.memory_digest = -81985529216486896;  // 0xfedcba9876543210
  m.portions = 1;
  m.structure_portions = 1;
  m.view_basis = -6762863007442862697;  // 0xa126e3a0e17dfd97, the builtin basis' id
  m.places = 2;
  m.edges = 1;
  m.detected_places = 3;
  m.frames = 1000;
  m.frames_dropped = 2;
  m.messages_rejected = 1;
  m.queue_fill = 0.25F;
  m.status = "running";
  m.hmac = Hmac();
  m.hmac_size = static_cast<int16_t>(m.hmac.size());
  return m;
}

tsc::place_event_t Event(int32_t robot) {
  tsc::place_event_t m{};
  m.utime = kUtime + 2;
  m.robot = robot;
  m.frame = 314;
  m.event = "mapped";
  m.detected_place = 3;
  m.has_place = 1;
  m.place = Ref(robot, 2);
  m.has_from = 1;
  m.from = Ref(robot, 1);
  m.cost = 0.125;
  m.partial = 0;
  m.hybrid = 1;
  m.members = 17;
  m.transition_first = 300;
  m.transition_last = 310;
  return m;
}

tsc::learned_place_v2_t Place(int32_t robot, int32_t local, float base) {
  tsc::learned_place_v2_t p{};
  p.id = Ref(robot, local);
  p.member_count = 10 + local;
  p.dims = 3;
  p.mean = {base, base + 0.5F, base + 1.0F};
  // Views base base base and base+0.25 base+0.5 base+0.75 as values times 2^-14 (the largest
  // |coordinate| of both places lies in [1, 2), so the largest value in [2^14, 2^15)).
  p.view_shift = 14;
  const auto value = [](float v) { return static_cast<int16_t>(std::lround(v * 16384.0F)); };
  p.samples = {{value(base), value(base), value(base)},
               {value(base + 0.25F), value(base + 0.5F), value(base + 0.75F)}};
  p.num_samples = static_cast<int32_t>(p.samples.size());
  p.view_dims = 3;
  if (local == 2) {
    p.sources = {Ref(9, 4)};
  }
  p.num_sources = static_cast<int32_t>(p.sources.size());
  return p;
}

tsc::place_entry_t Entry(int32_t robot, int32_t local) {
  tsc::place_entry_t e{};
  e.id = Ref(robot, local);
  e.body_digest = -1234567890123 * local;
  e.slink_pi = 1;
  e.slink_lambda = local == 1 ? 0.75 : -1.0;
  return e;
}

tsc::memory_node_t Node(int32_t index, int32_t parent, int32_t place, double height,
                        std::vector<int32_t> children) {
  tsc::memory_node_t n{};
  n.index = index;
  n.parent = parent;
  n.place = place;
  n.height = height;
  n.children = std::move(children);
  n.num_children = static_cast<int32_t>(n.children.size());
  return n;
}

tsc::memory_portion_v2_t Portion(int32_t robot) {
  tsc::memory_portion_v2_t m{};
  m.utime = kUtime + 3;
  m.robot = robot;
  m.boot_id = 123456789012345;
  m.version = 5;
  m.index = 0;
  m.count = 3;
  m.structure_portions = 1;
  m.digest = -81985529216486896;
  m.total_places = 2;
  m.first_place = 0;
  m.next_local = 3;
  m.view_basis = -6762863007442862697;
  // Every array filled, to decode each field: tscd sends entries and bodies apart.
  m.entries = {Entry(robot, 1), Entry(robot, 2)};
  m.num_entries = static_cast<int32_t>(m.entries.size());
  m.places = {Place(robot, 1, 0.5F), Place(robot, 2, -1.5F)};
  m.num_places = static_cast<int32_t>(m.places.size());
  m.nodes = {Node(0, 2, 0, 0.0, {}), Node(1, 2, 1, 0.0, {}), Node(2, -1, -1, 0.75, {0, 1})};
  m.num_nodes = static_cast<int32_t>(m.nodes.size());
  tsc::map_edge_t edge{};
  edge.a = Ref(robot, 1);
  edge.b = Ref(robot, 2);
  edge.traversals = 4;
  m.edges = {edge};
  m.num_edges = static_cast<int32_t>(m.edges.size());
  m.hmac = Hmac();
  m.hmac_size = static_cast<int16_t>(m.hmac.size());
  return m;
}

// A body portion of protocols 2-3 (float32 views), as logs of those tscd versions hold it: the
// log dumper still decodes it, by its fingerprint.
tsc::memory_portion_t PortionOfProtocol3(int32_t robot) {
  tsc::memory_portion_t m{};
  m.utime = kUtime + 8;
  m.robot = robot;
  m.count = 2;
  m.structure_portions = 1;
  m.index = 1;
  m.total_places = 1;
  tsc::learned_place_t p{};
  p.id = Ref(robot, 1);
  p.member_count = 3;
  p.dims = 2;
  p.mean = {0.25F, 0.5F};
  p.view_dims = 2;
  p.samples = {{0.25F, 0.75F}};
  p.num_samples = static_cast<int32_t>(p.samples.size());
  m.places = {p};
  m.num_places = 1;
  return m;
}

tsc::memory_request_t Request(int32_t robot) {
  tsc::memory_request_t m{};
  m.utime = kUtime + 4;
  m.requester = 8;
  m.robot = robot;
  m.version = 5;
  m.missing = {0, 2, 5};
  m.num_missing = static_cast<int32_t>(m.missing.size());
  m.hmac = Hmac();
  m.hmac_size = static_cast<int16_t>(m.hmac.size());
  return m;
}

jaguar::motor_command_t Command() {
  jaguar::motor_command_t m{};
  m.utime = kUtime + 5;
  m.sequence = 99;
  m.linear_mps = 0.5;
  m.angular_radps = -0.25;
  m.flipper_front = 1.0;
  m.flipper_rear = -1.0;
  m.estop = 0;
  return m;
}

jaguar::motor_state_t State() {
  jaguar::motor_state_t m{};
  m.utime = kUtime + 6;
  m.x = 1.5;
  m.y = -2.25;
  m.heading = 3.125;
  m.linear_mps = 0.5;
  m.angular_radps = -0.25;
  m.left_ticks = 10000;
  m.right_ticks = -10001;
  m.battery_volts = 24.5;
  m.temperatures_c = {31.5, 33.0};
  m.num_temperatures = static_cast<int16_t>(m.temperatures_c.size());
  m.link_ok = 1;
  m.stopped = 0;
  m.fault = "watchdog: \"no command\" for 0.5 s";
  return m;
}

tsc::stats_t Stats(int32_t robot) {
  tsc::stats_t m{};
  m.utime = kUtime + 7;
  m.robot = robot;
  m.boot_id = 123456789012345;
  m.uptime_s = 61.5;
  m.frames = 1000;
  m.places = 2;
  m.merges_completed = 9;
  m.buffered_portions = 3;
  m.channel = {"TSC_ANNOUNCE", "TSC_MEMORY"};
  m.sent = {60, 12};
  m.sent_bytes = {9000, 120000};
  m.received = {240, 40};
  m.received_bytes = {36000, 400000};
  m.num_channels = static_cast<int16_t>(m.channel.size());
  return m;
}

/// Publishes `message` on `channel`; false (with a message) when LCM refuses.
template <typename Message>
bool Publish(lcm::LCM& bus, const std::string& channel, const Message& message) {
  if (bus.publish(channel, &message) != 0) {
    std::fprintf(stderr, "lcm_publish_all: publish on %s failed\n", channel.c_str());
    return false;
  }
  return true;
}

bool PublishRaw(lcm::LCM& bus, const std::string& channel, const std::vector<uint8_t>& bytes) {
  if (bus.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size())) != 0) {
    std::fprintf(stderr, "lcm_publish_all: publish on %s failed\n", channel.c_str());
    return false;
  }
  return true;
}

bool PublishAll(lcm::LCM& bus, int32_t robot) {
  const std::string id = std::to_string(robot);
  return Publish(bus, "TSC_ANNOUNCE", Announce(robot)) &&
         Publish(bus, "TSC_EVENT_" + id, Event(robot)) &&
         Publish(bus, "TSC_MEMORY_" + id, Portion(robot)) &&
         Publish(bus, "TSC_MEMORY_" + std::to_string(robot + 1), PortionOfProtocol3(robot + 1)) &&
         Publish(bus, "TSC_REQUEST_" + id, Request(robot)) &&
         Publish(bus, "TSC_STATS_" + id, Stats(robot)) &&
         Publish(bus, "JAGUAR_CMD_" + id, Command()) && Publish(bus, "JAGUAR_STATE_" + id, State());
}

bool PublishGarbage(lcm::LCM& bus, int32_t robot) {
  const std::string id = std::to_string(robot);
  return PublishRaw(bus, "TSC_EVENT_" + id, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}) &&
         Publish(bus, "TSC_MEMORY_" + id, Announce(robot));
}

bool WaitForFile(lcm::LCM& bus, const std::string& path) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  const std::vector<uint8_t> ping = {'p', 'i', 'n', 'g'};
  while (std::chrono::steady_clock::now() < deadline) {
    if (!PublishRaw(bus, "TSCD_TEST_PING", ping)) return false;
    std::error_code error;
    const auto size = std::filesystem::file_size(path, error);
    if (!error && size > 0) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::fprintf(stderr, "lcm_publish_all: %s still empty after 10 s (is lcm-logger running?)\n",
               path.c_str());
  return false;
}

int Usage() {
  std::fprintf(stderr,
               "usage: lcm_publish_all --url URL [--robot N] [--wait-for-file PATH] "
               "[--repeat-seconds S] [--garbage]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--url" && has_value) {
      options.url = argv[++i];
    } else if (arg == "--robot" && has_value) {
      options.robot = std::atoi(argv[++i]);
    } else if (arg == "--wait-for-file" && has_value) {
      options.wait_for_file = argv[++i];
    } else if (arg == "--repeat-seconds" && has_value) {
      options.repeat_seconds = std::atof(argv[++i]);
    } else if (arg == "--garbage") {
      options.garbage = true;
    } else {
      return Usage();
    }
  }
  // Never default to the shared multicast group: the caller names the URL it made safe.
  if (options.url.empty() || options.robot <= 0 || !std::isfinite(options.repeat_seconds) ||
      options.repeat_seconds < 0.0) {
    return Usage();
  }

  lcm::LCM bus(options.url);
  if (!bus.good()) {
    std::fprintf(stderr, "lcm_publish_all: cannot open LCM at %s\n", options.url.c_str());
    return 1;
  }
  if (!options.wait_for_file.empty() && !WaitForFile(bus, options.wait_for_file)) return 1;

  const auto publish = [&] {
    return options.garbage ? PublishGarbage(bus, options.robot) : PublishAll(bus, options.robot);
  };
  if (options.repeat_seconds <= 0.0) return publish() ? 0 : 1;
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(options.repeat_seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (!publish()) return 1;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return 0;
}
