// Camera previews for the live view (issue 17, daemon/previewer.h,
// transport/camera_preview_message.h). The pipeline in process on the in-memory bus, on the
// simulated room: no preview before a client asks; then previews of the camera asked for only, at
// most two a second of the stream's capture time, ending when the last request runs out; each one a
// message of at most 61 440 bytes whose JPEG is the camera's frame scaled down, whose changed bits
// are that frame's changed pixels scaled down, and whose coverage is the carve table's. Then the
// previewer's own rules with time passed in (its schedule, a message made smaller until it fits,
// one that never fits), and the decoders refusing truncated and lying messages with a reason.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <occmap/status_request_t.hpp>
#include <opencv2/imgcodecs.hpp>

#include "base/clock.h"
#include "bus_listener.h"
#include "config/config.h"
#include "core/changed_pixels.h"
#include "core/fusion_kernel.h"
#include "daemon/pipeline.h"
#include "daemon/previewer.h"
#include "daemon/service_notifier.h"
#include "sim_room_config.h"
#include "temporary_folder.h"
#include "timing.h"
#include "transport/camera_preview_message.h"
#include "transport/map_codec.h"
#include "transport/memory_bus.h"

namespace occmap {
namespace {

using testing::BusListener;
using testing::TemporaryFolder;

const std::string kPreviewChannel = "OCCMAP_STATUS_PREVIEW";
const std::string kRequestChannel = "OCCMAP_STATUS_PREVIEW_REQUEST";

// Pixel (u, v) of a changed-pixel mask, read by the layout core/fusion_kernel.h documents (not
// by the code under test).
bool changedAt(const std::uint8_t* mask, int width, int u, int v) {
  const std::size_t word =
      static_cast<std::size_t>(v / 8) * tilesAcross(width) + static_cast<std::size_t>(u / 8);
  std::uint64_t bits = 0;
  std::memcpy(&bits, mask + word * 8, 8);  // little-endian in memory, as the host is
  return (bits >> ((v % 8) * 8 + u % 8) & 1u) != 0;
}

// A frame at 1/scale as camera_preview_t defines it: each preview pixel the mean of the stream
// pixels it covers, changed when any of them is.
struct ByDefinition {
  int width = 0;
  int height = 0;
  std::vector<double> grey;
  std::vector<std::uint8_t> changed;
};

ByDefinition shrinkByDefinition(ImageView image, const std::uint8_t* mask, int scale) {
  ByDefinition out;
  out.width = (image.width + scale - 1) / scale;
  out.height = (image.height + scale - 1) / scale;
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      double sum = 0;
      int pixels = 0;
      std::uint8_t changed = 0;
      for (int v = y * scale; v < std::min((y + 1) * scale, image.height); ++v) {
        for (int u = x * scale; u < std::min((x + 1) * scale, image.width); ++u) {
          sum += image.at(u, v);
          ++pixels;
          if (changedAt(mask, image.width, u, v)) changed = 1;
        }
      }
      out.grey.push_back(sum / pixels);
      out.changed.push_back(changed);
    }
  }
  return out;
}

// The mean absolute difference between a decoded JPEG and the grey levels it should show.
double meanAbsoluteDifference(const cv::Mat& picture, const std::vector<double>& expected) {
  double total = 0;
  for (int y = 0; y < picture.rows; ++y) {
    for (int x = 0; x < picture.cols; ++x) {
      total += std::abs(picture.at<std::uint8_t>(y, x) -
                        expected[static_cast<std::size_t>(y * picture.cols + x)]);
    }
  }
  return total / static_cast<double>(expected.size());
}

cv::Mat decodeJpeg(const occmap::camera_preview_t& preview) {
  return cv::imdecode(preview.jpeg, cv::IMREAD_UNCHANGED);
}

// A preview as the test's own program heard it: its bytes, and when (host time, us).
struct Heard {
  std::vector<std::uint8_t> bytes;
  std::int64_t heard_us = 0;
};

// The daemon's pipeline on the simulated room, and a program of the test's on the same bus that
// hears its previews and maps and sends requests.
class PreviewRun {
 public:
  explicit PreviewRun(std::chrono::milliseconds preview_for)
      : config_(loadConfig(folder_.write("room.yaml", testing::simRoomConfig()))),
        listener_(network_) {
    listener_.subscribe(kPreviewChannel, [this](const std::uint8_t* data, std::size_t size) {
      const std::lock_guard lock(mutex_);
      heard_.push_back({std::vector<std::uint8_t>(data, data + size), hostTimeMicroseconds()});
    });
    listener_.subscribe("OCCMAP_MAP", [this](const std::uint8_t* data, std::size_t size) {
      const DecodedMap& map = decoder_.decode(data, size);
      const std::lock_guard lock(mutex_);
      if (map.ok()) newest_map_us_ = std::max(newest_map_us_, map.utime);
    });
    listener_.start();
    PipelineOptions options;
    options.preview_for = preview_for;
    pipeline_ = std::make_unique<Pipeline>(prepareRig(config_), network_.connect(), options);
    pipeline_->start();
  }
  ~PreviewRun() { stop(); }

