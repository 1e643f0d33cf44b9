// occmapd as a merge node on a real network made by the test (UDP multicast on a private loopback:
// nothing leaves it): two camera PCs' daemons, each with two of the simulated room's cameras on a
// channel of its own, and a merge node publishing one map. Their merged maps come with both inputs
// streaming; one PC killed is down in the merged maps once its newest map is max_age_ms behind the
// other's (its cells unseen), and merged again once it is back.
#include <chrono>
#include <optional>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "child_process.h"
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
const std::string kUrl = "udpm://239.255.76.67:7667?ttl=0";

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

struct Daemon {
  std::optional<NotifyListener> systemd;
  ChildProcess process;
  Daemon(const TemporaryFolder& folder, const std::string& name, const std::string& config)
      : systemd(std::in_place, folder / (name + ".notify")),
        process({kOccmapd, "--config", folder.write(name + ".yaml", config).string()},
                folder / name, {{"NOTIFY_SOCKET", (folder / (name + ".notify")).string()}}) {}
  bool ready() {
    const bool ready = systemd->collect(testing::eventually(30s), "READY=1");
    systemd.reset();  // a socket nobody reads would fill and block the daemon's sd_notify
    return ready;
  }
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

TEST(MergeDaemon, TwoCameraPcsMergedAndOneKilledIsDownThenBack) {
  if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
    GTEST_SKIP() << problem;
  }
  TemporaryFolder folder;
  Daemon merge(folder, "merge", mergeNodeConfig());
  ASSERT_TRUE(merge.ready()) << merge.process.err();
  auto west = std::make_unique<Daemon>(folder, "west", cameraPcConfig("WEST", "c0", "c1"));
  Daemon east(folder, "east", cameraPcConfig("EAST", "c2", "c3"));
  ASSERT_TRUE(west->ready()) << west->process.err();
  ASSERT_TRUE(east.ready()) << east.process.err();

  MergedMaps maps;
  ASSERT_TRUE(maps.until(testing::eventually(10s), [](const DecodedMap& map) {
    return streaming(map, 0) && streaming(map, 1);
  })) << merge.process.err();
  EXPECT_EQ(maps.last().cameras[0].name, "west");
  EXPECT_EQ(maps.last().cameras[1].name, "east");
  const long long unseen_with_both = unseenCells(maps.last());
  const std::int64_t west_last_seen = maps.last().cameras[0].capture_utime;
  EXPECT_GT(west_last_seen, 0);

  // West is killed: down once its newest map is 150 ms behind east's, and its cells unseen.
  west->process.signal(SIGKILL);
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

  // Back: merged again.
  west.reset();
  west = std::make_unique<Daemon>(folder, "west2", cameraPcConfig("WEST", "c0", "c1"));
  ASSERT_TRUE(west->ready()) << west->process.err();
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

  merge.process.signal(SIGTERM);
  EXPECT_EQ(merge.process.waitExit(testing::eventually(5s)).value_or(-100), 0)
      << merge.process.err();
  EXPECT_NE(merge.process.err().find("merge node ready: 2 inputs"), std::string::npos)
      << merge.process.err();
}

}  // namespace
}  // namespace occmap
