// The live pipeline in process, on an in-memory bus (transport/memory_bus.h): capture threads,
// fusion, the publisher. The maps arrive in order and each equals the reference fusion of the very
// frames it says it used; a stop under load loses nothing; steady work allocates nothing; a
// publisher stuck in a call stops the watchdog's pings. Each with the floor point (0) and with the
// shipped default, 0.3 m columns.
#include "daemon/pipeline.h"

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <random>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "allocation_counter.h"
#include "base/clock.h"
#include "bus_listener.h"
#include "config/config.h"
#include "core/changed_pixels.h"
#include "daemon/liveness.h"
#include "downward_rig.h"
#include "sim_reference.h"
#include "sim_room_config.h"
#include "temporary_folder.h"
#include "timing.h"
#include "transport/lcm_bus.h"
#include "transport/map_codec.h"
#include "transport/memory_bus.h"

namespace occmap {
namespace {

using testing::BusListener;
using testing::TemporaryFolder;

class PipelineAtHeight : public ::testing::TestWithParam<const char*> {
 protected:
  Config loadRoom() {
    return loadConfig(
        folder_.write("room.yaml", testing::simRoomConfig("memq://", "", GetParam())));
  }
  TemporaryFolder folder_;
};

INSTANTIATE_TEST_SUITE_P(Columns, PipelineAtHeight, ::testing::Values("0", "0.3"),
                         [](const auto& param_info) {
                           return std::string(param_info.param) == "0" ? "FloorPoint"
                                                                       : "Columns30cm";
                         });

TEST_P(PipelineAtHeight, MapsArriveInOrderAndEqualTheReferenceFusionOfTheirFrames) {
  const Config config = loadRoom();
  MemoryNetwork network;
  BusListener listener(network);
  std::mutex mutex;
  std::vector<DecodedMap> received;
  std::size_t undecodable = 0;
  MapDecoder decoder;  // used only in the listener's thread, inside the handler
  listener.subscribe("OCCMAP_MAP", [&](const std::uint8_t* data, std::size_t size) {
    const DecodedMap& map = decoder.decode(data, size);
    std::lock_guard lock(mutex);
    if (map.ok()) {
      received.push_back(map);
    } else {
      ++undecodable;
    }
  });
  listener.start();
  Pipeline pipeline(prepareRig(config), network.connect());
  pipeline.start();
  // About a second at full speed; sanitizers slow the simulator down, so wait for the maps.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::lock_guard lock(mutex);
    if (received.size() >= 40) break;
  }
  pipeline.stop();
  listener.stop();

  std::lock_guard lock(mutex);
  EXPECT_EQ(undecodable, 0u);
  ASSERT_GE(received.size(), 40u) << "four 30 fps cameras should give 30 maps a second";
  // In process nothing is lost: every map the publisher numbered arrives, in order.
  EXPECT_EQ(received.front().seq, 0);
  for (std::size_t i = 1; i < received.size(); ++i) {
    ASSERT_EQ(received[i].seq, received[i - 1].seq + 1) << "maps out of order or lost";
  }
  for (const DecodedMap& map : received) {
    // utime is the newest fused frame's host capture time.
    std::int64_t newest = 0;
    for (const DecodedCamera& camera : map.cameras) {
      if (camera.used) newest = std::max(newest, camera.capture_utime);
    }
    if (newest != 0) {
      ASSERT_EQ(map.utime, newest) << "map " << map.seq;
    }
  }
  EXPECT_EQ(pipeline.mapsPublished(), received.size());

