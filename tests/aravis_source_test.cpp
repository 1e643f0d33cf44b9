// The Aravis backend against Aravis's own in-process Fake camera (aravis://Fake_1): settings
// applied and read back, config errors named, pixel formats reduced, frames with their times and
// ids, and the live daemon's pipeline fed by four fake cameras that show the simulated room: every
// map it publishes equals the reference fusion of the very images the cameras sent.
//
// The GigE Vision and USB3 Vision interfaces are switched off first, so that looking for a camera
// sends nothing to any network.
#include "capture/aravis_source.h"

#include <atomic>
#include <cmath>
#include <map>
#include <mutex>
#include <thread>

#include <arv.h>
#include <gtest/gtest.h>

#include "base/clock.h"
#include "bus_listener.h"
#include "capture/image_file.h"
#include "capture/live_source.h"
#include "capture/sim/renderer.h"
#include "config/config.h"
#include "config/input_error.h"
#include "daemon/pipeline.h"
#include "sim_reference.h"
#include "temporary_folder.h"
#include "transport/map_codec.h"
#include "transport/memory_bus.h"
#include "tsai_xml.h"

namespace occmap {
namespace {

using namespace std::chrono_literals;
using testing::TemporaryFolder;

class FakeCamera : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    arv_disable_interface("GigEVision");
    arv_disable_interface("USB3Vision");
    arv_enable_interface("Fake");
  }
  void TearDown() override { setFakeCameraFill({}); }

  LiveSourceOptions options(int width, int height,
                            std::vector<std::pair<std::string, std::string>> settings = {}) {
    LiveSourceOptions o;
    o.name = "a";
    o.width = width;
    o.height = height;
    o.fps = 50;
    o.settings = std::move(settings);
    o.notice = [this](const std::string& message) {
      std::lock_guard lock(mutex_);
      notices_.push_back(message);
    };
    return o;
  }
  std::string notices() {
    std::lock_guard lock(mutex_);
    std::string all;
    for (const std::string& n : notices_) all += n + "\n";
    return all;
  }

  // The next frame within a few seconds (a live source may say kTimeout meanwhile).
  static FrameSource::Status nextFrame(FrameSource& source, Frame& frame) {
    const auto give_up = std::chrono::steady_clock::now() + 5s;
    for (;;) {
      const FrameSource::Status status = source.read(frame);
      if (status != FrameSource::Status::kTimeout || std::chrono::steady_clock::now() > give_up)
        return status;
    }
  }

  std::mutex mutex_;
  std::vector<std::string> notices_;
};

std::uint8_t pattern(int u, int v, std::uint64_t n) {
  return static_cast<std::uint8_t>(u * 7 + v * 3 + static_cast<int>(n * 11));
}

TEST_F(FakeCamera, FramesCarryWhatTheCameraSentWithTheirTimesAndIds) {
  std::atomic<std::uint64_t> filled{0};
  setFakeCameraFill(
      [&](const std::string& name, std::uint8_t* data, std::size_t size, int width, int height) {
        ASSERT_EQ(name, "a");
        ASSERT_GE(size, static_cast<std::size_t>(width * height));
        const std::uint64_t n = filled++;
        for (int v = 0; v < height; ++v)
          for (int u = 0; u < width; ++u) data[v * width + u] = pattern(u, v, n);
      });
  std::string error;
  auto source = openAravisSource("Fake_1", options(320, 240), error);
  ASSERT_TRUE(source) << error;
  EXPECT_TRUE(source->isLive());
  EXPECT_EQ(source->width(), 320);
  EXPECT_EQ(source->height(), 240);
  std::int64_t previous_time = 0;
  std::uint64_t previous_id = 0;
  for (std::uint64_t n = 0; n < 10; ++n) {
    Frame frame;
    ASSERT_EQ(nextFrame(*source, frame), FrameSource::Status::kFrame) << source->lastError();
    EXPECT_EQ(frame.sequence, n);
    ASSERT_EQ(frame.image.width, 320);
    ASSERT_EQ(frame.image.height, 240);
    // Every pixel is the one the camera sent for this frame (Mono8: handed out without a copy).
    long wrong = 0;
    for (int v = 0; v < 240; ++v)
      for (int u = 0; u < 320; ++u) wrong += frame.image.at(u, v) != pattern(u, v, n);
    EXPECT_EQ(wrong, 0) << "frame " << n;
    // Host capture time: now, and later than the previous frame's by about a frame period.
    EXPECT_LT(std::abs(frame.capture_time_us - hostTimeMicroseconds()), 2'000'000);
    EXPECT_GT(frame.capture_time_us, previous_time);
    EXPECT_NE(frame.device_time_ns, 0u);
    if (n > 0) {
      EXPECT_EQ(frame.device_frame_id, previous_id + 1) << "the camera's own frame ids";
    }
    previous_time = frame.capture_time_us;
    previous_id = frame.device_frame_id;
  }
  const TransportCounters counters = source->transportCounters();
  EXPECT_EQ(counters.frames_incomplete, 0);
  EXPECT_EQ(counters.missing_packets, 0);
}

