#include "daemon/merge_daemon.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include "base/clock.h"
#include "base/log.h"
#include "base/time_histogram.h"
#include "config/exit_codes.h"
#include "daemon/merge_node.h"
#include "daemon/service_notifier.h"
#include "transport/lcm_bus.h"
#include "transport/merge_status_publisher.h"
#include "transport/status_requests.h"

namespace occmap {
namespace {

constexpr std::int64_t kNanosecondsPerMs = 1'000'000;
constexpr std::int64_t kMergeStatusPeriodNs = 1000 * kNanosecondsPerMs;
// The longest the loop reads messages before it looks at signals, requests and the watchdog.
constexpr std::int64_t kDrainNs = 100 * kNanosecondsPerMs;
// Answers to status requests, at most (transport/status_requests.h), as occmapd's pipeline.
constexpr double kMaxMergeStatusAnswersPerS = 20.0;
// A clock warning for one input at most this often, and repeated this often while it lasts.
constexpr std::int64_t kClockWarningGapNs = 10'000 * kNanosecondsPerMs;
constexpr std::int64_t kClockWarningRepeatNs = 60'000 * kNanosecondsPerMs;

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

// The log's word on one input's clock: a warning when it goes past 10 ms off the others' (at most
// one every 10 s, so that an offset hovering at 10 ms does not flood the journal), again every
// minute while it stays off, and a notice when it is back within.
struct ClockWatch {
  bool told = false;  // warned of since the clock was last within
  std::int64_t last_warning_ns = INT64_MIN / 2;

  void look(const MergeNode::InputStatus& input, std::int64_t now_ns) {
    if (!input.clock_offset_s) return;  // not heard from yet
    const double offset_s = *input.clock_offset_s;
    if (std::abs(offset_s) > MergeInputs::kOffsetWarningS) {
      if (now_ns - last_warning_ns >= (told ? kClockWarningRepeatNs : kClockWarningGapNs)) {
        logLine(LogLevel::kWarning,
                "input %s: its clock is %.1f ms off the others': its maps are judged that much "
                "too old or too new (docs/merge.md: chrony or PTP)",
                input.name.c_str(), offset_s * 1e3);
        last_warning_ns = now_ns;
        told = true;
      }
    } else if (told) {
      logLine(LogLevel::kNotice, "input %s: its clock agrees with the others' again (%.1f ms)",
              input.name.c_str(), offset_s * 1e3);
      told = false;
    }
  }
};

// The node's figures for its status (merge_status_t), filled in place.
void fillMergeReport(const MergeNode& node, const std::vector<MergeNode::InputStatus>& inputs,
                     const TimeHistogram& latency, const TimeHistogram& merge_times,
                     std::int64_t start_ns, std::int64_t now_ns, MergeReport& report) {
  report.uptime_s = static_cast<double>(now_ns - start_ns) / 1e9;
  report.maps_published = node.published();
  report.publish_errors = node.publishErrors();
  const bool merged = latency.count() > 0;
  report.latency_p50_ms = merged ? latency.percentileMs(0.50) : 0.0;
  report.latency_p99_ms = merged ? latency.percentileMs(0.99) : 0.0;
  report.latency_last_ms = merged ? node.lastLatencyS() * 1e3 : 0.0;
  const bool taken = merge_times.count() > 0;
  report.merge_p50_ms = taken ? merge_times.percentileMs(0.50) : 0.0;
  report.merge_p99_ms = taken ? merge_times.percentileMs(0.99) : 0.0;
  report.inputs.resize(inputs.size());
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    const MergeNode::InputStatus& from = inputs[k];
    MergeInputReport& to = report.inputs[k];
    to.name = from.name;
    to.channel = from.channel;
    to.state = from.fresh       ? MergeInputState::kFresh
               : from.maps == 0 ? MergeInputState::kNeverHeard
                                : MergeInputState::kDown;
    to.maps = from.maps;
    to.lost = from.lost;
    to.tiles_lost = from.tiles_lost;
    to.refused = from.refused;
    to.age_s = from.age_s;
    to.clock_offset_s = from.clock_offset_s;
    to.last_error = from.last_error;
  }
}

}  // namespace

