// The V4L2 backend (v4l2:///dev/videoN, capture/v4l2_source.cpp) through tests/v4l2_shim: no
// kernel video device can exist on the machines these tests run on, so CTest preloads a capture
// device made of memory that answers the driver's ioctls and draws a known picture. Every pixel
// of the frames read is checked against that picture. Without the shim the tests skip, saying why.
//
// V4l2Daemon runs occmapd itself on such a camera and asks `occmap status` over LCM, inside a
// private network namespace (skipped where none can be made); CTest runs it as v4l2_daemon_test.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <dlfcn.h>
#include <gtest/gtest.h>

#include "base/clock.h"
#include "capture/live_source.h"
#include "child_process.h"
#include "network_namespace.h"
#include "notify_listener.h"
#include "temporary_folder.h"
#include "timing.h"
#include "v4l2_shim/v4l2_shim.h"

namespace occmap {
namespace {

using namespace std::chrono_literals;
using Status = FrameSource::Status;
using testing::TemporaryFolder;
namespace shim = v4l2_shim;

constexpr const char* kDevice = "/dev/video42";

std::string shimMissing() {
#ifdef OCCMAP_V4L2_SHIM_MISSING
  return OCCMAP_V4L2_SHIM_MISSING;
#else
  if (::dlsym(RTLD_DEFAULT, shim::kLoadedSymbol) == nullptr) {
    return "the V4L2 test shim is not loaded: run the test through CTest, which preloads "
           "liboccmap_v4l2_shim.so (LD_PRELOAD)";
  }
  return "";
#endif
}

const char* statusName(Status status) {
  switch (status) {
    case Status::kFrame:
      return "kFrame";
    case Status::kEnd:
      return "kEnd";
    case Status::kError:
      return "kError";
    case Status::kTimeout:
      return "kTimeout";
    case Status::kLost:
      return "kLost";
  }
  return "?";
}

LiveSourceOptions sized(int width, int height, double fps = 0,
                        std::vector<std::pair<std::string, std::string>> settings = {}) {
  LiveSourceOptions options;
  options.width = width;
  options.height = height;
  options.fps = fps;
  options.settings = std::move(settings);
  options.name = "usb0";
  return options;
}

// Reads past timeouts until something else comes, for at most `limit`.
Status readPastTimeouts(FrameSource& source, Frame& frame,
                        std::chrono::milliseconds limit = 3000ms) {
  const auto end = std::chrono::steady_clock::now() + limit;
  Status status = Status::kTimeout;
  while (status == Status::kTimeout && std::chrono::steady_clock::now() < end) {
    status = source.read(frame);
  }
  return status;
}

// Every pixel of `frame` is the shim's picture of frame `number` at that gain.
::testing::AssertionResult showsPattern(const Frame& frame, std::uint64_t number, int gain) {
  for (int v = 0; v < frame.image.height; ++v) {
    for (int u = 0; u < frame.image.width; ++u) {
      const int expected = shim::patternLuminance(number, u, v, gain);
      const int got = frame.image.at(u, v);
      if (got != expected) {
        return ::testing::AssertionFailure()
               << "pixel (" << u << ", " << v << ") of frame " << number << " is " << got
               << ", not " << expected << " (the device's picture at gain " << gain << ")"
               << (got == shim::kPaddingByte ? " (a padding byte read as a pixel)"
                   : got == shim::kChromaU || got == shim::kChromaV
                       ? " (a chroma byte read as luminance)"
                       : "");
      }
    }
  }
  return ::testing::AssertionSuccess();
}

// How far the wall clock is ahead of the monotonic one, now. The source stamps a frame with the
// driver's monotonic time plus this offset taken as it reads, so a wall clock that is slewed or
// stepped (NTP, a VM's host: this test's CI machine slews it by 0.5 %) moves the stamps with it.
std::int64_t wallAheadOfMonotonicUs() {
  timespec wall{}, monotonic{};
  ::clock_gettime(CLOCK_REALTIME, &wall);
  ::clock_gettime(CLOCK_MONOTONIC, &monotonic);
  return (wall.tv_sec - monotonic.tv_sec) * 1'000'000LL + (wall.tv_nsec - monotonic.tv_nsec) / 1000;
}

// The driver's own interval between two frames: their wall-clock stamps less what the wall clock
// moved against the monotonic clock between the two reads.
double driverIntervalUs(const Frame& first, std::int64_t first_offset_us, const Frame& second,
                        std::int64_t second_offset_us) {
  return static_cast<double>((second.capture_time_us - second_offset_us) -
                             (first.capture_time_us - first_offset_us));
}

class V4l2Backend : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::string why = shimMissing(); !why.empty()) {
      std::fprintf(stderr, "SKIPPING the V4L2 backend tests: %s\n", why.c_str());
      GTEST_SKIP() << why;
    }
    // Each test plugs in a device of its own: the shim reads these when the device is opened.
    ::setenv(shim::kDeviceVariable, kDevice, 1);
    ::setenv(shim::kUnplugFileVariable, unplug_file_.c_str(), 1);
    ::setenv(shim::kStallFileVariable, stall_file_.c_str(), 1);
    for (const char* name :
         {shim::kFormatsVariable, shim::kSizesVariable, shim::kPaddingVariable,
          shim::kRatesVariable, shim::kErrorEveryVariable, shim::kNoStreamingVariable}) {
      ::unsetenv(name);
    }
  }

  std::unique_ptr<FrameSource> open(const LiveSourceOptions& options) {
    error_.clear();
    return openV4l2Source(kDevice, options, error_);
  }
  void unplug() const { std::ofstream(unplug_file_) << "gone\n"; }
  void replug() const { std::filesystem::remove(unplug_file_); }
  void stall() const { std::ofstream(stall_file_) << "stalled\n"; }
  void unstall() const { std::filesystem::remove(stall_file_); }

  TemporaryFolder folder_;
  std::filesystem::path unplug_file_ = folder_ / "unplugged";
  std::filesystem::path stall_file_ = folder_ / "stalled";
  std::string error_;
};

