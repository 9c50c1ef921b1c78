#include "daemon/system_notifier.h"

#include <systemd/sd-daemon.h>

#include <cstdlib>

namespace tsc {

SystemNotifier::SystemNotifier() {
  enabled_ = std::getenv("NOTIFY_SOCKET") != nullptr;
  uint64_t usec = 0;
  if (enabled_ && sd_watchdog_enabled(/*unset_environment=*/0, &usec) > 0 && usec > 0) {
    watchdog_ = std::chrono::microseconds(usec / 2);
  }
}

void SystemNotifier::Ready(const std::string& status) const {
  if (enabled_) sd_notifyf(0, "READY=1\nSTATUS=%s", status.c_str());
}

void SystemNotifier::Status(const std::string& status) const {
  if (enabled_) sd_notifyf(0, "STATUS=%s", status.c_str());
}

void SystemNotifier::Watchdog() const {
  if (enabled_) sd_notify(0, "WATCHDOG=1");
}

void SystemNotifier::Stopping() const {
  if (enabled_) sd_notify(0, "STOPPING=1");
}

void SystemNotifier::Reloading() const {
  if (enabled_) sd_notify(0, "RELOADING=1");
}

}  // namespace tsc