int runMergeDaemon(const Config& config, int signal_fd) {
  const std::int64_t start_ns = monotonicNanoseconds();
  const MergeSettings& merge = *config.merge;
  const TransportSettings& transport = config.transport;
  std::vector<MergeInputSpec> inputs;
  for (const MergeInputConfig& input : merge.inputs) inputs.push_back({input.name, input.channel});
  std::unique_ptr<Bus> lcm = LcmBus::open(transport.lcm_url);
  Bus& bus = *lcm;
  TimeHistogram latency;  // from the newest input's arrival to the merged map's publish
  MergeNode node(bus, config.map, inputs, merge.max_age_ms / 1000.0, transport.map_channel,
                 parseMapEncoding(transport.encoding).value_or(MapEncoding::kZstd), config.zones,
                 hostName(), transport.tiles ? MapMessages::kTiles : MapMessages::kWhole);
  // The same status requests a camera PC's occmapd answers (`occmap status`, and `--all`), on the
  // same bus: one request reaches every daemon.
  StatusRequests requests(kMaxMergeStatusAnswersPerS, start_ns);
  requests.subscribe(bus, transport.status_channel);
  MergeStatusPublisher status(transport.status_channel, inputs.size(), start_ns);
  MergeReport report;
  report.hostname = hostName();
  report.config_file = config.file.string();
  report.map_channel = transport.map_channel;
  report.state = DaemonState::kRunning;
  report.max_age_s = merge.max_age_ms / 1000.0;
  report.clock_warning_s = MergeInputs::kOffsetWarningS;
  std::int64_t next_status_ns = start_ns;
  const auto publishStatus = [&](std::int64_t request_id, std::int64_t now_ns) {
    fillMergeReport(node, node.inputs(), latency, node.mergeTimes(), start_ns, now_ns, report);
    status.publish(bus, report, request_id, now_ns);
  };

  ServiceNotifier notifier;
  notifier.ready();
  logLine(LogLevel::kNotice, "merge node ready: %zu inputs into %s (map %dx%d), status on %s",
          inputs.size(), transport.map_channel.c_str(), config.map.width, config.map.height,
          status.channel().c_str());

  std::vector<ClockWatch> clocks(inputs.size());
  auto last_notify = std::chrono::steady_clock::now() - std::chrono::seconds(10);
  for (;;) {
    pollfd fds[2] = {{signal_fd, POLLIN, 0}, {bus.fileno(), POLLIN, 0}};
    const std::int64_t until_status_ns = next_status_ns - monotonicNanoseconds();
    const int wait_ms = static_cast<int>(std::clamp<std::int64_t>(
        (until_status_ns + kNanosecondsPerMs - 1) / kNanosecondsPerMs, 0, 250));
    ::poll(fds, bus.fileno() >= 0 ? 2 : 1, wait_ms);
    if (fds[0].revents & POLLIN) {
      signalfd_siginfo info{};
      if (::read(signal_fd, &info, sizeof info) == sizeof info) {
        if (info.ssi_signo == SIGHUP) {
          logLine(LogLevel::kWarning,
                  "SIGHUP: a merge node does not reload; restart it to apply a new config");
        } else {
          notifier.stopping();
          // A last status that says the node is stopping, as occmapd's pipeline sends.
          report.state = DaemonState::kStopping;
          publishStatus(-1, monotonicNanoseconds());
          logLine(LogLevel::kNotice, "stopping: %s", summary(node).c_str());
          return kExitOk;
        }
      }
    }
    // What waits, without blocking: the poll above waited. A message makes at most one merged
    // map, whose latency is then the node's last. For no longer than kDrainNs at a time: when
    // maps come faster than they are merged (an overloaded machine; TSan on a busy one), a
    // thousand messages took 30 s and more, through which a SIGTERM waited unread and the
    // watchdog went unfed.
    const std::int64_t drain_until_ns = monotonicNanoseconds() + kDrainNs;
    for (int handled = 0; handled < 1000 && monotonicNanoseconds() < drain_until_ns; ++handled) {
      const std::uint64_t published = node.published();
      if (node.spinOnce(0) <= 0) break;
      if (node.published() != published) {
        latency.record(static_cast<std::int64_t>(std::max(0.0, node.lastLatencyS()) * 1e9));
      }
    }
    notifier.watchdog();
    const std::int64_t now_ns = monotonicNanoseconds();
    requests.answer(now_ns, [&](std::int64_t request_id) { publishStatus(request_id, now_ns); });
    if (now_ns >= next_status_ns) {
      publishStatus(-1, now_ns);
      next_status_ns = now_ns + kMergeStatusPeriodNs;
    }
    const std::vector<MergeNode::InputStatus> inputs_now = node.inputs();
    for (std::size_t k = 0; k < inputs_now.size() && k < clocks.size(); ++k) {
      clocks[k].look(inputs_now[k], now_ns);
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - last_notify >= std::chrono::seconds(2)) {
      notifier.status(summary(node));
      last_notify = now;
    }
  }
}

}  // namespace occmap
