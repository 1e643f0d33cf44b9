// occmapd as a merge node on a LAN made by the test (tests/lan.h: machines in network namespaces
// of their own on a bridge, UDP multicast with ttl=1 through it; nothing leaves the test's own
// namespace): two camera PCs' daemons, each with two of the simulated room's cameras on a channel
// of its own, a merge node publishing one map, and lcm-logger on a fourth machine. The logger
// records the merged maps at the inputs' rate, none lost; one PC killed is down in the merged maps
// once its newest map is max_age_ms behind the other's (its cells unseen), and merged again once it
// is back.
#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "child_process.h"
#include "lan.h"
#include "network_namespace.h"
#include "notify_listener.h"
#include "sim_room_config.h"
#include "timing.h"
#include "transport/lcm_bus.h"
#include "transport/map_codec.h"

namespace occmap {
namespace {

using namespace std::chrono_literals;
using testing::ChildProcess;
using testing::NotifyListener;
using testing::TemporaryFolder;

const std::string kOccmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
// ttl=1: one hop, through the bridge to the other machines (ttl=0 would never leave a machine).
const std::string kUrl = "udpm://239.255.76.67:7667?ttl=1";

// A camera PC: the test's simulated room with two of its cameras, maps on their own channel.
std::string cameraPcConfig(const std::string& name, const std::string& first,
                           const std::string& second) {
  std::string config = testing::simRoomConfig(kUrl);
  config = config.substr(0, config.find("cameras:\n"));
  config.replace(config.find("transport: {"), 12,
                 "transport: {map_channel: OCCMAP_MAP_" + name +
                     ", status_channel: OCCMAP_STATUS_" + name + ", ");
  return config + "cameras:\n  - {name: " + first + ", source: \"sim://room/" + first +
         "\"}\n  - {name: " + second + ", source: \"sim://room/" + second + "\"}\n";
}

std::string mergeNodeConfig() {
  return "map: {origin_m: [-0.62, -1.87], cell_size_m: 0.04, width: 256, height: 256}\n"
         "transport: {lcm_url: \"" +
         kUrl +
         "\", status_channel: OCCMAP_STATUS_MERGE}\n"
         "merge:\n"
         "  max_age_ms: 150\n"
         "  inputs:\n"
         "    - {name: west, channel: OCCMAP_MAP_WEST}\n"
         "    - {name: east, channel: OCCMAP_MAP_EAST}\n";
}

// A daemon on a machine of its own on the LAN.
struct Daemon {
  std::optional<NotifyListener> systemd;
  std::unique_ptr<ChildProcess> process;
  Daemon(testing::Lan& lan, const TemporaryFolder& folder, const std::string& name, int host,
         const std::string& config)
      : systemd(std::in_place, folder / (name + ".notify")),
        process(lan.start(
            name, host, {kOccmapd, "--config", folder.write(name + ".yaml", config).string()},
            folder / name, {{"NOTIFY_SOCKET", (folder / (name + ".notify")).string()}})) {}
  bool ready() {
    const bool ready = process && systemd->collect(testing::eventually(30s), "READY=1");
    systemd.reset();  // a socket nobody reads would fill and block the daemon's sd_notify
    return ready;
  }
  std::string err() const { return process ? process->err() : "not started"; }
};

// The merged maps as they arrive, in this process's network.
class MergedMaps {
 public:
  MergedMaps() : bus_(LcmBus::open(kUrl)) {
    bus_->subscribe("OCCMAP_MAP", [this](const std::uint8_t* data, std::size_t size, std::int64_t) {
      const DecodedMap& map = decoder_.decode(data, size);
      if (map.ok()) {
        last_ = map;
        ++count_;
      }
    });
  }
  // Maps until `done` says so of the newest, or the deadline: whether it did.
  template <typename Done>
  bool until(std::chrono::milliseconds deadline, Done done) {
    const auto end = std::chrono::steady_clock::now() + deadline;
    while (std::chrono::steady_clock::now() < end) {
      if (bus_->handleTimeout(50) > 0 && done(last_)) return true;
    }
    return false;
  }
  const DecodedMap& last() const { return last_; }
  int count() const { return count_; }

 private:
  std::unique_ptr<LcmBus> bus_;
  MapDecoder decoder_;
  DecodedMap last_;
  int count_ = 0;
};

long long unseenCells(const DecodedMap& map) {
  long long unseen = 0;
  for (const std::uint8_t cell : map.cells) unseen += cell == 2 ? 1 : 0;
  return unseen;
}

bool streaming(const DecodedMap& map, std::size_t input) {
  return map.cameras.size() == 2 && map.cameras[input].state == CameraState::kStreaming;
}

// The merged maps in an lcm-logger recording, and the inputs' maps beside them.
struct Recording {
  std::map<std::string, int> maps;  // per channel
  int merged_gaps = 0;              // merged maps missing between two recorded
  double merged_seconds = 0;        // from the first merged map's capture to the last's
};

Recording readRecording(const std::filesystem::path& log) {
  Recording recording;
  lcm::LogFile file(log.string(), "r");
  EXPECT_TRUE(file.good()) << "lcm-logger wrote no readable log";
  if (!file.good()) return recording;
  MapDecoder decoder;
  std::int64_t previous = -1, first_utime = 0, last_utime = 0;
  while (const lcm::LogEvent* event = file.readNextEvent()) {
    ++recording.maps[event->channel];
    if (event->channel != "OCCMAP_MAP") continue;
    const DecodedMap& map = decoder.decode(event->data, static_cast<std::size_t>(event->datalen));
    EXPECT_TRUE(map.ok()) << map.error;
    if (!map.ok()) continue;
    if (previous >= 0 && map.seq > previous + 1) {
      recording.merged_gaps += static_cast<int>(map.seq - previous - 1);
    }
    previous = map.seq;
    if (first_utime == 0) first_utime = map.utime;
    last_utime = map.utime;
  }
  recording.merged_seconds = static_cast<double>(last_utime - first_utime) * 1e-6;
  return recording;
}

TEST(MergeDaemon, TwoCameraPcsMergedOnALanRecordedByAFourthAndOneKilledIsDownThenBack) {
  if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
    GTEST_SKIP() << problem;
  }
  testing::Lan lan;
  if (const std::string problem = lan.up(); !problem.empty()) GTEST_SKIP() << problem;
  TemporaryFolder folder;
  Daemon merge(lan, folder, "merge", 2, mergeNodeConfig());
  ASSERT_TRUE(merge.ready()) << lan.error() << merge.err();
  auto west = std::make_unique<Daemon>(lan, folder, "west", 3, cameraPcConfig("WEST", "c0", "c1"));
  Daemon east(lan, folder, "east", 4, cameraPcConfig("EAST", "c2", "c3"));
  ASSERT_TRUE(west->ready()) << lan.error() << west->err();
  ASSERT_TRUE(east.ready()) << lan.error() << east.err();

