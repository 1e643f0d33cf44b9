#include "daemon/service_notifier.h"

#include <cstdint>

#include <systemd/sd-daemon.h>
#include <time.h>
#include <unistd.h>

namespace occmap {

std::string hostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "?";
  return name;
}

ServiceNotifier::ServiceNotifier() {
  std::uint64_t usec = 0;
  // 0 = do not unset the variables: they are inherited by nothing we start, and tests read them.
  if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0) {
    watchdog_ = std::chrono::microseconds(usec);
  }
}

void ServiceNotifier::send(const std::string& state) { sd_notify(0, state.c_str()); }

void ServiceNotifier::ready() { send("READY=1"); }

void ServiceNotifier::reloading() {
  // MONOTONIC_USEC lets newer systemd (Type=notify-reload) match the reload to its request.
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  send("RELOADING=1\nMONOTONIC_USEC=" +
       std::to_string(now.tv_sec * 1'000'000LL + now.tv_nsec / 1000));
}

void ServiceNotifier::stopping() { send("STOPPING=1"); }

void ServiceNotifier::status(const std::string& line) { send("STATUS=" + line); }

void ServiceNotifier::watchdog() { send("WATCHDOG=1"); }

}  // namespace occmap
