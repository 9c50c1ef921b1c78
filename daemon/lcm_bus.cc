#include "daemon/lcm_bus.h"

#include <lcm/lcm.h>

#include <stdexcept>

namespace tsc {

struct LcmBus::Subscription {
  LcmBus* bus = nullptr;
  Handler handler;
  lcm_subscription_t* handle = nullptr;
};

namespace {
lcm_t* Raw(void* p) { return static_cast<lcm_t*>(p); }
}  // namespace

LcmBus::LcmBus(const std::string& url) : url_(url) {
  lcm_ = lcm_create(url.c_str());
  if (lcm_ == nullptr) {
    throw std::runtime_error("LCM cannot start on '" + url +
                             "' (is there a multicast route? e.g. `ip route add 224.0.0.0/4 "
                             "dev lo` for host-local use)");
  }
}

LcmBus::~LcmBus() {
  for (auto& s : subscriptions_) lcm_unsubscribe(Raw(lcm_), s->handle);
  lcm_destroy(Raw(lcm_));
}

int LcmBus::fd() const { return lcm_get_fileno(Raw(lcm_)); }

bool LcmBus::HandleReady() {
  // lcm_handle_timeout(…, 0) returns 0 when nothing is waiting, >0 after one message.
  for (int i = 0; i < 256; ++i) {  // bounded, so a flood cannot starve the loop's timers
    const int r = lcm_handle_timeout(Raw(lcm_), 0);
    if (r < 0) return false;
    if (r == 0) break;
  }
  return true;
}

bool LcmBus::HandleTimeout(int timeout_ms) {
  return lcm_handle_timeout(Raw(lcm_), timeout_ms) >= 0;
}

void LcmBus::Dispatch(const void* rbuf, const char* channel, void* user) {
  auto* s = static_cast<Subscription*>(user);
  const auto* buf = static_cast<const lcm_recv_buf_t*>(rbuf);
  try {
    s->handler(channel, static_cast<const uint8_t*>(buf->data), buf->data_size);
  } catch (...) {
    // Nothing may unwind through LCM's C code.
    ++s->bus->handler_failures_;
  }
}

void LcmBus::Subscribe(const std::string& channel_regex, Handler handler) {
  auto s = std::make_unique<Subscription>();
  s->bus = this;
  s->handler = std::move(handler);
  s->handle = lcm_subscribe(
      Raw(lcm_), channel_regex.c_str(),
      [](const lcm_recv_buf_t* rbuf, const char* channel, void* user) {
        Dispatch(rbuf, channel, user);
      },
      s.get());
  if (s->handle == nullptr)
    throw std::runtime_error("LCM refused to subscribe to " + channel_regex);
  subscriptions_.push_back(std::move(s));
}

bool LcmBus::PublishRaw(const std::string& channel, const std::vector<uint8_t>& bytes) {
  return lcm_publish(Raw(lcm_), channel.c_str(), bytes.data(),
                     static_cast<unsigned int>(bytes.size())) == 0;
}

}  // namespace tsc
