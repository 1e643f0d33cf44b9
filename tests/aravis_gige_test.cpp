// occmapd on four GigE Vision cameras: Aravis's arv-fake-gv-camera-0.8, one process per camera on
// 127.0.0.1-4 (serials GV01-GV04), inside a private network namespace the test makes, with
// examples/aravis-fake.yaml as the config (on the daemon tests' 4 cm map). The cameras stream at 30
// fps for ten seconds without a failure counted; a camera killed mid-stream is marked down within a
// second while the maps go on (its cells turning unseen), and once it is started again the daemon
// streams from it within 3 s.
#include <algorithm>
#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <thread>

#include <gtest/gtest.h>
#include <occmap/status_request_t.hpp>
#include <occmap/status_t.hpp>

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
using testing::runCommand;
using testing::TemporaryFolder;
using Clock = std::chrono::steady_clock;

const std::string kOccmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
const std::string kConfig = OCCMAP_SOURCE_DIR "/examples/aravis-fake.yaml";
const std::string kUrl = "udpm://239.255.76.67:7667?ttl=0";  // the example's (LCM's default)
constexpr int kCameras = 4;

using testing::kSanitized;  // rates and latencies are not what is under test there
// Maps published in 10 s by four 30 fps cameras, at least two thirds of 300 in the plain build (see
// there). Under the sanitizers how many is a rate of that build on that host (a TSan occmapd makes
// 6 to 7 maps a second on a 2-core EPYC), so there the maps and frames need only go on.
constexpr long long kMinMapsIn10s = kSanitized ? 1 : 200;

std::string address(int k) { return "127.0.0." + std::to_string(k + 1); }
std::string serial(int k) { return "GV0" + std::to_string(k + 1); }

// What the test hears of the daemon on the bus: the newest status (asked for ten times a second)
// and the newest map.
class Listener {
 public:
  Listener() : bus_(kUrl) {
    bus_.subscribe("OCCMAP_STATUS",
                   [this](const std::uint8_t* data, std::size_t size, std::int64_t) {
                     occmap::status_t status;
                     if (status.decode(data, 0, static_cast<int>(size)) == static_cast<int>(size))
                       status_ = status;
                   });
    bus_.subscribe("OCCMAP_MAP", [this](const std::uint8_t* data, std::size_t size, std::int64_t) {
      const DecodedMap& map = decoder_.decode(data, size);
      if (map.ok()) {
        map_ = map;
        ++maps_;
      }
    });
  }
  bool good() const { return bus_.good(); }

  // Listens for `duration`, asking for the status every 100 ms, until `done` holds.
  template <typename Done>
  bool listen(std::chrono::milliseconds duration, Done done) {
    const auto end = Clock::now() + duration;
    auto next_request = Clock::now();
    while (Clock::now() < end) {
      if (Clock::now() >= next_request) {
        occmap::status_request_t request{};
        request.request_id = ++request_id_;
        std::vector<std::uint8_t> bytes(static_cast<std::size_t>(request.getEncodedSize()));
        request.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
        bus_.publish(statusRequestChannel("OCCMAP_STATUS"), bytes);
        next_request = Clock::now() + 100ms;
      }
      bus_.handleTimeout(20);
      if (done()) return true;
    }
    return false;
  }
  void listen(std::chrono::milliseconds duration) {
    listen(duration, [] { return false; });
  }

  const std::optional<occmap::status_t>& status() const { return status_; }
  const occmap::camera_status_t* camera(const std::string& name) const {
    if (!status_) return nullptr;
    for (const auto& c : status_->cameras)
      if (c.name == name) return &c;
    return nullptr;
  }
  const std::optional<DecodedMap>& map() const { return map_; }
  std::size_t maps() const { return maps_; }

 private:
  LcmBus bus_;
  MapDecoder decoder_;
  std::optional<occmap::status_t> status_;
  std::optional<DecodedMap> map_;
  std::size_t maps_ = 0;
  std::int64_t request_id_ = 0;
};

