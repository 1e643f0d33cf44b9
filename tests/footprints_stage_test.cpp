// The footprints thread's share for the zones (daemon/footprints_stage.h): the fusion thread gets
// the people found on the newest map done, and none once they are older than it allows.
#include "daemon/footprints_stage.h"

#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "core/fusion_kernel.h"
#include "corner_cameras.h"

namespace occmap {
namespace {

TEST(FootprintsStage, GivesTheZonesThePeopleFoundOnTheNewestMapWhileTheyAreFresh) {
  const MapGeometry map = testing::cornerRoomMap();
  const std::vector<Camera> cameras = testing::cornerRoomCameras();
  const std::size_t bytes = changedMaskBytes(320, 240);
  const std::vector<std::size_t> mask_bytes(cameras.size(), bytes);
  FootprintsStage stage(map, cameras, FootprintSettings{}, mask_bytes);
  EXPECT_TRUE(stage.foundFor(0.0, 0.1).empty()) << "nothing found yet";

  // Every pixel changed and every cell occupied: people are found all over the floor.
  const std::vector<std::uint8_t> everything(bytes, 0xff);
  const std::vector<const std::uint8_t*> masks(cameras.size(), everything.data());
  const std::vector<CellState> occupied(map.cellCount(), CellState::kOccupied);
  stage.offer(1, 1000, 10.0, masks, occupied);
  ASSERT_TRUE(stage.findNewest());
  const FootprintsFound* found = stage.takeLatest();
  ASSERT_NE(found, nullptr);
  ASSERT_FALSE(found->footprints.empty());

  const std::span<const Detection> fresh = stage.foundFor(10.05, 0.1);
  ASSERT_EQ(fresh.size(), found->footprints.size());
  EXPECT_EQ(fresh[0].x_m, found->footprints[0].x_m);
  EXPECT_EQ(stage.foundFor(10.1, 0.1).size(), found->footprints.size()) << "as old as allowed";
  EXPECT_TRUE(stage.foundFor(10.2, 0.1).empty()) << "people move on: too old to tell";

  // A map with nobody on it replaces them.
  const std::vector<std::uint8_t> nothing(bytes, 0);
  const std::vector<const std::uint8_t*> still(cameras.size(), nothing.data());
  const std::vector<CellState> free(map.cellCount(), CellState::kFree);
  stage.offer(2, 2000, 10.2, still, free);
  ASSERT_TRUE(stage.findNewest());
  EXPECT_TRUE(stage.foundFor(10.2, 0.1).empty());
}

}  // namespace
}  // namespace occmap