TEST_F(FakeCamera, SettingsAreAppliedAndWhatTheCameraChangedIsSaid) {
  std::string error;
  auto source =
      openAravisSource("Fake_1", options(160, 120, {{"ExposureTimeAbs", "1234.5"}}), error);
  ASSERT_TRUE(source) << error;
  // The fake camera keeps whole microseconds: read back, the difference is reported.
  EXPECT_NE(notices().find("camera a: setting ExposureTimeAbs: asked 1234.5, the camera took 1234"),
            std::string::npos)
      << notices();
  Frame frame;
  ASSERT_EQ(nextFrame(*source, frame), FrameSource::Status::kFrame) << source->lastError();
  EXPECT_EQ(frame.image.width, 160);
}

// Whether the priority is granted depends on the process's limits (RLIMIT_RTPRIO, CAP_SYS_NICE):
// either way the receive thread asks for it when it starts, and the answer is said.
TEST_F(FakeCamera, TheReceiveThreadAsksForRealtimePriorityAndTheAnswerIsSaid) {
  std::string error;
  auto source =
      openAravisSource("Fake_1", options(80, 60, {{"stream.realtime_priority", "5"}}), error);
  ASSERT_TRUE(source) << error;
  Frame frame;
  ASSERT_EQ(nextFrame(*source, frame), FrameSource::Status::kFrame) << source->lastError();
  ASSERT_EQ(nextFrame(*source, frame), FrameSource::Status::kFrame) << source->lastError();
  const std::string said = notices();
  const bool granted = said.find("camera a: Aravis's receive thread runs at realtime priority 5") !=
                       std::string::npos;
  const bool refused =
      said.find(
          "camera a: realtime priority 5 for Aravis's receive thread refused: the service "
          "needs LimitRTPRIO=") != std::string::npos;
  EXPECT_TRUE(granted || refused) << said;
  std::printf("realtime priority 5: %s\n", granted ? "granted" : "refused");
}

TEST_F(FakeCamera, WhatTheCameraRefusesIsAConfigErrorThatNamesIt) {
  struct Case {
    std::vector<std::pair<std::string, std::string>> settings;
    int width;
    std::vector<std::string> said;
  };
  const std::vector<Case> cases = {
      {{{"Colour", "blue"}}, 160, {"'Colour'", "no such feature", "arv-tool-0.8"}},
      {{}, 5000, {"Width 5000", "refused"}},
      {{{"PixelFormat", "Mono16"}}, 160, {"Mono16", "not one occmap takes", "Mono8"}},
      {{{"PixelFormat", "Purple8"}}, 160, {"PixelFormat", "Purple8", "refused"}},
      {{{"stream.socket_buffer", "auto"}}, 160, {"stream.socket_buffer", "no such property"}},
      {{{"stream.realtime_priority", "0"}}, 160, {"realtime_priority", "1 to 99"}},
  };
  for (const Case& c : cases) {
    std::string error;
    auto source = openAravisSource("Fake_1", options(c.width, 120, c.settings), error);
    EXPECT_FALSE(source) << "accepted: " << (c.settings.empty() ? "" : c.settings[0].first);
    for (const std::string& part : c.said) EXPECT_NE(error.find(part), std::string::npos) << error;
  }
}

