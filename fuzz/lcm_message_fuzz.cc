// Fuzz target: one LCM message type tscd accepts from the network (TSCD_FUZZ_MESSAGE, set by
// fuzz/CMakeLists.txt), decoded exactly as the daemon does (LcmBus::Decode). A message that
// decodes must encode again and decode to the same encoding.

#include <cstdlib>
#include <vector>

#include "daemon/lcm_bus.h"
#include "fuzz/fuzz_target.h"
#include "jaguar/motor_command_t.hpp"
#include "tsc/announce_t.hpp"
#include "tsc/memory_portion_v2_t.hpp"
#include "tsc/memory_request_t.hpp"
#include "tsc/place_event_t.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using Message = TSCD_FUZZ_MESSAGE;
  const auto msg = tsc::LcmBus::Decode<Message>(data, size);
  if (!msg) return 0;
  const std::vector<uint8_t> once = tsc::LcmBus::Encode(*msg);
  const auto again = tsc::LcmBus::Decode<Message>(once.data(), once.size());
  if (!again || tsc::LcmBus::Encode(*again) != once) std::abort();  // round trip broken
  return 0;
}
