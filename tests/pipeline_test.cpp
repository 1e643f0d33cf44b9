// The live pipeline in process (LCM's memq://): capture threads, rings, fusion, the LCM thread. The
// maps arrive in order and each equals the reference fusion of the very frames it says it used.
#include "daemon/pipeline.h"

#include <mutex>
#include <thread>

#include <gtest/gtest.h>

#include "capture/sim/renderer.h"
#include "core/reference_fusion.h"
#include "daemon/config.h"
#include "daemon_process.h"
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
  const std::vector<CarveTable> reference_tables = tables;

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
  std::this_thread::sleep_for(std::chrono::seconds(3));
  pipeline.stop();

  std::lock_guard lock(mutex);
  EXPECT_EQ(undecodable, 0u);
  ASSERT_GE(received.size(), 45u) << "four 30 fps cameras for 3 s should give about 90 maps";
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
  const auto scene = sim::makeScene("room");
  std::vector<std::unique_ptr<sim::Renderer>> renderers;
  for (std::size_t k = 0; k < 4; ++k) {
    renderers.push_back(std::make_unique<sim::Renderer>(
        *scene,
        Camera(std::make_shared<TsaiCamera>(scene->cameras()[k].calibration),
               LengthUnit::kMillimetre, 640, 480),
        static_cast<int>(k)));
  }
  std::size_t compared = 0, all_cameras = 0;
  for (std::size_t i = 0; i < received.size(); i += 7) {
    const DecodedMap& map = received[i];
    ASSERT_EQ(map.cameras.size(), 4u);
    std::vector<Image> live(4);
    std::vector<CameraFrame> frames;
    std::size_t used = 0;
    for (std::size_t k = 0; k < 4; ++k) {
      const DecodedCamera& camera = map.cameras[k];
      if (camera.used) {
        const auto n = static_cast<std::uint64_t>(camera.sequence);
        renderers[k]->render(scene->objectsAt(static_cast<double>(n) / 30.0), n, live[k]);
        ++used;
      }
      frames.push_back({&reference_tables[k], camera.used ? live[k].view() : ImageView{},
                        renderers[k]->background().view(), 20});
    }
    const OccupancyMap expected = fuseReference(config.map, frames);
    ASSERT_EQ(map.cells.size(), expected.cells.size());
    for (std::size_t cell = 0; cell < expected.cells.size(); ++cell) {
      ASSERT_EQ(map.cells[cell], static_cast<std::uint8_t>(expected.cells[cell]))
          << "map " << map.seq << " cell " << cell;
    }
    ++compared;
    all_cameras += used == 4 ? 1 : 0;
  }
  EXPECT_GE(compared, 6u);
  EXPECT_GE(all_cameras, compared / 2) << "most maps should fuse all four cameras";
}

}  // namespace
}  // namespace occmap