class FakeGigE : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string(OCCMAP_ARV_FAKE_GV_CAMERA).find("NOTFOUND") != std::string::npos ||
        !std::filesystem::exists(OCCMAP_ARV_FAKE_GV_CAMERA)) {
      GTEST_SKIP() << "arv-fake-gv-camera-0.8 is not installed (Debian package aravis-tools-cli)";
    }
    if (std::string(OCCMAP_IP).find("NOTFOUND") != std::string::npos) {
      GTEST_SKIP() << "the ip command is not installed (Debian package iproute2)";
    }
    if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
      GTEST_SKIP() << problem;
    }
    // One address per camera on this namespace's own loopback (127.0.0.1 is there already).
    for (int k = 1; k < kCameras; ++k) {
      const auto result =
          runCommand({OCCMAP_IP, "addr", "replace", address(k) + "/8", "dev", "lo"});
      ASSERT_EQ(result.exit_code, 0) << result.err;
    }
    for (int k = 0; k < kCameras; ++k) startCamera(k);
  }

  void startCamera(int k) {
    cameras_[k] = std::make_unique<ChildProcess>(
        std::vector<std::string>{OCCMAP_ARV_FAKE_GV_CAMERA, "-i", address(k), "-s", serial(k)},
        folder_ / ("camera-" + serial(k)));
    ASSERT_TRUE(cameras_[k]->started());
  }

  // The example copied beside the test (its paths are relative to it) with its map as the daemon
  // tests' (testing::inCoarseMap: the same floor in 4 cm cells, a quarter of the cells to build
  // tables for at each start and reload; the cameras and their faults are what these tests are
  // about). Returns the config's text; it is written to occmapd.yaml.
  std::string writeExample() {
    if (!std::filesystem::exists(folder_ / "aravis-fake")) {
      std::filesystem::copy(OCCMAP_SOURCE_DIR "/examples/aravis-fake", folder_ / "aravis-fake");
    }
    const std::string text = testing::inCoarseMap(testing::readWhole(kConfig));
    EXPECT_NE(text, "") << "examples/aravis-fake.yaml changed: not the map inCoarseMap knows";
    folder_.write("occmapd.yaml", text);
    return text;
  }

  // occmapd on the example (writeExample, or `config`), up once every camera streams (READY=1).
  void startDaemon(std::string config = "") {
    if (config.empty()) {
      writeExample();
      config = (folder_ / "occmapd.yaml").string();
    }
    NotifyListener systemd(folder_ / "notify");
    daemon_ = std::make_unique<ChildProcess>(std::vector<std::string>{kOccmapd, "--config", config},
                                             folder_ / "occmapd",
                                             std::vector<std::pair<std::string, std::string>>{
                                                 {"NOTIFY_SOCKET", systemd.path().string()}});
    ASSERT_TRUE(systemd.collect(60s, "READY=1")) << daemon_->err();
  }

  void TearDown() override {
    if (daemon_) {
      daemon_->signal(SIGTERM);
      EXPECT_EQ(daemon_->waitExit(testing::eventually(5s)), 0) << daemon_->err();
    }
  }

  TemporaryFolder folder_;
  std::array<std::unique_ptr<ChildProcess>, kCameras> cameras_;
  std::unique_ptr<ChildProcess> daemon_;
};

// `occmap background` through a real GigE Vision camera: the camera is set to the stream's size,
// N frames are taken, their per-pixel median written. (The fake camera's pattern moves from frame
// to frame, so only the geometry and the count are checked here; the median itself is tested on
// files in occmap_cli_test.)
TEST_F(FakeGigE, BackgroundTakesTheMedianOfFramesFromTheCamera) {
  const auto out = folder_ / "gv01-background.png";
  const auto result =
      runCommand({OCCMAP_BINARY_DIR "/tools/occmap", "background", "--config", kConfig, "--camera",
                  "gv01", "--frames", "15", "--out", out.string()});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find("the per-pixel median of 15 frames of camera gv01 (640x480)"),
            std::string::npos)
      << result.out;
  EXPECT_TRUE(std::filesystem::exists(out));
}