  // Re-render exactly the frames each map says it used, and fuse them the reference way.
  const testing::SimRoomReference reference(config.map, config.fusion.column_height_m);
  std::size_t compared = 0, all_cameras = 0;
  for (std::size_t i = 0; i < received.size(); i += 5) {
    const DecodedMap& map = received[i];
    ASSERT_EQ(map.cameras.size(), 4u);
    ASSERT_EQ(reference.firstDifference(map), -1) << "map " << map.seq;
    ++compared;
    all_cameras += std::count_if(map.cameras.begin(), map.cameras.end(),
                                 [](const DecodedCamera& c) { return c.used; }) == 4;
  }
  EXPECT_GE(compared, 6u);
  EXPECT_GE(all_cameras, compared / 2) << "most maps should fuse all four cameras";
}

// Under light that steps and ramps (sim://room-light: 1, 0.6, 0.6 -> 1.5, 1.5 in four seconds),
// with the light's model on (the default): each map equals the maps replayed off-line from the
// very frames it used, each camera's frames put through the same model from its first frame on
// (core/changed_pixels.h, as `occmap fuse` does). Live equals off-line, and the floor stays free.
TEST(Pipeline, UnderChangingLightEachMapIsTheOffLineReplayOfItsFrames) {
  TemporaryFolder folder;
  const std::string text =
      testing::inScene(testing::simRoomConfig("memq://", "", "0.3"), "room-light");
  const Config config = loadConfig(folder.write("room-light.yaml", text));
  ASSERT_TRUE(config.cameras[0].effectiveLighting(config.fusion).adapt);
  MemoryNetwork network;
  BusListener listener(network);
  std::mutex mutex;
  std::vector<DecodedMap> received;
  MapDecoder decoder;  // used only in the listener's thread, inside the handler
  listener.subscribe("OCCMAP_MAP", [&](const std::uint8_t* data, std::size_t size) {
    const DecodedMap& map = decoder.decode(data, size);
    std::lock_guard lock(mutex);
    if (map.ok()) received.push_back(map);
  });
  listener.start();
  Pipeline pipeline(prepareRig(config), network.connect());
  pipeline.start();
  // Four seconds of frames cover a whole cycle of the light; slower under the sanitizers.
  constexpr std::int64_t kFrames = 125;
  const auto deadline =
      std::chrono::steady_clock::now() + testing::eventually(std::chrono::seconds(60));
  while (std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::lock_guard lock(mutex);
    if (!received.empty() && received.back().cameras.size() == 4 &&
        std::all_of(received.back().cameras.begin(), received.back().cameras.end(),
                    [](const DecodedCamera& c) { return c.sequence >= kFrames; }))
      break;
  }
  pipeline.stop();
  listener.stop();
  std::lock_guard lock(mutex);
  ASSERT_FALSE(received.empty());
  for (const DecodedCamera& camera : received.back().cameras) {
    ASSERT_GE(camera.sequence, kFrames) << "the maps should cover a whole cycle of the light";
  }

  // The replay: each camera's frames in order through its own model, its masks kept by frame.
  PreparedRig replay = prepareRig(config);
  FusionKernel kernel(replay.tables);
  const std::size_t cameras = replay.rig.cameras().size();
  std::vector<std::vector<std::vector<std::uint8_t>>> masks(cameras);
  std::vector<std::vector<bool>> explained(cameras);
  for (std::size_t k = 0; k < cameras; ++k) {
    RigCamera& camera = replay.rig.cameras()[k];
    ChangedPixels changed(camera.lighting, *camera.camera);
    for (std::int64_t n = 0; n <= kFrames + 30; ++n) {
      Frame frame;
      ASSERT_EQ(camera.source->read(frame), FrameSource::Status::kFrame);
      ASSERT_EQ(static_cast<std::int64_t>(frame.sequence), n);
      masks[k].emplace_back(changedMaskBytes(frame.image.width, frame.image.height));
      explained[k].push_back(changed.mark(kernel, k, frame.image, camera.background,
                                          camera.threshold, masks[k].back().data(),
                                          frame.capture_time_us));
    }
  }
  std::vector<CellState> cells(config.map.cellCount());
  std::vector<const std::uint8_t*> used(cameras);
  std::size_t compared = 0;
  std::size_t complete = 0;
  double worst_free = 1.0;
  // Every third map (a fusion under TSan takes some 70 ms): a third of a cycle of the light still
  // gives some forty of them.
  for (std::size_t i = 0; i < received.size(); i += 3) {
    const DecodedMap& map = received[i];
    ASSERT_EQ(map.cameras.size(), cameras);
    bool within = true;
    for (std::size_t k = 0; k < cameras; ++k) {
      const DecodedCamera& camera = map.cameras[k];
      within = within && camera.sequence < static_cast<std::int64_t>(masks[k].size());
      if (!within) break;
      used[k] = camera.used ? masks[k][static_cast<std::size_t>(camera.sequence)].data() : nullptr;
      if (camera.used) {
        ASSERT_TRUE(explained[k][static_cast<std::size_t>(camera.sequence)])
            << "map " << map.seq << " used a frame of camera " << k << " no light explains";
      }
    }
    if (!within) continue;
    kernel.fuse(used, cells);
    for (std::size_t cell = 0; cell < cells.size(); ++cell) {
      ASSERT_EQ(map.cells[cell], static_cast<std::uint8_t>(cells[cell]))
          << "map " << map.seq << ", cell " << cell;
    }
    ++compared;
    // How free the floor is depends on how many cameras a frame set has (one camera leaves the
    // wedges behind people occupied): judged on maps of all four, which a slow (sanitized) run
    // makes fewer of.
    if (std::count(used.begin(), used.end(), nullptr) != 0) continue;
    ++complete;
    const auto free = static_cast<double>(std::count(cells.begin(), cells.end(), CellState::kFree));
    const auto seen =
        static_cast<double>(cells.size() - static_cast<std::size_t>(std::count(
                                               cells.begin(), cells.end(), CellState::kUnseen)));
    worst_free = std::min(worst_free, free / seen);
  }
  std::printf(
      "%zu maps compared with their replay; the least free of the %zu of all four cameras had "
      "%.1f %% of its seen cells free\n",
      compared, complete, 100 * worst_free);
  EXPECT_GE(compared, 10u);
  EXPECT_GE(complete, 5u);
  // The room has people, chairs and a robot: most of what is seen is free in every map all the
  // same (a fixed background would leave most of the floor occupied at 0.6 and 1.5).
  EXPECT_GE(worst_free, 0.85);
}

// The threads of this process, from /proc.
std::size_t threadCount() {
  std::size_t threads = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator("/proc/self/task"))
    ++threads;
  return threads;
}

