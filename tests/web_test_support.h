#pragma once
// What the tests of `occmap web` share (web_server_test, web_browser_test): occmapd on the
// simulated room and `occmap web` as processes in the test's private network, and the HTTP and
// WebSocket client of web_client.h.

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "child_process.h"
#include "notify_listener.h"
#include "sim_room_config.h"
#include "temporary_folder.h"
#include "timing.h"
#include "web_client.h"

namespace occmap::testing {

using namespace std::chrono_literals;

inline const std::string kOccmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
inline const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";
inline const std::string kLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

// The simulated room (tests/sim_room_config.h: four cameras, 256 x 256 cells of 4 cm) on UDP
// multicast, with a zone; `extra_cameras` are more lines of the cameras list.
inline std::string webRoomConfig(const std::string& extra_cameras = "") {
  std::string config = simRoomConfig(kLcmUrl);
  config.insert(config.find("cameras:"),
                "zones: [{name: walkway, polygon_m: [[1, 1], [3, 1], [3, 3], [1, 3]]}]\n");
  return config + extra_cameras;
}

// occmapd started in this process's network (as network_test's RunningDaemon).
struct WebTestDaemon {
  std::optional<NotifyListener> systemd;
  ChildProcess process;
  // `name` names its files in `folder`: the config (unless `config_name` does), its output.
  WebTestDaemon(const TemporaryFolder& folder, const std::string& config, const std::string& name,
                const std::string& config_name = "")
      : systemd(std::in_place, folder / (name + ".notify")),
        process(
            {kOccmapd, "--config",
             folder.write((config_name.empty() ? name : config_name) + ".yaml", config).string()},
            folder / name, {{"NOTIFY_SOCKET", (folder / (name + ".notify")).string()}}) {}
  // Waits for READY=1 (every camera streaming), then stops listening (a notify socket nobody
  // reads would block the daemon's sd_notify).
  bool ready() {
    const bool ready = systemd->collect(eventually(30s), "READY=1");
    systemd.reset();
    return ready;
  }
  int stop() {
    process.signal(SIGTERM);
    return process.waitExit(eventually(5s)).value_or(-100);
  }
};

// `occmap web` started in this process's network, on 127.0.0.1 and the port given (0: any).
struct WebProcess {
  ChildProcess process;
  std::uint16_t port = 0;
  WebProcess(const TemporaryFolder& folder, const std::string& name, std::uint16_t listen_port = 0)
      : process({kOccmap, "web", "--lcm-url", kLcmUrl, "--listen",
                 "127.0.0.1:" + std::to_string(listen_port)},
                folder / name) {}
  // Waits for "serving http://127.0.0.1:PORT/" and takes the port.
  bool serving() {
    const std::string said = "occmap web: serving http://127.0.0.1:";
    if (!process.waitForOutput(said, eventually(10s))) return false;
    const std::string out = process.out();
    port = static_cast<std::uint16_t>(std::stoi(out.substr(out.find(said) + said.size())));
    return port != 0;
  }
  int stop() {
    process.signal(SIGTERM);
    return process.waitExit(eventually(5s)).value_or(-100);
  }
};

// A process's resident memory, KiB (0 when it cannot be read).
inline long residentKiB(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.starts_with("VmRSS:")) return std::atol(line.c_str() + 6);
  }
  return 0;
}

}  // namespace occmap::testing