TEST_F(FakeGigE, FourCamerasStreamAtThirtyFpsForTenSecondsWithNoFailureCounted) {
  startDaemon();
  Listener listener;
  ASSERT_TRUE(listener.good());
  ASSERT_TRUE(listener.listen(5s, [&] { return listener.status().has_value(); }));
  const std::int64_t maps_before = listener.status()->maps_published;
  std::array<std::int64_t, kCameras> frames_before{};
  for (int k = 0; k < kCameras; ++k) {
    const auto* camera = listener.camera("gv0" + std::to_string(k + 1));
    ASSERT_NE(camera, nullptr) << "status names the cameras gv01-gv04";
    frames_before[k] = camera->frames_in;
  }
  listener.listen(10s);
  const occmap::status_t& status = *listener.status();
  const std::int64_t maps = status.maps_published - maps_before;
  std::printf("10 s: %lld maps published, %zu heard; fusion p50 %.2f ms, p99 %.2f ms\n",
              static_cast<long long>(maps), listener.maps(), status.fusion_p50_ms,
              status.fusion_p99_ms);
  // About 30 a second. The fake cameras are processes on the same two cores as everything else
  // and fall behind their clock when the machine is busy (27 fps seen under a parallel build; the
  // test runs alone in CTest for that reason), so the floor here is two thirds; what must hold
  // exactly is that nothing fails.
  EXPECT_GE(maps, kMinMapsIn10s) << "about 30 maps a second (fewer under the sanitizers)";
  EXPECT_EQ(status.publish_errors, 0);
  for (int k = 0; k < kCameras; ++k) {
    const auto& camera = *listener.camera("gv0" + std::to_string(k + 1));
    std::printf(
        "  %s: %lld frames in 10 s (%.1f fps), incomplete %lld, missing packets %lld, "
        "resent %lld, underruns %lld, dropped %lld\n",
        camera.name.c_str(), static_cast<long long>(camera.frames_in - frames_before[k]),
        camera.fps, static_cast<long long>(camera.frames_incomplete),
        static_cast<long long>(camera.missing_packets),
        static_cast<long long>(camera.resent_packets), static_cast<long long>(camera.underruns),
        static_cast<long long>(camera.frames_dropped));
    EXPECT_EQ(camera.state, 1) << camera.name << " streaming";
    EXPECT_EQ(camera.reconnects, 0) << camera.name;
    if (kSanitized) {
      // Packets the receive thread was too slow for are lost under a sanitizer on a slow host
      // (the kernel's socket buffer overflows): a rate again. The frames must go on.
      EXPECT_GT(camera.frames_in - frames_before[k], 0) << camera.name;
    } else {
      EXPECT_GE(camera.frames_in - frames_before[k], 200) << camera.name;
      EXPECT_EQ(camera.frames_incomplete, 0) << camera.name;
      EXPECT_EQ(camera.missing_packets, 0) << camera.name;
      EXPECT_EQ(camera.underruns, 0) << camera.name;
      EXPECT_EQ(camera.frames_dropped, 0) << camera.name;
    }
  }
}

std::size_t unseenCells(const DecodedMap& map) {
  return static_cast<std::size_t>(
      std::count(map.cells.begin(), map.cells.end(), static_cast<std::uint8_t>(2)));
}

TEST_F(FakeGigE, ACameraKilledIsMarkedDownTheMapsGoOnAndItStreamsAgainSoonAfterItIsBack) {
  startDaemon();
  Listener listener;
  ASSERT_TRUE(listener.good());
  ASSERT_TRUE(listener.listen(5s, [&] { return listener.map() && listener.status(); }));
  listener.listen(1s);
  const std::size_t unseen_before = unseenCells(*listener.map());
  const int lost = 2;  // gv03
  const std::string name = "gv03";

  cameras_[lost]->signal(SIGKILL);
  const auto killed = Clock::now();
  ASSERT_TRUE(listener.listen(testing::eventually(5s), [&] {
    const auto* camera = listener.camera(name);
    return camera != nullptr && camera->state == 2;
  })) << "never marked down";
  const auto down_after = Clock::now() - killed;
  std::printf("%s marked down %.2f s after it was killed: %s\n", name.c_str(),
              std::chrono::duration<double>(down_after).count(),
              listener.camera(name)->last_error.c_str());
  // The status is asked for every 0.1 s: "within a second" plus one question's round trip.
  if (!kSanitized) {
    EXPECT_LT(down_after, 1200ms) << "down within a second";
  }

  // The maps go on without it, and what only it saw is unseen now.
  const std::size_t maps_at_loss = listener.maps();
  if (kSanitized) {
    // Not a rate there (tests/timing.h): the maps go on, however slowly.
    listener.listen(testing::eventually(2s), [&] { return listener.maps() - maps_at_loss >= 10u; });
  } else {
    listener.listen(2s);
  }
  EXPECT_GE(listener.maps() - maps_at_loss, kSanitized ? 10u : 20u) << "maps go on";
  const DecodedMap& map = *listener.map();
  ASSERT_EQ(map.cameras.size(), static_cast<std::size_t>(kCameras));
  EXPECT_FALSE(map.cameras[lost].used);
  EXPECT_EQ(map.cameras[lost].state, CameraState::kDown);
  EXPECT_GT(unseenCells(map), unseen_before) << "its cells turn unseen";
  // Every other camera is in the maps. One map is not enough to ask of: under TSan a frame can
  // miss its set now and then (the ring's newest frame is late), which the next set makes good.
  const auto others_used = [&] {
    const DecodedMap& newest = *listener.map();
    for (int k = 0; k < kCameras; ++k) {
      if (k != lost && !newest.cameras[static_cast<std::size_t>(k)].used) {
        return false;
      }
    }
    return true;
  };
  EXPECT_TRUE(listener.listen(testing::eventually(1s), others_used))
      << "the other cameras are in the maps";

  startCamera(lost);
  const auto restarted = Clock::now();
  const std::int64_t frames_at_restart = listener.camera(name)->frames_in;
  ASSERT_TRUE(listener.listen(testing::eventually(10s),
                              [&] {
                                const auto* camera = listener.camera(name);
                                return camera->state == 1 && camera->frames_in > frames_at_restart;
                              }))
      << "never streamed again: " << daemon_->err();
  const auto back_after = Clock::now() - restarted;
  std::printf("%s streaming again %.2f s after it was restarted (reconnects %d)\n", name.c_str(),
              std::chrono::duration<double>(back_after).count(), listener.camera(name)->reconnects);
  if (!kSanitized) {
    EXPECT_LT(back_after, 3s) << "streaming again within 3 s";
  }
  EXPECT_GE(listener.camera(name)->reconnects, 1);
  // Its cells are seen again: on a map with every camera in it (see above).
  EXPECT_TRUE(listener.listen(testing::eventually(2s), [&] {
    const DecodedMap& newest = *listener.map();
    return newest.cameras[lost].used && others_used() && unseenCells(newest) == unseen_before;
  })) << "its cells are seen again: " << unseenCells(*listener.map()) << " unseen, "
      << unseen_before << " before";
  EXPECT_NE(daemon_->err().find("camera gv03 is back"), std::string::npos) << daemon_->err();
}