TEST_F(V4l2Backend, NegotiatesGreyAtTheBackgroundsSizeAndHonoursPaddedRows) {
  ::setenv(shim::kPaddingVariable, "24", 1);
  auto source = open(sized(320, 240, 60));
  ASSERT_TRUE(source) << error_;
  EXPECT_TRUE(source->isLive());
  EXPECT_EQ(source->width(), 320);
  EXPECT_EQ(source->height(), 240);
  for (int k = 0; k < 5; ++k) {
    Frame frame;
    ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
    EXPECT_EQ(frame.image.width, 320);
    EXPECT_EQ(frame.image.height, 240);
    // Rows 320 + 24 bytes apart: the frame is the driver's buffer itself, padding and all.
    EXPECT_EQ(frame.image.stride, 344) << "GREY frames are read in place, rows bytesperline apart";
    EXPECT_TRUE(showsPattern(frame, frame.sequence, shim::kGainDefault));
  }
}

TEST_F(V4l2Backend, TakesTheDevicesOwnSizeWhenNoneIsAsked) {
  auto source = open(sized(0, 0));
  ASSERT_TRUE(source) << error_;
  EXPECT_EQ(source->width(), 640);
  EXPECT_EQ(source->height(), 480);
  Frame frame;
  ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
  EXPECT_TRUE(showsPattern(frame, frame.sequence, shim::kGainDefault));
}

TEST_F(V4l2Backend, ReducesYuyvToItsLuminanceExactly) {
  ::setenv(shim::kFormatsVariable, "YUYV", 1);
  ::setenv(shim::kPaddingVariable, "8", 1);
  auto source = open(sized(320, 240, 60));
  ASSERT_TRUE(source) << error_;
  for (int k = 0; k < 5; ++k) {
    Frame frame;
    ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
    EXPECT_EQ(frame.image.stride, 320) << "YUYV frames are reduced into a packed luminance image";
    EXPECT_TRUE(showsPattern(frame, frame.sequence, shim::kGainDefault));
  }
}

