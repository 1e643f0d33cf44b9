#pragma once

#include <chrono>
#include <optional>
#include <string>

namespace occmap {

// This machine's name as the daemon gives it in its messages (status_t, zones_t), "?" if unknown.
std::string hostName();

// What occmapd tells systemd (sd_notify): READY=1, RELOADING=1, STOPPING=1, STATUS=..., WATCHDOG=1.
// Outside a Type=notify service (no NOTIFY_SOCKET) every call does nothing.
class ServiceNotifier {
 public:
  ServiceNotifier();

  // The unit's WatchdogSec= as systemd passed it (WATCHDOG_USEC), if the watchdog is on.
  std::optional<std::chrono::microseconds> watchdogInterval() const { return watchdog_; }

  void ready();
  void reloading();
  void stopping();
  void status(const std::string& line);
  void watchdog();

 private:
  void send(const std::string& state);

  std::optional<std::chrono::microseconds> watchdog_;
};

}  // namespace occmap
