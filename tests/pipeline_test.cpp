// The live pipeline in process (LCM's memq://): capture threads, rings, fusion, the LCM thread. The
// maps arrive in order and each equals the reference fusion of the very frames it says it used.
#include "daemon/pipeline.h"

#include <atomic>
#include <filesystem>
#include <mutex>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "allocation_counter.h"
#include "config/config.h"
#include "sim_reference.h"
#include "sim_room_config.h"
#include "temporary_folder.h"
#include "transport/map_codec.h"

namespace occmap {
namespace {

using testing::TemporaryFolder;

TEST(Pipeline, MapsArriveInOrderAndEqualTheReferenceFusionOfTheirFrames) {
  TemporaryFolder folder;
  const auto file = folder.write("room.yaml", testing::simRoomConfig("memq://"));
  const Config config = loadConfig(file);
  Rig rig = Rig::open(config);
  std::vector<CarveTable> tables = rig.buildTables(0.0);

  std::mutex mutex;
  std::vector<DecodedMap> received;
  std::size_t undecodable = 0;
  PipelineOptions options;
  MapDecoder decoder;  // used only in the LCM thread, inside the handler
  options.subscriptions.push_back({"OCCMAP_MAP", [&](const std::uint8_t* data, std::size_t size) {
                                     const DecodedMap& map = decoder.decode(data, size);
                                     std::lock_guard lock(mutex);
                                     if (map.ok()) {
                                       received.push_back(map);
                                     } else {
                                       ++undecodable;
                                     }
                                   }});
  Pipeline pipeline(std::move(rig), std::move(tables), options);
  pipeline.start();
  // About a second at full speed; sanitizers slow the simulator down, so wait for the maps.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::lock_guard lock(mutex);
    if (received.size() >= 40) break;
  }
  pipeline.stop();

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
  const testing::SimRoomReference reference(config.map, 0.0);
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

// The threads of this process, from /proc.
std::size_t threadCount() {
  std::size_t threads = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator("/proc/self/task"))
    ++threads;
  return threads;
}

// Stopped at a random moment under full load, again and again: every thread it started is gone,
// and every map fusion made was published and received (none left in the map buffers).
TEST(Pipeline, ShutdownUnderLoadLeavesNoThreadAndLosesNoFusedMap) {
  TemporaryFolder folder;
  const auto file = folder.write("room.yaml", testing::simRoomConfig("memq://"));
  const Config config = loadConfig(file);
  Rig opened = Rig::open(config);
  const std::vector<CarveTable> tables = opened.buildTables(0.0);
  const std::size_t threads_before = threadCount();
  std::mt19937 random(7);
  for (int trial = 0; trial < 12; ++trial) {
    std::atomic<std::uint64_t> received{0};
    PipelineOptions options;
    options.subscriptions.push_back(
        {"OCCMAP_MAP", [&](const std::uint8_t*, std::size_t) { ++received; }});
    // Every trial opens the rig afresh: the pipeline owns its sources.
    Pipeline pipeline(Rig::open(config), tables, options);
    pipeline.start();
    EXPECT_GT(threadCount(), threads_before);
    std::this_thread::sleep_for(std::chrono::milliseconds(100 + random() % 300));
    pipeline.stop();
    EXPECT_EQ(threadCount(), threads_before) << "trial " << trial << ": a thread outlived stop()";
    EXPECT_GT(pipeline.mapsFused(), 0u);
    // The publisher sends the newest map; one it was too slow for is skipped and counted (none
    // should be in process). Nothing else may go missing, least of all the last map at the stop.
    EXPECT_EQ(pipeline.mapsPublished() + pipeline.mapsSkipped(), pipeline.mapsFused())
        << "trial " << trial << ": a fused map was neither published nor counted as skipped";
    EXPECT_EQ(received.load(), pipeline.mapsPublished()) << "trial " << trial;
  }
}

// The hot path (capture -> fusion -> publish) allocates nothing once running, and neither does the
// once-a-second status: over seconds of steady work at 30 frame sets a second, no operator new
// from any thread. (LCM's C code uses malloc, which this does not see: only occmap's own code is
// held to it.)
TEST(Pipeline, RunningSteadilyAllocatesNothing) {
  TemporaryFolder folder;
  const Config config = loadConfig(folder.write("room.yaml", testing::simRoomConfig("memq://")));
  Rig rig = Rig::open(config);
  std::vector<CarveTable> tables = rig.buildTables(0.0);
  Pipeline pipeline(std::move(rig), std::move(tables));
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

}  // namespace
}  // namespace occmap