TEST_F(V4l2Backend, PrefersGreyAndTakesYuyvWhenThePixelFormatSettingSaysSo) {
  ::setenv(shim::kFormatsVariable, "YUYV,GREY", 1);
  ::setenv(shim::kPaddingVariable, "8", 1);
  {
    auto grey = open(sized(320, 240));
    ASSERT_TRUE(grey) << error_;
    Frame frame;
    ASSERT_EQ(readPastTimeouts(*grey, frame), Status::kFrame) << grey->lastError();
    EXPECT_EQ(frame.image.stride, 328) << "GREY is chosen when offered, whatever its place";
    EXPECT_TRUE(showsPattern(frame, frame.sequence, shim::kGainDefault));
  }
  auto yuyv = open(sized(320, 240, 0, {{"pixel_format", "yuyv"}}));
  ASSERT_TRUE(yuyv) << error_;
  Frame frame;
  ASSERT_EQ(readPastTimeouts(*yuyv, frame), Status::kFrame) << yuyv->lastError();
  EXPECT_EQ(frame.image.stride, 320) << "pixel_format: yuyv gives YUYV reduced to luminance";
  EXPECT_TRUE(showsPattern(frame, frame.sequence, shim::kGainDefault));
}

TEST_F(V4l2Backend, WhatTheDeviceCannotDoIsAConfigErrorSayingWhat) {
  ::setenv(shim::kSizesVariable, "640x480,320x240", 1);
  EXPECT_FALSE(open(sized(800, 600)));
  EXPECT_NE(error_.find("800x600"), std::string::npos) << error_;
  EXPECT_NE(error_.find("640x480"), std::string::npos) << "the size the driver gives: " << error_;
  EXPECT_NE(error_.find(kDevice), std::string::npos) << error_;

  EXPECT_FALSE(open(sized(320, 240, 0, {{"pixel_format", "MJPG"}})));
  EXPECT_NE(error_.find("GREY or YUYV"), std::string::npos) << error_;

  ::setenv(shim::kFormatsVariable, "GREY", 1);
  EXPECT_FALSE(open(sized(320, 240, 0, {{"pixel_format", "YUYV"}})));
  EXPECT_NE(error_.find("offers GREY"), std::string::npos) << error_;

  ::setenv(shim::kFormatsVariable, "MJPG,H264", 1);
  EXPECT_FALSE(open(sized(320, 240)));
  EXPECT_NE(error_.find("MJPG, H264"), std::string::npos) << "the formats it has: " << error_;

  ::unsetenv(shim::kFormatsVariable);
  ::setenv(shim::kNoStreamingVariable, "1", 1);
  EXPECT_FALSE(open(sized(320, 240)));
  EXPECT_NE(error_.find("cannot stream"), std::string::npos) << error_;
}

TEST_F(V4l2Backend, AnUnknownControlIsAConfigErrorListingTheDevicesControls) {
  EXPECT_FALSE(open(sized(320, 240, 0, {{"Brightness", "10"}})));
  EXPECT_NE(error_.find("'Brightness'"), std::string::npos) << error_;
  EXPECT_NE(error_.find("gain"), std::string::npos) << error_;
  EXPECT_NE(error_.find("exposure_time_absolute"), std::string::npos) << error_;
  EXPECT_EQ(error_.find("user_controls"), std::string::npos)
      << "control classes are headings, not controls: " << error_;

  EXPECT_FALSE(open(sized(320, 240, 0, {{"gain", "500"}})));
  EXPECT_NE(error_.find("0 to 100"), std::string::npos) << "the device's range: " << error_;
  EXPECT_FALSE(open(sized(320, 240, 0, {{"gain", "high"}})));
  EXPECT_NE(error_.find("'high' is not a whole number"), std::string::npos) << error_;
}

TEST_F(V4l2Backend, ControlsAreMatchedByNameInAnySpellingAndApplied) {
  for (const std::string name : {"Gain", "gain", "GAIN"}) {
    auto source = open(sized(320, 240, 0,
                             {{name, "40"},
                              {"Exposure Time, Absolute", "500"},
                              {"ExposureTimeAbsolute", "600"},
                              {"exposure_time_absolute", "700"}}));
    ASSERT_TRUE(source) << name << ": " << error_;
    Frame frame;
    ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
    EXPECT_TRUE(showsPattern(frame, frame.sequence, 40)) << "the device draws with its gain";
  }
}