  const Config& config() const { return config_; }
  Pipeline& pipeline() { return *pipeline_; }
  void ask(const std::string& camera) {
    listener_.send(kRequestChannel, encodeCameraPreviewRequest(hostTimeMicroseconds(), camera));
  }
  // Waits until a map of frames captured at `utime` or later has come: the stream's own time,
  // however slowly a sanitizer makes it pass. False when it did not within the deadline.
  bool waitForMapsPast(std::int64_t utime) {
    return waitFor([&] { return newest_map_us_ >= utime; });
  }
  template <typename Condition>
  bool waitFor(Condition condition) {
    const auto deadline =
        std::chrono::steady_clock::now() + testing::eventually(std::chrono::seconds(30));
    while (std::chrono::steady_clock::now() < deadline) {
      {
        const std::lock_guard lock(mutex_);
        if (condition()) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }
  std::vector<Heard> heard() {
    const std::lock_guard lock(mutex_);
    return heard_;
  }
  // For waitFor's conditions, which run under the lock.
  const std::vector<Heard>& heardLocked() const { return heard_; }
  // Stops the pipeline, then the listener, which hears all that was sent.
  void stop() {
    if (pipeline_) pipeline_->stop();
    listener_.stop();
  }

 private:
  TemporaryFolder folder_;
  Config config_;
  MemoryNetwork network_;
  BusListener listener_;
  std::mutex mutex_;
  std::vector<Heard> heard_;
  std::int64_t newest_map_us_ = 0;
  MapDecoder decoder_;  // the listener's thread only
  std::unique_ptr<Pipeline> pipeline_;
};

// Camera c1's frames replayed off-line from the first on, as its capture thread saw them: each
// previewed frame (by sequence) and the changed pixels the pipeline marked in it.
struct Replayed {
  Image frame;
  std::vector<std::uint8_t> mask;
};

std::map<std::uint64_t, Replayed> replayCamera(std::size_t k, const std::set<std::uint64_t>& wanted,
                                               PreparedRig& replay) {
  FusionKernel kernel(replay.tables);
  RigCamera& camera = replay.rig.cameras()[k];
  ChangedPixels changed(camera.lighting, *camera.camera);
  std::map<std::uint64_t, Replayed> out;
  const std::uint64_t last = wanted.empty() ? 0 : *wanted.rbegin();
  std::vector<std::uint8_t> mask(changedMaskBytes(camera.source->width(), camera.source->height()));
  for (std::uint64_t n = 0; n <= last;) {
    Frame frame;
    const FrameSource::Status status = camera.source->read(frame);
    if (status == FrameSource::Status::kEnd && camera.source->rewind()) continue;
    if (status != FrameSource::Status::kFrame) {
      ADD_FAILURE() << "the replay of " << camera.name << " ended at frame " << n;
      break;
    }
    EXPECT_EQ(frame.sequence, n);
    changed.mark(kernel, k, frame.image, camera.background, camera.threshold, mask.data(),
                 frame.capture_time_us);
    if (wanted.count(n) != 0) {
      Replayed& kept = out[n];
      kept.frame = Image(frame.image.width, frame.image.height);
      for (int v = 0; v < frame.image.height; ++v) {
        std::memcpy(kept.frame.row(v), frame.image.row(v),
                    static_cast<std::size_t>(frame.image.width));
      }
      kept.mask = mask;
    }
    ++n;
  }
  return out;
}

// What a preview shows, against the frame it names: its JPEG is the frame scaled down, its
// changed bits the frame's changed pixels scaled down.
void expectShows(const occmap::camera_preview_t& preview, const Replayed& replayed) {
  const ByDefinition expected =
      shrinkByDefinition(replayed.frame.view(), replayed.mask.data(), preview.scale);
  ASSERT_EQ(preview.width, expected.width);
  ASSERT_EQ(preview.height, expected.height);
  const cv::Mat picture = decodeJpeg(preview);
  ASSERT_FALSE(picture.empty()) << "frame " << preview.sequence << ": the JPEG does not decode";
  ASSERT_EQ(picture.type(), CV_8UC1) << "the JPEG should be grey";
  ASSERT_EQ(picture.cols, preview.width);
  ASSERT_EQ(picture.rows, preview.height);
  // JPEG at quality 80 of the simulator's noisy frames: some 2.5 grey levels.
  EXPECT_LT(meanAbsoluteDifference(picture, expected.grey), 4.0)
      << "frame " << preview.sequence << ": the JPEG is not the frame scaled down";
  EXPECT_EQ(previewChangedPixels(preview), expected.changed)
      << "frame " << preview.sequence << ": the changed bits are not the frame's scaled down";
}

void expectCoverageOf(const occmap::camera_preview_t& preview, const CarveTable& table) {
  ASSERT_EQ(preview.map_width, table.map().width);
  ASSERT_EQ(preview.map_height, table.map().height);
  std::string error;
  const std::optional<std::vector<std::uint8_t>> coverage = previewCoverage(preview, &error);
  ASSERT_TRUE(coverage) << error;
  ASSERT_EQ(coverage->size(), table.map().cellCount());
  std::size_t wrong = 0;
  for (std::size_t cell = 0; cell < coverage->size(); ++cell) {
    wrong += ((*coverage)[cell] != 0) != table.sees(cell);
  }
  EXPECT_EQ(wrong, 0u) << preview.camera << ": cells whose coverage bit is not sees(cell)";
}

// One request for c1, then a second 1.5 s of stream time after its first preview came. occmapd
// makes previews for 10 s after the last request; the pipeline reads its clocks itself, so this
// test shortens that to 3 s (PipelineOptions::preview_for) and gives the request's way to the
// publisher a tolerance.
TEST(CameraPreview, OnlyTheCameraAskedForAtMostTwiceASecondUntilTheLastRequestRunsOut) {
  constexpr std::int64_t kPreviewForUs = 3'000'000;
  PreviewRun run(std::chrono::milliseconds(kPreviewForUs / 1000));
  const std::int64_t started = hostTimeMicroseconds();
  ASSERT_TRUE(run.waitForMapsPast(started + 1'000'000)) << "no maps from the simulated room";
  EXPECT_TRUE(run.heard().empty()) << "previews before anyone asked for them";

  run.ask("c1");
  ASSERT_TRUE(run.waitFor([&] { return !run.heardLocked().empty(); }))
      << "no preview after a request";
  // The request reached the publisher before this, the first preview, was heard: the previews it
  // asked for are of frames captured before first_heard + 3 s.
  const std::int64_t first_heard = run.heard().front().heard_us;
  ASSERT_TRUE(run.waitForMapsPast(first_heard + 1'500'000));
  const std::int64_t asked_again = hostTimeMicroseconds();
  run.ask("c1");
  // From the request's queueing here to the publisher's handling of it (plain: some 10 ms).
  const std::int64_t tolerance_us =
      std::chrono::microseconds(testing::eventually(std::chrono::milliseconds(300))).count();
  const std::int64_t last_allowed = asked_again + kPreviewForUs + tolerance_us;
  ASSERT_TRUE(run.waitForMapsPast(last_allowed + 1'000'000))
      << "the cameras should have gone on past the previews' end";
  run.stop();

  const std::vector<Heard> heard = run.heard();
  std::vector<occmap::camera_preview_t> previews;
  std::size_t largest = 0, smallest = SIZE_MAX;
  std::size_t jpeg_largest = 0;
  for (const Heard& h : heard) {
    ASSERT_LE(h.bytes.size(), kMaxPreviewMessageBytes) << "a preview larger than a datagram";
    largest = std::max(largest, h.bytes.size());
    smallest = std::min(smallest, h.bytes.size());
    std::string error;
    std::optional<occmap::camera_preview_t> preview =
        decodeCameraPreview(h.bytes.data(), h.bytes.size(), &error);
    ASSERT_TRUE(preview) << error;
    jpeg_largest = std::max(jpeg_largest, preview->jpeg.size());
    previews.push_back(std::move(*preview));
  }
  ASSERT_GE(previews.size(), 3u);
  for (std::size_t i = 0; i < previews.size(); ++i) {
    const occmap::camera_preview_t& preview = previews[i];
    EXPECT_EQ(preview.camera, "c1") << "a preview of a camera no one asked for";
    EXPECT_EQ(preview.hostname, hostName());
    EXPECT_EQ(preview.state, occmap::camera_frame_t::STATE_STREAMING);
    EXPECT_EQ(preview.stream_width, 640);
    EXPECT_EQ(preview.stream_height, 480);
    EXPECT_EQ(preview.scale, 2) << "640 pixels at most 320 wide";
    EXPECT_LT(preview.utime, last_allowed) << "a preview after the last request ran out";
    if (i > 0) {
      EXPECT_GE(preview.utime - previews[i - 1].utime, Previewer::kPeriodUs)
          << "previews " << i - 1 << " and " << i << " closer than 0.5 s of capture time";
      EXPECT_GT(preview.sequence, previews[i - 1].sequence);
    }
  }
  EXPECT_GT(previews.back().utime, first_heard + kPreviewForUs + 20'000)
      << "the second request should have made the previews last past the first one's end";
  EXPECT_EQ(run.pipeline().previewsTooLarge(), 0u);
  EXPECT_EQ(run.pipeline().previewsPublished(), previews.size());

  // What each preview shows, against camera c1's frames replayed.
  PreparedRig replay = prepareRig(run.config());
  std::set<std::uint64_t> sequences;
  for (const auto& preview : previews)
    sequences.insert(static_cast<std::uint64_t>(preview.sequence));
  const std::map<std::uint64_t, Replayed> frames = replayCamera(1, sequences, replay);
  for (const auto& preview : previews) {
    SCOPED_TRACE("frame " + std::to_string(preview.sequence));
    const auto frame = frames.find(static_cast<std::uint64_t>(preview.sequence));
    ASSERT_NE(frame, frames.end());
    expectShows(preview, frame->second);
    EXPECT_EQ(preview.coverage, previews.front().coverage) << "the coverage changed";
  }
  expectCoverageOf(previews.front(), replay.tables[1]);

  const TimeHistogram& times = run.pipeline().previewTimes();
  std::printf(
      "%zu previews of c1 (640 x 480 -> %d x %d): messages %zu to %zu bytes (JPEG up to "
      "%zu, changed bits %zu, coverage of %d x %d cells %zu); the previewer's thread "
      "p50 %.2f ms, max %.2f ms per preview\n",
      previews.size(), previews.front().width, previews.front().height, smallest, largest,
      jpeg_largest, previews.front().changed.size(), previews.front().map_width,
      previews.front().map_height, previews.front().coverage.size(), times.percentileMs(0.5),
      times.maxMs());
}

TEST(CameraPreview, ARequestForEveryCameraPreviewsEachAndOneForAnotherDaemonsCameraNone) {
  PreviewRun run(std::chrono::milliseconds(10'000));
  run.ask("not-here");
  const std::int64_t asked = hostTimeMicroseconds();
  ASSERT_TRUE(run.waitForMapsPast(asked + 1'000'000));
  EXPECT_TRUE(run.heard().empty()) << "previews for a camera this daemon does not have";

  run.ask("");
  auto camerasHeard = [](const std::vector<Heard>& heard) {
    std::set<std::string> names;
    for (const Heard& h : heard) {
      if (auto preview = decodeCameraPreview(h.bytes.data(), h.bytes.size())) {
        names.insert(preview->camera);
      }
    }
    return names;
  };
  EXPECT_TRUE(run.waitFor([&] { return camerasHeard(run.heardLocked()).size() == 4; }))
      << "a request for every camera should bring previews of all four";
  run.stop();
  PreparedRig replay = prepareRig(run.config());
  std::map<std::string, std::int64_t> last_utime;
  std::set<std::string> covered;
  for (const Heard& h : run.heard()) {
    ASSERT_LE(h.bytes.size(), kMaxPreviewMessageBytes);
    std::string error;
    const auto preview = decodeCameraPreview(h.bytes.data(), h.bytes.size(), &error);
    ASSERT_TRUE(preview) << error;
    if (last_utime.count(preview->camera) != 0) {
      EXPECT_GE(preview->utime - last_utime[preview->camera], Previewer::kPeriodUs)
          << preview->camera;
    }
    last_utime[preview->camera] = preview->utime;
    const auto k = static_cast<std::size_t>(preview->camera.back() - '0');
    if (covered.insert(preview->camera).second) expectCoverageOf(*preview, replay.tables[k]);
  }
  EXPECT_EQ(covered, (std::set<std::string>{"c0", "c1", "c2", "c3"}));
}

// ---------------------------------------------------------------------------------------------
// The previewer without its thread, time passed in.

// A carve table over a map of width x height cells for a stream of 640 x 480 pixels, that sees a
// cell when `sees` says so (its pixels are not looked at by the previewer).
template <typename Sees>
CarveTable tableSeeing(int width, int height, Sees sees) {
  const MapGeometry map{-1.0, -1.0, 0.05, width, height};
  std::vector<std::uint32_t> offsets{0};
  std::vector<std::uint32_t> pixels;
  for (std::size_t cell = 0; cell < map.cellCount(); ++cell) {
    if (sees(cell)) pixels.push_back(0);
    offsets.push_back(static_cast<std::uint32_t>(pixels.size()));
  }
  return CarveTable(CarveRule::kAnyPixel, map, 640, 480, std::move(offsets), std::move(pixels));
}

// A 640 x 480 picture with smooth shading and some edges, and a changed mask with a few blobs.
struct TestFrame {
  Image image{640, 480};
  std::vector<std::uint8_t> mask = std::vector<std::uint8_t>(changedMaskBytes(640, 480), 0);
  TestFrame() {
    for (int v = 0; v < 480; ++v) {
      for (int u = 0; u < 640; ++u) {
        const bool box = u > 200 && u < 300 && v > 100 && v < 400;
        image.at(u, v) = static_cast<std::uint8_t>(box ? 30 : 60 + (u + v) / 8);
      }
    }
    std::mt19937 random(7);
    for (int blob = 0; blob < 20; ++blob) {
      const int cx = static_cast<int>(random() % 640), cy = static_cast<int>(random() % 480);
      for (int v = std::max(0, cy - 6); v < std::min(480, cy + 6); ++v) {
        for (int u = std::max(0, cx - 9); u < std::min(640, cx + 9); ++u) {
          const std::size_t word =
              static_cast<std::size_t>(v / 8) * tilesAcross(640) + static_cast<std::size_t>(u / 8);
          mask[word * 8 + static_cast<std::size_t>(v % 8)] |=
              static_cast<std::uint8_t>(1u << (u % 8));
        }
      }
    }
  }
};

TEST(Previewer, IsDueOnlyWhileAskedForAndAtMostTwiceASecondOfCaptureTime) {
  const std::vector<std::string> names{"a", "b"};
  std::vector<CarveTable> tables;
  tables.push_back(tableSeeing(8, 8, [](std::size_t) { return true; }));
  tables.push_back(tableSeeing(8, 8, [](std::size_t) { return true; }));
  Previewer previewer("host", names, tables, std::chrono::seconds(10));
  constexpr std::int64_t kS = 1'000'000'000;  // ns
  constexpr std::int64_t kUs = 1'000'000;     // us in a second
  const std::int64_t t0 = 1'700'000'000'000'000;
  EXPECT_FALSE(previewer.due(0, 100 * kS, t0)) << "due before any request";
  EXPECT_FALSE(previewer.requested("c", 100 * kS)) << "a camera of another daemon";
  EXPECT_FALSE(previewer.due(0, 100 * kS, t0));
  EXPECT_TRUE(previewer.requested("a", 100 * kS));
  EXPECT_FALSE(previewer.due(1, 100 * kS, t0)) << "b was not asked for";
  EXPECT_TRUE(previewer.due(0, 100 * kS, t0));
  EXPECT_FALSE(previewer.due(0, 100 * kS, t0 + kUs / 2 - 1)) << "within 0.5 s of the last";
  EXPECT_TRUE(previewer.due(0, 100 * kS, t0 + kUs / 2));
  EXPECT_TRUE(previewer.due(0, 100 * kS, t0 - 5 * kUs)) << "capture time went back: starts over";
  EXPECT_FALSE(previewer.due(0, 110 * kS, t0 + 60 * kUs)) << "10 s after the request";
  EXPECT_TRUE(previewer.requested("", 115 * kS)) << "every camera";
  EXPECT_TRUE(previewer.due(0, 124 * kS, t0 + 61 * kUs));
  EXPECT_TRUE(previewer.due(1, 124 * kS, t0 + 61 * kUs));
  EXPECT_FALSE(previewer.due(1, 125 * kS, t0 + 62 * kUs));
}

// Sends what the previewer made of one frame of camera 0 (asked for at time 0).
std::optional<occmap::camera_preview_t> previewOf(Previewer& previewer, const TestFrame& frame) {
  previewer.requested("", 0);
  EXPECT_TRUE(previewer.due(0, 0, 1'000));
  previewer.offer(0, frame.image.view(), frame.mask.data(), 17, 1'000, CameraState::kStreaming);
  previewer.makeNewest();
  const std::vector<std::uint8_t>* bytes = previewer.takeMessage(0);
  if (bytes == nullptr) return std::nullopt;
  EXPECT_LE(bytes->size(), kMaxPreviewMessageBytes);
  std::string error;
  auto preview = decodeCameraPreview(bytes->data(), bytes->size(), &error);
  EXPECT_TRUE(preview) << error;
  return preview;
}

TEST(Previewer, AMessageIsTheFrameScaledDownAndTheTablesCoverage) {
  const std::vector<std::string> names{"a"};
  std::vector<CarveTable> tables;
  tables.push_back(tableSeeing(100, 60, [](std::size_t cell) { return cell % 100 < 37; }));
  Previewer previewer("host", names, tables, std::chrono::seconds(10));
  const TestFrame frame;
  const auto preview = previewOf(previewer, frame);
  ASSERT_TRUE(preview);
  EXPECT_EQ(preview->scale, 2);
  EXPECT_EQ(preview->sequence, 17);
  EXPECT_EQ(preview->utime, 1'000);
  Replayed replayed{frame.image, frame.mask};
  expectShows(*preview, replayed);
  expectCoverageOf(*preview, tables[0]);
  EXPECT_EQ(previewer.made(), 1u);
  EXPECT_EQ(previewer.takeMessage(0), nullptr) << "a message is handed over once";
}

// A coverage of some 51 KB (every cell a coin toss: zstd cannot shrink it) leaves a 320 x 240
// preview too little room: the previewer halves it, to 160 x 120, which fits.
TEST(Previewer, AMessageTooLargeIsMadeCoarserUntilItFits) {
  const std::vector<std::string> names{"a"};
  std::vector<CarveTable> tables;
  std::mt19937 random(3);
  tables.push_back(tableSeeing(640, 640, [&](std::size_t) { return (random() & 1u) != 0; }));
  Previewer previewer("host", names, tables, std::chrono::seconds(10));
  const TestFrame frame;
  const auto preview = previewOf(previewer, frame);
  ASSERT_TRUE(preview) << "the preview should fit once coarser";
  EXPECT_EQ(preview->scale, 4);
  EXPECT_EQ(preview->width, 160);
  EXPECT_EQ(preview->height, 120);
  const Replayed replayed{frame.image, frame.mask};
  expectShows(*preview, replayed);
  expectCoverageOf(*preview, tables[0]);
  EXPECT_EQ(previewer.tooLarge(), 0u);
}

TEST(Previewer, AMessageThatNeverFitsIsCountedAndNotSent) {
  const std::vector<std::string> names{"a"};
  std::vector<CarveTable> tables;
  std::mt19937 random(5);
  tables.push_back(tableSeeing(800, 800, [&](std::size_t) { return (random() & 1u) != 0; }));
  Previewer previewer("host", names, tables, std::chrono::seconds(10));
  const TestFrame frame;
  EXPECT_FALSE(previewOf(previewer, frame)) << "an 80 KB coverage cannot fit";
  EXPECT_EQ(previewer.tooLarge(), 1u);
  EXPECT_EQ(previewer.made(), 0u);
}

TEST(Previewer, ShrinksAndHalvesStreamsOfAnySizeByTheDefinition) {
  // 651 x 37: the last column and row of each scale cut at the stream's edge.
  Image image(651, 37);
  std::vector<std::uint8_t> mask(changedMaskBytes(651, 37), 0);
  std::mt19937 random(11);
  for (int v = 0; v < 37; ++v) {
    for (int u = 0; u < 651; ++u) image.at(u, v) = static_cast<std::uint8_t>(random() % 256);
  }
  for (std::uint8_t& byte : mask) byte = static_cast<std::uint8_t>(random() % 13 == 0 ? 0x10 : 0);
  const int scale = previewScale(651);
  ASSERT_EQ(scale, 3);
  PreviewFrame shrunk;
  shrunk.grey.resize(217 * 13);
  shrunk.changed.resize(217 * 13);
  std::vector<std::uint32_t> sums(651);
  shrinkForPreview(image.view(), mask.data(), scale, sums, shrunk);
  const ByDefinition expected = shrinkByDefinition(image.view(), mask.data(), scale);
  ASSERT_EQ(shrunk.width, 217);
  ASSERT_EQ(shrunk.height, 13);
  for (std::size_t i = 0; i < expected.grey.size(); ++i) {
    ASSERT_LE(std::abs(shrunk.grey[i] - expected.grey[i]), 0.5) << "pixel " << i;
    ASSERT_EQ(shrunk.changed[i], expected.changed[i]) << "pixel " << i;
  }
  PreviewFrame halved;
  halved.grey.resize(shrunk.grey.size());
  halved.changed.resize(shrunk.changed.size());
  halvePreview(shrunk, halved);
  const ByDefinition coarser = shrinkByDefinition(image.view(), mask.data(), 2 * scale);
  ASSERT_EQ(halved.width, coarser.width);
  ASSERT_EQ(halved.height, coarser.height);
  for (std::size_t i = 0; i < coarser.grey.size(); ++i) {
    // The mean of rounded means: within a grey level of the exact one.
    ASSERT_LE(std::abs(halved.grey[i] - coarser.grey[i]), 1.0) << "pixel " << i;
    ASSERT_EQ(halved.changed[i], coarser.changed[i]) << "pixel " << i;
  }
}

// ---------------------------------------------------------------------------------------------
// The messages from the network.

TEST(CameraPreviewMessage, BitsArePackedMostSignificantFirst) {
  const std::vector<std::uint8_t> values{1, 0, 0, 0, 0, 0, 0, 1, 1, 0, 1};
  std::vector<std::uint8_t> packed(packedBytes(values.size()));
  packBits(values, packed);
  EXPECT_EQ(packed, (std::vector<std::uint8_t>{0x81, 0xA0}));
  EXPECT_EQ(unpackBits(packed, values.size()), values);
  EXPECT_TRUE(unpackBits(packed, 17).empty()) << "17 bits from 2 bytes";
}

TEST(CameraPreviewMessage, RequestsDecodeToTheirCameraAndAnythingElseToNothing) {
  const std::vector<std::uint8_t> one = encodeCameraPreviewRequest(5, "c2");
  ASSERT_TRUE(decodeCameraPreviewRequest(one.data(), one.size()));
  EXPECT_EQ(*decodeCameraPreviewRequest(one.data(), one.size()), "c2");
  const std::vector<std::uint8_t> all = encodeCameraPreviewRequest(5, "");
  ASSERT_TRUE(decodeCameraPreviewRequest(all.data(), all.size()));
  EXPECT_EQ(*decodeCameraPreviewRequest(all.data(), all.size()), "");
  for (std::size_t size = 0; size < one.size(); ++size) {
    EXPECT_FALSE(decodeCameraPreviewRequest(one.data(), size)) << "truncated to " << size;
  }
  std::vector<std::uint8_t> longer = one;
  longer.push_back(0);
  EXPECT_FALSE(decodeCameraPreviewRequest(longer.data(), longer.size())) << "a trailing byte";
  std::vector<std::uint8_t> lying = one;
  lying[8 + 8 + 3] = 0x7F;  // the name's length, far past the end
  EXPECT_FALSE(decodeCameraPreviewRequest(lying.data(), lying.size()));
  occmap::status_request_t status{};
  std::vector<std::uint8_t> other(static_cast<std::size_t>(status.getEncodedSize()));
  status.encode(other.data(), 0, static_cast<int>(other.size()));
  EXPECT_FALSE(decodeCameraPreviewRequest(other.data(), other.size())) << "another type";
  EXPECT_FALSE(decodeCameraPreviewRequest(nullptr, 0));
}

// A well-formed preview: a 700 x 96 stream at scale 3, 234 x 32; a 40 x 30 map.
occmap::camera_preview_t samplePreview() {
  occmap::camera_preview_t preview{};
  preview.utime = 1'700'000'000'000'000;
  preview.sequence = 99;
  preview.hostname = "camera-pc";
  preview.camera = "c0";
  preview.state = occmap::camera_frame_t::STATE_STREAMING;
  preview.stream_width = 700;
  preview.stream_height = 96;
  preview.scale = previewScale(700);
  preview.width = 234;
  preview.height = 32;
  cv::Mat grey(32, 234, CV_8UC1);
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 234; ++x) grey.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(x + y);
  }
  cv::imencode(".jpg", grey, preview.jpeg);
  preview.jpeg_size = static_cast<std::int32_t>(preview.jpeg.size());
  preview.changed.assign(packedBytes(234 * 32), 0x5A);
  preview.changed_size = static_cast<std::int32_t>(preview.changed.size());
  preview.map_width = 40;
  preview.map_height = 30;
  preview.coverage = compressCoverage(std::vector<std::uint8_t>(packedBytes(40 * 30), 0xF0));
  preview.coverage_size = static_cast<std::int32_t>(preview.coverage.size());
  return preview;
}

std::vector<std::uint8_t> bytesOf(const occmap::camera_preview_t& preview) {
  std::vector<std::uint8_t> bytes;
  encodeCameraPreview(preview, bytes);
  return bytes;
}

// Where the int32 jpeg_size of samplePreview()'s bytes is.
std::size_t jpegSizeOffset(const occmap::camera_preview_t& preview) {
  return 8 + 8 + 8 + 4 + preview.hostname.size() + 1 + 4 + preview.camera.size() + 1 + 1 + 5 * 4;
}

void putInt32(std::vector<std::uint8_t>& bytes, std::size_t at, std::int32_t value) {
  const auto bits = static_cast<std::uint32_t>(value);
  for (int i = 0; i < 4; ++i) {
    bytes[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(bits >> (24 - 8 * i));
  }
}

std::string refusal(const std::vector<std::uint8_t>& bytes) {
  std::string error;
  if (decodeCameraPreview(bytes.data(), bytes.size(), &error)) return "";
  EXPECT_FALSE(error.empty()) << "refused without a reason";
  return error;
}

TEST(CameraPreviewMessage, AWellFormedPreviewDecodesWithItsBitsAndCoverage) {
  const occmap::camera_preview_t sample = samplePreview();
  const std::vector<std::uint8_t> bytes = bytesOf(sample);
  std::string error;
  const auto preview = decodeCameraPreview(bytes.data(), bytes.size(), &error);
  ASSERT_TRUE(preview) << error;
  EXPECT_EQ(preview->camera, "c0");
  EXPECT_EQ(preview->jpeg, sample.jpeg);
  const std::vector<std::uint8_t> changed = previewChangedPixels(*preview);
  EXPECT_EQ(preview->scale, 3);
  ASSERT_EQ(changed.size(), 234u * 32u);
  EXPECT_EQ(changed[0], 0);  // 0x5A: 0101 1010
  EXPECT_EQ(changed[1], 1);
  const auto coverage = previewCoverage(*preview, &error);
  ASSERT_TRUE(coverage) << error;
  ASSERT_EQ(coverage->size(), 1200u);
  EXPECT_EQ((*coverage)[0], 1);  // 0xF0
  EXPECT_EQ((*coverage)[4], 0);
}

TEST(CameraPreviewMessage, TruncatedAndLyingMessagesAreRefusedWithAReason) {
  const occmap::camera_preview_t sample = samplePreview();
  const std::vector<std::uint8_t> bytes = bytesOf(sample);
  for (std::size_t size = 0; size < bytes.size(); ++size) {
    const std::vector<std::uint8_t> cut(bytes.begin(),
                                        bytes.begin() + static_cast<std::ptrdiff_t>(size));
    ASSERT_FALSE(refusal(cut).empty()) << "truncated to " << size << " bytes";
  }
  std::vector<std::uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_NE(refusal(longer).find("left over"), std::string::npos) << refusal(longer);

  // Counts that lie about the bytes.
  const std::size_t jpeg_size_at = jpegSizeOffset(sample);
  std::vector<std::uint8_t> lying = bytes;
  putInt32(lying, jpeg_size_at, sample.jpeg_size + 1000);
  EXPECT_NE(refusal(lying).find("jpeg_size is more than"), std::string::npos) << refusal(lying);
  putInt32(lying, jpeg_size_at, -1);
  EXPECT_NE(refusal(lying).find("jpeg_size is negative"), std::string::npos) << refusal(lying);
  lying = bytes;
  putInt32(lying, jpeg_size_at + 4 + sample.jpeg.size(), INT32_MIN);
  EXPECT_NE(refusal(lying).find("changed_size is negative"), std::string::npos) << refusal(lying);
  lying = bytes;
  putInt32(lying, 8 + 8 + 8, 1 << 30);  // the hostname's length
  EXPECT_NE(refusal(lying).find("string"), std::string::npos) << refusal(lying);

  // Figures that disagree, in messages whose counts add up.
  auto refusedFor = [](occmap::camera_preview_t preview) { return refusal(bytesOf(preview)); };
  occmap::camera_preview_t wrong = sample;
  wrong.width = 235;
  EXPECT_NE(refusedFor(wrong).find("not the stream's at the scale"), std::string::npos);
  wrong = sample;
  wrong.scale = 0;
  EXPECT_NE(refusedFor(wrong).find("scale"), std::string::npos);
  wrong = sample;
  wrong.changed.pop_back();
  wrong.changed_size -= 1;
  EXPECT_NE(refusedFor(wrong).find("changed_size is not"), std::string::npos);
  wrong = sample;
  wrong.state = 7;
  EXPECT_NE(refusedFor(wrong).find("state"), std::string::npos);
  wrong = sample;
  wrong.jpeg[0] = 0;
  EXPECT_NE(refusedFor(wrong).find("JPEG"), std::string::npos);
  wrong = sample;
  wrong.map_width = 9000;
  EXPECT_NE(refusedFor(wrong).find("8192"), std::string::npos);
  wrong = sample;
  wrong.stream_height = 0;
  EXPECT_NE(refusedFor(wrong).find("stream"), std::string::npos);

  occmap::status_request_t other{};
  std::vector<std::uint8_t> other_bytes(static_cast<std::size_t>(other.getEncodedSize()));
  other.encode(other_bytes.data(), 0, static_cast<int>(other_bytes.size()));
  EXPECT_NE(refusal(other_bytes).find("fingerprint"), std::string::npos);
  std::string error;
  EXPECT_FALSE(decodeCameraPreview(nullptr, 0, &error));
  EXPECT_FALSE(error.empty());
}

TEST(CameraPreviewMessage, ACoverageThatIsNotTheMapsBitsIsRefusedWithAReason) {
  auto refusedCoverage = [](std::vector<std::uint8_t> coverage) {
    occmap::camera_preview_t preview = samplePreview();
    preview.coverage = std::move(coverage);
    preview.coverage_size = static_cast<std::int32_t>(preview.coverage.size());
    const std::vector<std::uint8_t> bytes = bytesOf(preview);
    std::string error;
    const auto decoded = decodeCameraPreview(bytes.data(), bytes.size(), &error);
    EXPECT_TRUE(decoded) << "the message itself is sound: " << error;
    if (!decoded) return std::string("not decoded");
    const auto cells = previewCoverage(*decoded, &error);
    EXPECT_FALSE(cells) << "a coverage that is not the map's bits";
    EXPECT_FALSE(error.empty());
    return error;
  };
  // 40 x 30 cells are 150 bytes of bits.
  EXPECT_NE(refusedCoverage(compressCoverage(std::vector<std::uint8_t>(149, 0xFF))).find("size"),
            std::string::npos);
  EXPECT_NE(refusedCoverage(compressCoverage(std::vector<std::uint8_t>(1 << 20, 0))).find("size"),
            std::string::npos)
      << "a small frame that would inflate to a megabyte";
  EXPECT_NE(refusedCoverage({1, 2, 3, 4, 5, 6, 7, 8}).find("not a zstd frame"), std::string::npos);
  std::vector<std::uint8_t> trailing = compressCoverage(std::vector<std::uint8_t>(150, 0xFF));
  trailing.push_back(0);
  EXPECT_NE(refusedCoverage(trailing).find("after"), std::string::npos);
  std::vector<std::uint8_t> corrupt = compressCoverage(std::vector<std::uint8_t>(150, 0x3C));
  corrupt.pop_back();
  EXPECT_FALSE(refusedCoverage(corrupt).empty());
}

}  // namespace
}  // namespace occmap