TEST_F(FakeCamera, ColourIsReducedToLuminanceAndBayerIsTakenRaw) {
  setFakeCameraFill([](const std::string&, std::uint8_t* data, std::size_t size, int, int) {
    for (std::size_t i = 0; i < size; ++i) data[i] = static_cast<std::uint8_t>(i * 37 % 251);
  });
  {
    std::string error;
    auto source = openAravisSource("Fake_1", options(64, 48, {{"PixelFormat", "RGB8"}}), error);
    ASSERT_TRUE(source) << error;
    Frame frame;
    ASSERT_EQ(nextFrame(*source, frame), FrameSource::Status::kFrame) << source->lastError();
    int worst = 0;
    for (int v = 0; v < 48; ++v) {
      for (int u = 0; u < 64; ++u) {
        const std::size_t i = static_cast<std::size_t>(v * 64 + u) * 3;
        const double r = static_cast<double>(i * 37 % 251),
                     g = static_cast<double>((i + 1) * 37 % 251),
                     b = static_cast<double>((i + 2) * 37 % 251);
        const double luminance = 0.299 * r + 0.587 * g + 0.114 * b;  // ITU-R BT.601
        worst = std::max(worst, static_cast<int>(std::abs(frame.image.at(u, v) - luminance) + 0.5));
      }
    }
    EXPECT_LE(worst, 1) << "RGB8 becomes BT.601 luminance, as colour image files do";
  }
  {
    std::string error;
    auto source = openAravisSource("Fake_1", options(64, 48, {{"PixelFormat", "BayerRG8"}}), error);
    ASSERT_TRUE(source) << error;
    Frame frame;
    ASSERT_EQ(nextFrame(*source, frame), FrameSource::Status::kFrame) << source->lastError();
    long wrong = 0;
    for (int v = 0; v < 48; ++v)
      for (int u = 0; u < 64; ++u)
        wrong += frame.image.at(u, v) != static_cast<std::uint8_t>((v * 64 + u) * 37 % 251);
    EXPECT_EQ(wrong, 0) << "Bayer frames are compared raw, against a raw Bayer background";
  }
}

TEST(Luminance, YuvGivesItsLumaSamplesAndPaddingIsNeverRead) {
  constexpr int kWidth = 6, kHeight = 3, kStride = kWidth * 2 + 4;  // 4 bytes of row padding
  std::vector<std::uint8_t> yuyv(kStride * kHeight, 0xEE), uyvy(kStride * kHeight, 0xEE);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const auto y = static_cast<std::uint8_t>(10 * v + u);
      const auto chroma = static_cast<std::uint8_t>(200 + u);
      yuyv[v * kStride + 2 * u] = y;  // Y0 U Y1 V
      yuyv[v * kStride + 2 * u + 1] = chroma;
      uyvy[v * kStride + 2 * u + 1] = y;  // U Y0 V Y1
      uyvy[v * kStride + 2 * u] = chroma;
    }
  }
  for (const auto& [pixels, data] :
       {std::pair{CameraPixels::kYuv422Yuyv, &yuyv}, std::pair{CameraPixels::kYuv422Uyvy, &uyvy}}) {
    std::vector<std::uint8_t> out(kWidth * kHeight, 0);
    reduceToLuminance(pixels, data->data(), kWidth, kHeight, kStride, out.data());
    for (int v = 0; v < kHeight; ++v)
      for (int u = 0; u < kWidth; ++u) EXPECT_EQ(out[v * kWidth + u], 10 * v + u) << u << "," << v;
  }
  EXPECT_TRUE(cameraPixelsOf(ARV_PIXEL_FORMAT_YUV_422_PACKED).has_value());
  EXPECT_FALSE(cameraPixelsOf(ARV_PIXEL_FORMAT_MONO_16).has_value());
}

TEST_F(FakeCamera, ASerialNumberFindsTheCamera) {
  std::string error;
  auto source = openAravisSource("1", options(80, 60), error);  // Fake_1's serial number
  ASSERT_TRUE(source) << error;
  Frame frame;
  EXPECT_EQ(nextFrame(*source, frame), FrameSource::Status::kFrame) << source->lastError();
}

TEST_F(FakeCamera, AnAbsentCameraIsWaitedForWhenItsSizeIsKnown) {
  std::string error;
  auto source = openAravisSource("Fake_7", options(80, 60), error);
  ASSERT_TRUE(source) << "an absent camera is not a config error: " << error;
  EXPECT_NE(notices().find("camera a: camera 'Fake_7' not found"), std::string::npos) << notices();
  EXPECT_EQ(source->width(), 80);
  Frame frame;
  EXPECT_EQ(source->read(frame), FrameSource::Status::kLost);
  EXPECT_NE(source->lastError().find("not found"), std::string::npos) << source->lastError();
  EXPECT_FALSE(source->reopen());
  // Without a background nothing says what size the stream will be.
  EXPECT_FALSE(openAravisSource("Fake_7", options(0, 0), error));
  EXPECT_NE(error.find("background"), std::string::npos) << error;
}