TEST_F(V4l2Backend, SaysWhichRateAndValuesTheDriverAdjusted) {
  ::setenv(shim::kRatesVariable, "30,60", 1);
  LiveSourceOptions options = sized(320, 240, 50, {{"exposure_time_absolute", "505"}});
  std::vector<std::string> notices;
  options.notice = [&](const std::string& message) { notices.push_back(message); };
  auto source = open(options);
  ASSERT_TRUE(source) << error_;
  std::string all;
  for (const std::string& notice : notices) all += notice + "\n";
  EXPECT_NE(all.find("camera usb0: /dev/video42: runs at 60 fps, the nearest it can do to the 50 "
                     "asked"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("control exposure_time_absolute = 505 became 501"), std::string::npos) << all;
  // And 60 it is: the driver's timestamps are 1/60 s apart.
  Frame first, second;
  ASSERT_EQ(readPastTimeouts(*source, first), Status::kFrame) << source->lastError();
  const std::int64_t first_offset_us = wallAheadOfMonotonicUs();
  ASSERT_EQ(readPastTimeouts(*source, second), Status::kFrame) << source->lastError();
  const std::int64_t second_offset_us = wallAheadOfMonotonicUs();
  EXPECT_NEAR(driverIntervalUs(first, first_offset_us, second, second_offset_us),
              static_cast<double>(second.sequence - first.sequence) * 1e6 / 60.0, 50.0);
}

TEST_F(V4l2Backend, StreamsFramesInOrderStampedWithTheirCaptureTime) {
  // The device starts at 30 fps; the config asks 60, which it can do.
  ::setenv(shim::kRatesVariable, "30,60", 1);
  auto source = open(sized(320, 240, 60));
  ASSERT_TRUE(source) << error_;
  std::vector<std::uint64_t> sequences;
  std::vector<Frame> frames;
  std::vector<std::int64_t> offsets_us;
  std::int64_t worst_delay_us = 0;
  for (int k = 0; k < 30; ++k) {
    Frame frame;
    ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
    offsets_us.push_back(wallAheadOfMonotonicUs());
    const std::int64_t now = hostTimeMicroseconds();
    EXPECT_LE(frame.capture_time_us, now + 1000) << "captured in the future";
    worst_delay_us = std::max(worst_delay_us, now - frame.capture_time_us);
    EXPECT_TRUE(showsPattern(frame, frame.sequence, shim::kGainDefault));
    sequences.push_back(frame.sequence);
    frames.push_back(frame);
  }
  std::printf("30 frames: capture to read at most %.2f ms\n",
              static_cast<double>(worst_delay_us) / 1000.0);
  EXPECT_LT(worst_delay_us, 25'000) << "capture times are the host clock's, within a few ms";
  EXPECT_EQ(sequences.front(), 0u) << "sequence numbers start at 0";
  for (std::size_t k = 1; k < sequences.size(); ++k) {
    ASSERT_GT(sequences[k], sequences[k - 1]);
    // The driver's monotonic stamps, 1/60 s apart, come through exactly: the rate was applied
    // and the times are the driver's, not the moment of reading.
    const double expected_us = static_cast<double>(sequences[k] - sequences[k - 1]) * 1e6 / 60.0;
    EXPECT_NEAR(driverIntervalUs(frames[k - 1], offsets_us[k - 1], frames[k], offsets_us[k]),
                expected_us, 50.0)
        << k;
  }
  const TransportCounters counters = source->transportCounters();
  EXPECT_EQ(counters.frames_incomplete, 0);
  EXPECT_EQ(counters.underruns, static_cast<std::int64_t>(sequences.back() - sequences.front() -
                                                          (sequences.size() - 1)));
}

TEST_F(V4l2Backend, FramesTheDriverDroppedForWantOfABufferAreUnderruns) {
  ::setenv(shim::kRatesVariable, "60", 1);
  auto source = open(sized(320, 240));
  ASSERT_TRUE(source) << error_;
  Frame frame;
  ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
  std::uint64_t last = frame.sequence;
  std::int64_t gaps = 0;
  // A slow reader: 15 frames come due while the driver has 3 free buffers.
  std::this_thread::sleep_for(250ms);
  for (int k = 0; k < 8; ++k) {
    ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
    ASSERT_GT(frame.sequence, last);
    EXPECT_TRUE(showsPattern(frame, frame.sequence, shim::kGainDefault));
    gaps += static_cast<std::int64_t>(frame.sequence - last - 1);
    last = frame.sequence;
  }
  EXPECT_GE(gaps, 8) << "the sleep made the driver drop frames";
  EXPECT_EQ(source->transportCounters().underruns, gaps);
}

TEST_F(V4l2Backend, DamagedFramesAreDroppedAndCountedAsIncomplete) {
  ::setenv(shim::kErrorEveryVariable, "4", 1);
  ::setenv(shim::kRatesVariable, "60", 1);
  auto source = open(sized(320, 240));
  ASSERT_TRUE(source) << error_;
  int good = 0, damaged = 0;
  while (good < 16) {
    Frame frame;
    const Status status = readPastTimeouts(*source, frame);
    if (status == Status::kError) {
      ++damaged;
      EXPECT_EQ(source->lastError(), "damaged frame");
      continue;
    }
    ASSERT_EQ(status, Status::kFrame) << statusName(status) << ": " << source->lastError();
    ++good;
    EXPECT_NE(frame.sequence % 4, 3u) << "frame " << frame.sequence << " came flagged damaged";
    EXPECT_TRUE(showsPattern(frame, frame.sequence, shim::kGainDefault));
  }
  EXPECT_GE(damaged, 4);
  EXPECT_EQ(source->transportCounters().frames_incomplete, damaged);
}

TEST_F(V4l2Backend, AnUnplugIsLostWithinASecondAndTheReconnectReappliesTheSettings) {
  auto source = open(sized(320, 240, 60, {{"gain", "40"}, {"exposure_time_absolute", "500"}}));
  ASSERT_TRUE(source) << error_;
  Frame frame;
  std::uint64_t last = 0;
  for (int k = 0; k < 5; ++k) {
    ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
    EXPECT_TRUE(showsPattern(frame, frame.sequence, 40));
    last = frame.sequence;
  }

  unplug();
  const auto unplugged = std::chrono::steady_clock::now();
  Status status = Status::kFrame;
  while (status == Status::kFrame || status == Status::kTimeout) {
    ASSERT_LT(std::chrono::steady_clock::now() - unplugged, 1s) << "not lost within 1 s";
    status = source->read(frame);
    if (status == Status::kFrame) last = frame.sequence;
  }
  EXPECT_EQ(status, Status::kLost) << statusName(status) << ": " << source->lastError();
  EXPECT_NE(source->lastError().find("No such device"), std::string::npos) << source->lastError();
  EXPECT_EQ(source->state(), SourceState::kLost);

  for (int k = 0; k < 3; ++k) {
    EXPECT_FALSE(source->reopen()) << "reopened while unplugged";
    EXPECT_NE(source->lastError().find(kDevice), std::string::npos) << source->lastError();
    EXPECT_EQ(source->state(), SourceState::kLost);
  }
  replug();
  ASSERT_TRUE(source->reopen()) << source->lastError();
  EXPECT_EQ(source->state(), SourceState::kStarting);
  EXPECT_EQ(source->width(), 320);
  EXPECT_EQ(source->height(), 240);
  // The replugged device starts with its gain at 0: a frame drawn at 40 shows it was set again.
  std::uint64_t first_after = 0;
  for (int k = 0; k < 5; ++k) {
    ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
    if (k == 0) first_after = frame.sequence;
    EXPECT_GT(frame.sequence, last) << "sequence numbers go on increasing across a reconnect";
    if (k == 0) {
      EXPECT_EQ(frame.sequence, last + 1) << "the first after a reconnect is the next number";
    }
    last = frame.sequence;
    EXPECT_TRUE(showsPattern(frame, frame.sequence - first_after, 40));
  }
}

// A driver that stalls (streams, finishes no frame) gives the backend no evidence of anything:
// read() says kTimeout, each within about 100 ms, however long the silence lasts. How long is too
// long is the caller's decision (the daemon's, for every backend alike); here the test decides
// after a second, as the daemon does, and reopens the device while it is still streaming. The
// stuck stream does not come back by itself, the reopen brings it back, and the frame numbers go
// on from where they were.
TEST_F(V4l2Backend, AStalledDriverOnlyTimesOutAndTheCallersReopenBringsItBack) {
  auto source = open(sized(320, 240, 60, {{"gain", "40"}}));
  ASSERT_TRUE(source) << error_;
  Frame frame;
  ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
  std::uint64_t last = frame.sequence;
  stall();
  const auto stalled = std::chrono::steady_clock::now();
  auto longest_read = 0ms;
  int timeouts = 0;
  while (std::chrono::steady_clock::now() - stalled < 1200ms) {
    const auto start = std::chrono::steady_clock::now();
    const Status status = source->read(frame);
    longest_read = std::max(longest_read, std::chrono::duration_cast<std::chrono::milliseconds>(
                                              std::chrono::steady_clock::now() - start));
    // Frames the driver finished before it stalled may still come; then nothing.
    ASSERT_TRUE(status == Status::kTimeout || status == Status::kFrame)
        << statusName(status) << ": " << source->lastError()
        << " (silence alone is no evidence of a loss)";
    if (status == Status::kFrame) {
      last = frame.sequence;
    } else {
      ++timeouts;
    }
    EXPECT_EQ(source->state(), SourceState::kStreaming) << "silence changes no state";
  }
  EXPECT_GE(timeouts, 8) << "a second without frames";
  EXPECT_LT(longest_read, 150ms) << "read() waits at most about 100 ms";
  // The stall is over, yet the stuck stream stays stuck: only a new stream would deliver.
  unstall();
  EXPECT_EQ(readPastTimeouts(*source, frame, 300ms), Status::kTimeout) << source->lastError();

  // The caller's decision: reopen, in the streaming state (the source never said kLost).
  ASSERT_TRUE(source->reopen()) << source->lastError();
  EXPECT_EQ(source->state(), SourceState::kStarting);
  ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
  EXPECT_EQ(source->state(), SourceState::kStreaming);
  EXPECT_EQ(frame.sequence, last + 1) << "frame numbers go on across the reopen";
  // The new stream's first frame, with the gain applied again.
  EXPECT_TRUE(showsPattern(frame, 0, 40));
}

TEST_F(V4l2Backend, ADeviceAbsentAtStartIsASourceInTheLostState) {
  unplug();
  auto source = open(sized(320, 240, 30, {{"gain", "40"}}));
  ASSERT_TRUE(source) << "an absent camera is not a config error: " << error_;
  EXPECT_EQ(source->width(), 320);
  EXPECT_EQ(source->height(), 240);
  EXPECT_EQ(source->state(), SourceState::kLost);
  Frame frame;
  EXPECT_EQ(source->read(frame), Status::kLost);
  EXPECT_NE(source->lastError().find(kDevice), std::string::npos) << source->lastError();
  EXPECT_FALSE(source->reopen());
  replug();
  ASSERT_TRUE(source->reopen()) << source->lastError();
  ASSERT_EQ(readPastTimeouts(*source, frame), Status::kFrame) << source->lastError();
  EXPECT_EQ(frame.image.width, 320);
  EXPECT_TRUE(showsPattern(frame, frame.sequence, 40));

  // Without a background the stream's size is unknown: that needs saying.
  unplug();
  EXPECT_FALSE(open(sized(0, 0)));
  EXPECT_NE(error_.find("size is unknown"), std::string::npos) << error_;
}

// occmapd on one V4L2 camera, asked over LCM how the camera is.

const std::string kOccmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";
const std::string kUrl = "udpm://239.255.76.67:7667?ttl=0";

// The camera's entry in `occmap status --json` (there is one camera), or "" when none answered.
std::string cameraStatus() {
  const auto status =
      testing::runCommand({kOccmap, "status", "--lcm-url", kUrl, "--json", "--timeout", "1"});
  if (status.exit_code != 0) return "";
  const std::size_t at = status.out.find("\"cameras\"");
  return at == std::string::npos ? "" : status.out.substr(at);
}

long long numberAfter(const std::string& text, const std::string& key) {
  const std::size_t at = text.find("\"" + key + "\":");
  return at == std::string::npos ? -1 : std::atoll(text.c_str() + at + key.size() + 3);
}

TEST(V4l2Daemon, ACameraGoesDownOnUnplugAndStreamsAgainAfterReplug) {
  if (const std::string why = shimMissing(); !why.empty()) GTEST_SKIP() << why;
  if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
    GTEST_SKIP() << problem;
  }
  TemporaryFolder folder;
  // A camera 3 m above the middle of a 2 m x 2 m floor, looking straight down (OpenCV model).
  folder.write("usb0.yml",
               "%YAML:1.0\n"
               "image_width: 320\n"
               "image_height: 240\n"
               "camera_matrix: !!opencv-matrix\n"
               "  {rows: 3, cols: 3, dt: d, data: [200., 0., 159.5, 0., 200., 119.5, 0., 0., 1.]}\n"
               "distortion_coefficients: !!opencv-matrix\n"
               "  {rows: 1, cols: 5, dt: d, data: [0., 0., 0., 0., 0.]}\n"
               "rvec: !!opencv-matrix {rows: 3, cols: 1, dt: d, data: [3.14159265358979, 0., 0.]}\n"
               "tvec: !!opencv-matrix {rows: 3, cols: 1, dt: d, data: [0., 0., 3.]}\n");
  folder.write("usb0.pgm", "P5\n320 240\n255\n" + std::string(320 * 240, '\x80'));
  const auto config =
      folder.write("occmapd.yaml",
                   "map: {origin_m: [-1.0, -1.0], cell_size_m: 0.05, width: 40, height: 40}\n"
                   "fusion: {threshold: 20, column_height_m: 0}\n"
                   "transport: {lcm_url: \"" +
                       kUrl +
                       "\"}\n"
                       "cameras:\n"
                       "  - {name: usb0, source: \"v4l2://" +
                       kDevice +
                       "\", calibration: usb0.yml, background: usb0.pgm, fps: 30,\n"
                       "     settings: {gain: 40, pixel_format: GREY}}\n");
  const auto unplug_file = folder / "unplugged";
  std::optional<testing::NotifyListener> systemd(std::in_place, folder / "notify");
  testing::ChildProcess daemon({kOccmapd, "--config", config.string()}, folder / "occmapd",
                               {{shim::kDeviceVariable, kDevice},
                                {shim::kUnplugFileVariable, unplug_file.string()},
                                {shim::kRatesVariable, "30"},
                                {"NOTIFY_SOCKET", systemd->path().string()}});
  ASSERT_TRUE(systemd->collect(testing::eventually(30s), "READY=1")) << daemon.err();
  systemd.reset();  // nobody would read it any more (see network_test)

  auto waitFor = [&](const std::string& state, std::chrono::milliseconds limit) {
    const auto end = std::chrono::steady_clock::now() + limit;
    std::string camera;
    do {
      camera = cameraStatus();
      if (camera.find("\"state_name\":\"" + state + "\"") != std::string::npos) return camera;
      std::this_thread::sleep_for(100ms);
    } while (std::chrono::steady_clock::now() < end);
    ADD_FAILURE() << "the camera is not " << state << " after " << limit.count()
                  << " ms; status: " << camera << "\n"
                  << daemon.err();
    return std::string();
  };
  const std::string streaming = waitFor("streaming", 5s);
  ASSERT_FALSE(streaming.empty());
  EXPECT_GT(numberAfter(streaming, "frames_in"), 0) << streaming;

  std::ofstream(unplug_file) << "gone\n";
  std::this_thread::sleep_for(1s);
  const std::string down = cameraStatus();
  EXPECT_NE(down.find("\"state_name\":\"down\""), std::string::npos)
      << "not down 1 s after the unplug: " << down;
  // The daemon logs why (the status's last_error is the pipeline's own "no frame for ..." line).
  EXPECT_NE(daemon.err().find("No such device"), std::string::npos) << daemon.err();
  const long long frames_before = numberAfter(down, "frames_in");

  std::filesystem::remove(unplug_file);
  const auto replugged = std::chrono::steady_clock::now();
  const std::string back = waitFor("streaming", 3s);
  std::printf("streaming again %.1f s after the replug\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - replugged).count());
  ASSERT_FALSE(back.empty());
  EXPECT_GE(numberAfter(back, "reconnects"), 1) << back;
  std::this_thread::sleep_for(500ms);
  EXPECT_GT(numberAfter(cameraStatus(), "frames_in"), frames_before) << "frames flow again";
  EXPECT_NE(daemon.err().find("is back"), std::string::npos) << daemon.err();

  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.waitExit(testing::eventually(5s)), 0) << daemon.err();
  std::printf("occmapd said:\n%s", daemon.err().c_str());
}

}  // namespace
}  // namespace occmap