  // This process watches from the bridge's own address: a fifth machine.
  MergedMaps maps;
  ASSERT_TRUE(maps.until(testing::eventually(10s), [](const DecodedMap& map) {
    return streaming(map, 0) && streaming(map, 1);
  })) << merge.err();
  EXPECT_EQ(maps.last().cameras[0].name, "west");
  EXPECT_EQ(maps.last().cameras[1].name, "east");
  const long long unseen_with_both = unseenCells(maps.last());
  const std::int64_t west_last_seen = maps.last().cameras[0].capture_utime;
  EXPECT_GT(west_last_seen, 0);

  // lcm-logger on a fourth machine: every merged map, at the rate the PCs make theirs.
  const auto log = folder / "merged.lcmlog";
  auto logger =
      lan.start("logger", 5, {"/usr/bin/lcm-logger", "--lcm-url=" + kUrl, "-q", "-f", log.string()},
                folder / "logger");
  ASSERT_TRUE(logger) << lan.error();
  std::this_thread::sleep_for(4s);
  logger->signal(SIGINT);
  ASSERT_TRUE(logger->waitExit(5s)) << logger->err();
  const Recording recording = readRecording(log);
  const int merged = recording.maps.count("OCCMAP_MAP") ? recording.maps.at("OCCMAP_MAP") : 0;
  const int from_west =
      recording.maps.count("OCCMAP_MAP_WEST") ? recording.maps.at("OCCMAP_MAP_WEST") : 0;
  const int from_east =
      recording.maps.count("OCCMAP_MAP_EAST") ? recording.maps.at("OCCMAP_MAP_EAST") : 0;
  std::printf(
      "lcm-logger on a fourth machine: %d merged maps in %.2f s (%d missing), west %d, east %d\n",
      merged, recording.merged_seconds, recording.merged_gaps, from_west, from_east);
  EXPECT_GT(merged, 0);
  EXPECT_EQ(recording.merged_gaps, 0) << "merged maps lost on the way to the logger";
  if (!testing::kSanitized) {
    // A merged map for every pair of the PCs' maps (a few at the recording's ends aside).
    EXPECT_GE(merged, std::min(from_west, from_east) - 3) << "the merged maps keep the PCs' rate";
  }

  // West is killed: down once its newest map is 150 ms behind east's, and its cells unseen.
  west->process->signal(SIGKILL);
  const auto killed = std::chrono::steady_clock::now();
  ASSERT_TRUE(maps.until(testing::eventually(5s), [](const DecodedMap& map) {
    return map.cameras.size() == 2 && map.cameras[0].state == CameraState::kDown;
  }));
  const double down_after_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  EXPECT_GT(unseenCells(maps.last()), unseen_with_both);
  EXPECT_TRUE(streaming(maps.last(), 1));
  std::printf("west down in the merged maps %.0f ms after it was killed\n", down_after_s * 1e3);
  if (!testing::kSanitized) {
    EXPECT_LT(down_after_s, 0.150 + 0.100 + 0.250) << "generous on a busy CI";
  }

  // Back, on a machine started anew: merged again.
  west.reset();
  west = std::make_unique<Daemon>(lan, folder, "west2", 6, cameraPcConfig("WEST", "c0", "c1"));
  ASSERT_TRUE(west->ready()) << lan.error() << west->err();
  const auto back = std::chrono::steady_clock::now();
  ASSERT_TRUE(maps.until(testing::eventually(5s), [](const DecodedMap& map) {
    return streaming(map, 0) && streaming(map, 1);
  }));
  const double merged_after_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - back).count();
  std::printf("west merged again %.0f ms after it was ready\n", merged_after_s * 1e3);
  if (!testing::kSanitized) {
    EXPECT_LT(merged_after_s, 1.0);
  }
  EXPECT_LE(unseenCells(maps.last()), unseen_with_both + unseen_with_both / 10);

  merge.process->signal(SIGTERM);
  EXPECT_EQ(merge.process->waitExit(testing::eventually(5s)).value_or(-100), 0) << merge.err();
  EXPECT_NE(merge.err().find("merge node ready: 2 inputs"), std::string::npos) << merge.err();
}

}  // namespace
}  // namespace occmap