// The paper's room, shown by four in-process fake cameras instead of the simulator's own source.
TEST_F(FakeCamera, ThePipelinesMapsEqualTheReferenceFusionOfTheImagesTheCamerasSent) {
  const std::unique_ptr<sim::Scene> scene = sim::makeScene("room");
  ASSERT_EQ(scene->cameras().size(), 4u);
  struct Shown {
    std::unique_ptr<sim::Renderer> renderer;
    Image image{640, 480};
    std::vector<float> depth;
    std::uint64_t frames = 0;  // the fake camera's thread alone counts these
  };
  std::map<std::string, Shown> shown;
  TemporaryFolder folder;
  std::string config =
      "map: {origin_m: [-0.62, -1.87], cell_size_m: 0.04, width: 256, height: 256}\n"
      "fusion: {threshold: 20, column_height_m: 0}\n"
      "transport: {lcm_url: \"memq://\"}\n"
      "cameras:\n";
  for (std::size_t k = 0; k < scene->cameras().size(); ++k) {
    const auto& camera = scene->cameras()[k];
    Shown& s = shown[camera.name];
    s.renderer = std::make_unique<sim::Renderer>(
        *scene,
        Camera(std::make_shared<TsaiCamera>(camera.calibration), LengthUnit::kMillimetre, 640, 480),
        static_cast<int>(k));
    std::string error;
    ASSERT_TRUE(writeGreyPng(folder / (camera.name + "-bg.png"), s.renderer->background(), error));
    ASSERT_TRUE(
        writeGreyPng(folder / (camera.name + "-floor.png"), s.renderer->floorMask(), error));
    folder.write(camera.name + ".xml", testing::tsaiXml(camera.calibration, camera.name));
    config += "  - {name: " + camera.name +
              ", source: \"aravis://Fake_1\", calibration: " + camera.name +
              ".xml, background: " + camera.name + "-bg.png, floor_mask: " + camera.name +
              "-floor.png, fps: 30}\n";
  }
  // Frame n of each camera is the simulator's frame n: what SimRoomReference renders for a map
  // whose camera says it used frame n.
  setFakeCameraFill(
      [&](const std::string& name, std::uint8_t* data, std::size_t size, int width, int height) {
        Shown& s = shown.at(name);
        ASSERT_EQ(width, 640);
        ASSERT_EQ(height, 480);
        ASSERT_GE(size, 640u * 480u);
        const std::uint64_t n = s.frames++;
        s.renderer->render(scene->objectsAt(static_cast<double>(n) / 30.0), n, s.image, s.depth);
        std::memcpy(data, s.image.data(), 640u * 480u);
      });
  const Config loaded = loadConfig(folder.write("fake.yaml", config));
  Rig rig = Rig::open(loaded);
  std::vector<CarveTable> tables = rig.buildTables(0.0);

  std::mutex mutex;
  std::vector<DecodedMap> received;
  MemoryNetwork network;
  testing::BusListener listener(network);
  MapDecoder decoder;
  listener.subscribe("OCCMAP_MAP", [&](const std::uint8_t* data, std::size_t size) {
    const DecodedMap& map = decoder.decode(data, size);
    std::lock_guard lock(mutex);
    if (map.ok()) received.push_back(map);
  });
  listener.start();
  Pipeline pipeline(PreparedRig{std::move(rig), std::move(tables), 0.0}, network.connect());
  pipeline.start();
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(50ms);
    std::lock_guard lock(mutex);
    if (received.size() >= 40) break;
  }
  pipeline.stop();
  listener.stop();

  std::lock_guard lock(mutex);
  ASSERT_GE(received.size(), 40u);
  const testing::SimRoomReference reference(loaded.map, 0.0);
  std::size_t compared = 0, all_cameras = 0, people = 0;
  for (std::size_t i = 0; i < received.size(); i += 3) {
    const DecodedMap& map = received[i];
    ASSERT_EQ(map.cameras.size(), 4u);
    ASSERT_EQ(reference.firstDifference(map), -1) << "map " << map.seq;
    ++compared;
    all_cameras += std::count_if(map.cameras.begin(), map.cameras.end(),
                                 [](const DecodedCamera& c) { return c.used; }) == 4;
    people += std::count(map.cells.begin(), map.cells.end(),
                         static_cast<std::uint8_t>(CellState::kOccupied)) > 0;
  }
  EXPECT_GE(compared, 12u);
  EXPECT_GE(all_cameras, compared / 2) << "most maps should fuse all four cameras";
  EXPECT_EQ(people, compared) << "the room always holds someone: no map is all free";
}

}  // namespace
}  // namespace occmap