// SIGHUP with live cameras: a camera whose connection the new config leaves as it was is handed
// over without reconnecting; a changed one is opened anew with its new settings; a config a camera
// refuses puts the old one back, cameras and all.
TEST_F(FakeGigE, AReloadKeepsUnchangedCamerasAndReopensAChangedOne) {
  // The example, copied so that it can be edited.
  std::string text = writeExample();
  startDaemon((folder_ / "occmapd.yaml").string());
  Listener listener;
  ASSERT_TRUE(listener.good());
  ASSERT_TRUE(listener.listen(5s, [&] { return listener.status().has_value(); }));

  // gv02 at 20 fps instead of 30.
  const std::string gv02 = "source: \"aravis://Aravis-Fake-GV02\"";
  const std::size_t at = text.find("fps: 30", text.find(gv02));
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 7, "fps: 20");
  folder_.write("occmapd.yaml", text);
  daemon_->signal(SIGHUP);
  const auto reloaded = [&] { return daemon_->err().find("reloaded") != std::string::npos; };
  ASSERT_TRUE(listener.listen(testing::eventually(30s), reloaded)) << daemon_->err();
  const std::string log = daemon_->err();
  for (const char* kept : {"gv01", "gv03", "gv04"}) {
    EXPECT_NE(log.find(std::string("camera ") + kept + ": its connection carries over"),
              std::string::npos)
        << log;
  }
  EXPECT_NE(log.find("camera gv02: opened anew"), std::string::npos) << log;
  listener.listen(4s);
  for (const char* name : {"gv01", "gv02", "gv03", "gv04"}) {
    const auto* camera = listener.camera(name);
    ASSERT_NE(camera, nullptr);
    EXPECT_EQ(camera->state, 1) << name << " streaming after the reload";
    EXPECT_EQ(camera->reconnects, 0) << name;
  }
  if (!kSanitized) {
    EXPECT_NEAR(listener.camera("gv02")->fps, 20.0, 3.0) << "gv02 runs at its new rate";
    EXPECT_GT(listener.camera("gv01")->fps, 24.0) << "gv01 keeps its rate";
  }

  // A setting gv03 refuses: the reload is refused, and all four stream on with the old config.
  const std::string gv03 = "source: \"aravis://Aravis-Fake-GV03\"";
  const std::size_t settings = text.find("settings: {", text.find(gv03));
  text.insert(settings + 11, "Colour: blue, ");
  folder_.write("occmapd.yaml", text);
  daemon_->signal(SIGHUP);
  const auto refused = [&] { return daemon_->err().find("reload refused") != std::string::npos; };
  ASSERT_TRUE(listener.listen(testing::eventually(30s), refused)) << daemon_->err();
  EXPECT_NE(daemon_->err().find("Colour"), std::string::npos) << daemon_->err();
  ASSERT_TRUE(listener.listen(testing::eventually(10s),
                              [&] {
                                for (const char* name : {"gv01", "gv02", "gv03", "gv04"}) {
                                  const auto* camera = listener.camera(name);
                                  if (camera == nullptr || camera->state != 1 ||
                                      camera->frames_in < 30)
                                    return false;
                                }
                                return true;
                              }))
      << "the old config should stream again: " << daemon_->err();
  EXPECT_TRUE(daemon_->running());
}

}  // namespace
}  // namespace occmap
