#include "daemon/merge_daemon.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include "base/log.h"
#include "config/exit_codes.h"
#include "daemon/merge_node.h"
#include "daemon/service_notifier.h"
#include "transport/lcm_bus.h"

namespace occmap {
namespace {

std::string summary(const MergeNode& node) {
  std::string line = std::to_string(node.published()) + " merged maps;";
  for (const MergeNode::InputStatus& input : node.inputs()) {
    line += " " + input.name + (input.fresh ? " fresh" : input.maps == 0 ? " not heard" : " down");
    if (input.clock_offset_s) {
      char offset[48];
      std::snprintf(offset, sizeof offset, " (clock %+.1f ms)", *input.clock_offset_s * 1e3);
      line += offset;
    }
    line += ",";
  }
  line.back() = '.';
  return line;
}

}  // namespace

int runMergeDaemon(const Config& config, int signal_fd) {
  const MergeSettings& merge = *config.merge;
  std::vector<MergeInputSpec> inputs;
  for (const MergeInputConfig& input : merge.inputs) inputs.push_back({input.name, input.channel});
  std::unique_ptr<Bus> bus = LcmBus::open(config.transport.lcm_url);
  MergeNode node(*bus, config.map, inputs, merge.max_age_ms / 1000.0, config.transport.map_channel,
                 parseMapEncoding(config.transport.encoding).value_or(MapEncoding::kZstd),
                 config.zones, hostName());
  ServiceNotifier notifier;
  notifier.ready();
  logLine(LogLevel::kNotice, "merge node ready: %zu inputs into %s (map %dx%d)", inputs.size(),
          config.transport.map_channel.c_str(), config.map.width, config.map.height);

  std::vector<bool> warned(inputs.size(), false);
  auto last_status = std::chrono::steady_clock::now() - std::chrono::seconds(10);
  for (;;) {
    pollfd fds[2] = {{signal_fd, POLLIN, 0}, {bus->fileno(), POLLIN, 0}};
    ::poll(fds, bus->fileno() >= 0 ? 2 : 1, 250);
    if (fds[0].revents & POLLIN) {
      signalfd_siginfo info{};
      if (::read(signal_fd, &info, sizeof info) == sizeof info) {
        if (info.ssi_signo == SIGHUP) {
          logLine(LogLevel::kWarning,
                  "SIGHUP: a merge node does not reload; restart it to apply a new config");
        } else {
          notifier.stopping();
          logLine(LogLevel::kNotice, "stopping: %s", summary(node).c_str());
          return kExitOk;
        }
      }
    }
    // What waits, without blocking: the poll above waited.
    for (int handled = 0; handled < 1000 && node.spinOnce(0) > 0; ++handled) {
    }
    notifier.watchdog();
    const std::vector<MergeNode::InputStatus> status = node.inputs();
    for (std::size_t k = 0; k < status.size(); ++k) {
      const bool off = status[k].clock_offset_s &&
                       std::abs(*status[k].clock_offset_s) > MergeInputs::kOffsetWarningS;
      if (off != warned[k]) {
        warned[k] = off;
        logLine(off ? LogLevel::kWarning : LogLevel::kNotice,
                off ? "input %s: its clock is %.1f ms off the others': its maps are judged that "
                      "much too old or too new (docs/merge.md: chrony or PTP)"
                    : "input %s: its clock agrees with the others' again (%.1f ms)",
                status[k].name.c_str(), *status[k].clock_offset_s * 1e3);
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - last_status >= std::chrono::seconds(2)) {
      notifier.status(summary(node));
      last_status = now;
    }
  }
}

}  // namespace occmap