// The threads of this process once those already joined are gone from /proc: a joined thread's
// entry in /proc/self/task may outlast pthread_join by a moment (the kernel wakes the joiner as
// the thread exits, before it releases the task), which made one run under ASan see 3 where 2 were
// left. A thread still running stays, and is counted.
std::size_t threadCountAfterJoins(std::size_t expected) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
  std::size_t threads = threadCount();
  while (threads != expected && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    threads = threadCount();
  }
  return threads;
}

// Stopped at a random moment under full load, again and again: every thread it started is gone,
// and every map fusion made was published and received (none left in the map buffers).
TEST_P(PipelineAtHeight, ShutdownUnderLoadLeavesNoThreadAndLosesNoFusedMap) {
  const Config config = loadRoom();
  // The first trial opens the rig; each later one runs the rig the pipeline before it gave back
  // (takePrepared), as occmapd does when a reload fails and the old pipeline starts again. So each
  // stop also proves the rig fit to run again, and no trial spends seconds (under a sanitizer)
  // rendering the simulated room's empty views anew.
  PreparedRig rig = prepareRig(config);
  const std::size_t threads_before = threadCount();
  std::mt19937 random(7);
  // Twelve stops at random moments.
  for (int trial = 0; trial < 12; ++trial) {
    MemoryNetwork network;
    std::atomic<std::uint64_t> received{0};
    std::size_t threads_with_listener = 0;
    {
      BusListener listener(network);
      listener.subscribe("OCCMAP_MAP", [&](const std::uint8_t*, std::size_t) { ++received; });
      listener.start();
      threads_with_listener = threadCount();
      Pipeline pipeline(std::move(rig), network.connect());
      pipeline.start();
      EXPECT_GT(threadCount(), threads_with_listener);
      std::this_thread::sleep_for(std::chrono::milliseconds(100 + random() % 300));
      pipeline.stop();
      EXPECT_EQ(threadCountAfterJoins(threads_with_listener), threads_with_listener)
          << "trial " << trial << ": a thread outlived stop()";
      listener.stop();
      EXPECT_GT(pipeline.mapsFused(), 0u);
      // The publisher sends the newest map; one it was too slow for is skipped and counted.
      // Nothing else may go missing, least of all the last map at the stop.
      EXPECT_EQ(pipeline.mapsPublished() + pipeline.mapsSkipped(), pipeline.mapsFused())
          << "trial " << trial << ": a fused map was neither published nor counted as skipped";
      EXPECT_EQ(received.load(), pipeline.mapsPublished()) << "trial " << trial;
      rig = pipeline.takePrepared();
    }
    EXPECT_EQ(threadCountAfterJoins(threads_before), threads_before) << "trial " << trial;
  }
}

