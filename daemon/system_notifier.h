#pragma once
// systemd's service notification protocol (Type=notify): READY, STATUS, WATCHDOG, STOPPING.
// Does nothing when the daemon does not run under systemd (no NOTIFY_SOCKET).

#include <chrono>
#include <optional>
#include <string>

namespace tsc {

class SystemNotifier {
 public:
  /// Reads NOTIFY_SOCKET and WATCHDOG_USEC from the environment.
  SystemNotifier();
  bool enabled() const { return enabled_; }
  /// The interval at which Watchdog() must be called (half of WatchdogSec), if any.
  std::optional<std::chrono::microseconds> watchdog_interval() const { return watchdog_; }

  void Ready(const std::string& status) const;
  void Status(const std::string& status) const;
  void Watchdog() const;
  void Stopping() const;
  void Reloading() const;

 private:
  bool enabled_ = false;
  std::optional<std::chrono::microseconds> watchdog_;
};

}  // namespace tsc