// The hot path (capture -> fusion -> publish) allocates nothing once running, and neither does the
// once-a-second status: over seconds of steady work at 30 frame sets a second, no operator new
// from any thread. LCM's memq:// is the bus, as in occmapd (LCM's C code uses malloc, which this
// does not see: only occmap's own code is held to it).
TEST_P(PipelineAtHeight, RunningSteadilyAllocatesNothing) {
  const Config config = loadRoom();
  auto bus = std::make_unique<LcmBus>("memq://");
  ASSERT_TRUE(bus->good());
  Pipeline pipeline(prepareRig(config), std::move(bus));
  pipeline.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // warmed up, statuses sent
  long allocations = 0;
  std::size_t largest = 0;
  const std::uint64_t maps_before = pipeline.mapsPublished();
  {
    testing::AllocationCounter counter;
    std::this_thread::sleep_for(std::chrono::milliseconds(2500));
    allocations = counter.allocations();
    largest = counter.largest();
  }
  const std::uint64_t maps = pipeline.mapsPublished() - maps_before;
  pipeline.stop();
  EXPECT_GE(maps, 20u) << "the pipeline should have been working meanwhile";
  EXPECT_EQ(allocations, 0) << allocations << " allocations (the largest " << largest
                            << " bytes) over " << maps << " maps and two statuses";
}

// A camera that, once told to, fails every 7th read with a long reason (200 characters). The
// reason is made once, and the source's own error string is sized for it in advance, so that the
// source itself allocates nothing to say why.
class FlakySource final : public FrameSource {
 public:
  explicit FlakySource(const std::atomic<bool>& failing)
      : failing_(failing), image_(100, 100, 120), reason_(200, 'x') {
    fail(reason_);
  }
  int width() const override { return 100; }
  int height() const override { return 100; }
  Status read(Frame& frame) override {
    const std::uint64_t n = next_++;
    if (failing_.load() && n % 7 == 3) return fail(reason_);
    frame.image = image_.view();
    frame.sequence = n;
    frame.capture_time_us = hostTimeMicroseconds();
    return Status::kFrame;
  }

 private:
  const std::atomic<bool>& failing_;
  Image image_;
  std::string reason_;
  std::uint64_t next_ = 0;
};

// The status once a camera fails: the error text goes into room made in advance, so that
// reporting it allocates nothing. The camera's first error, longer than any text before it, comes
// while allocations are counted, and ten statuses a second carry it for two seconds.
TEST(Pipeline, TheStatusAllocatesNothingEvenAfterCameraErrors) {
  auto bus = std::make_unique<LcmBus>("memq://");
  ASSERT_TRUE(bus->good());
  PipelineOptions options;
  options.status_period = std::chrono::milliseconds(100);
  std::atomic<bool> failing{false};
  Pipeline pipeline(testing::downwardRig("flaky", std::make_unique<FlakySource>(failing), 0.3),
                    std::move(bus), options);
  pipeline.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // warmed up, statuses sent
  ASSERT_EQ(pipeline.framesDropped(), 0u) << "the camera failed before it was told to";
  long allocations = 0;
  {
    testing::AllocationCounter counter;
    failing.store(true);
    std::this_thread::sleep_for(std::chrono::milliseconds(2000));
    allocations = counter.allocations();
  }
  const std::uint64_t dropped = pipeline.framesDropped();
  pipeline.stop();
  EXPECT_GT(dropped, 5u) << "the camera should have failed meanwhile";
  EXPECT_EQ(allocations, 0) << "statuses after camera errors allocated";
}

// A bus whose publish blocks once told to, as a send stuck in the kernel or a wedged network
// driver would: the fault comes through the bus, not through a hook in the pipeline.
class StuckBus final : public Bus {
 public:
  explicit StuckBus(std::unique_ptr<Bus> bus) : bus_(std::move(bus)) {}
  bool publish(const std::string& channel, std::span<const std::uint8_t> message) override {
    std::unique_lock lock(mutex_);
    blocked_.wait(lock, [this] { return !stuck_; });
    return bus_->publish(channel, message);
  }
  bool subscribe(const std::string& channel, Handler handler) override {
    return bus_->subscribe(channel, std::move(handler));
  }
  int fileno() override { return bus_->fileno(); }
  int handleTimeout(int timeout_ms) override { return bus_->handleTimeout(timeout_ms); }
  void setStuck(bool stuck) {
    {
      const std::lock_guard lock(mutex_);
      stuck_ = stuck;
    }
    blocked_.notify_all();
  }

 private:
  std::unique_ptr<Bus> bus_;
  std::mutex mutex_;
  std::condition_variable blocked_;
  bool stuck_ = false;
};

TEST(Pipeline, APublisherStuckInASendStopsTheWatchdogPingsAndTheyResumeWhenItReturns) {
  TemporaryFolder folder;
  const Config config = loadConfig(folder.write("room.yaml", testing::simRoomConfig()));
  MemoryNetwork network;
  auto stuck = std::make_unique<StuckBus>(network.connect());
  StuckBus& bus = *stuck;
  Pipeline pipeline(prepareRig(config), std::move(stuck));
  pipeline.start();
  Liveness liveness;
  // Looks as occmapd's main loop does, every `tick`, until `pings` pings or the time is up.
  auto pingsWithin = [&](std::chrono::milliseconds tick, int looks) {
    int pings = 0;
    for (int i = 0; i < looks; ++i) {
      std::this_thread::sleep_for(tick);
      pings += liveness.alive(pipeline.mapsFused(), pipeline.publisherRounds());
    }
    return pings;
  };
  EXPECT_GE(pingsWithin(std::chrono::milliseconds(200), 10), 3)
      << "a healthy pipeline should be pinged nearly every look";
  bus.setStuck(true);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the round under way ends in it
  (void)liveness.alive(pipeline.mapsFused(), pipeline.publisherRounds());
  const std::uint64_t maps = pipeline.mapsFused();
  EXPECT_EQ(pingsWithin(std::chrono::milliseconds(200), 10), 0)
      << "pings went on although the publisher was stuck in a send";
  EXPECT_GT(pipeline.mapsFused(), maps) << "fusion itself went on";
  bus.setStuck(false);
  EXPECT_GE(pingsWithin(std::chrono::milliseconds(200), 10), 3) << "pings should resume";
  pipeline.stop();
}

TEST(Liveness, PingsOnlyWhenBothFusionAndThePublisherMoved) {
  Liveness liveness;
  EXPECT_TRUE(liveness.alive(1, 1));
  EXPECT_FALSE(liveness.alive(1, 2)) << "no new map: fusion stalled";
  EXPECT_FALSE(liveness.alive(2, 1)) << "no new round: the publisher is stuck";
  EXPECT_TRUE(liveness.alive(2, 2));
  EXPECT_FALSE(liveness.alive(2, 2));
  EXPECT_TRUE(liveness.alive(5, 9));
}

}  // namespace
}  // namespace occmap
