// The footprints thread (daemon/footprints_stage.h): the fusion thread gets the people found on the
// newest map done, and none once they are older than it allows; a camera re-posed after a knock
// counts again with boxes for its new pose.
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

// A camera re-posed after a knock (core/repose.h): its masks of the new pose say nothing until the
// stage has its pose, and then count with boxes for that pose, as a detector built for the
// knocked rig finds them.
TEST(FootprintsStage, ACameraReposedAfterAKnockCountsAgainWithItsNewPose) {
  const MapGeometry map = testing::cornerRoomMap();
  const std::vector<Camera> cameras = testing::cornerRoomCameras();
  std::vector<Camera> knocked = cameras;
  knocked[0] = cameras[0].turned({0.0, 0.05, 0.03});
  const std::size_t bytes = changedMaskBytes(320, 240);
  const std::vector<std::size_t> mask_bytes(cameras.size(), bytes);
  FootprintsStage stage(map, cameras, FootprintSettings{}, mask_bytes);

  const std::vector<testing::Cylinder> people = {{2.0, 2.5}, {3.5, 3.0}, {4.0, 4.5}};
  std::vector<std::vector<std::uint8_t>> masks;
  std::vector<const std::uint8_t*> all, without_first;
  for (const Camera& camera : knocked) {
    masks.push_back(testing::changedWhereCylinders(camera, people, 320, 240));
  }
  for (const std::vector<std::uint8_t>& mask : masks) all.push_back(mask.data());
  without_first = all;
  without_first[0] = nullptr;
  const std::vector<CellState> occupied(map.cellCount(), CellState::kOccupied);
  FootprintDetector built(map, knocked);
  const std::vector<Detection> with_new_pose = built.detect(all, occupied);
  const std::vector<Detection> left_out = built.detect(without_first, occupied);
  ASSERT_EQ(with_new_pose.size(), 3u);
  const auto same = [](const std::vector<Detection>& found,
                       const std::vector<Detection>& expected) {
    if (found.size() != expected.size()) return false;
    for (std::size_t i = 0; i < found.size(); ++i) {
      if (found[i].x_m != expected[i].x_m || found[i].y_m != expected[i].y_m) return false;
    }
    return true;
  };

  // Masks of the re-posed camera (generation 1) before its pose is handed over: left out.
  const std::vector<std::uint32_t> generations = {1, 0, 0, 0};
  stage.offer(1, 1000, 10.0, all, occupied, generations);
  ASSERT_TRUE(stage.findNewest());
  EXPECT_TRUE(same(stage.takeLatest()->footprints, left_out));
  EXPECT_EQ(stage.reposesApplied(), 0u);

  // Its pose handed over: its masks count, with boxes for the new pose.
  stage.reposed(0, 1, knocked[0]);
  stage.offer(2, 2000, 10.1, all, occupied, generations);
  ASSERT_TRUE(stage.findNewest());
  EXPECT_TRUE(same(stage.takeLatest()->footprints, with_new_pose));
  EXPECT_EQ(stage.reposesApplied(), 1u);

  // A mask of a later re-pose whose pose has not come yet says nothing again.
  const std::vector<std::uint32_t> later = {2, 0, 0, 0};
  stage.offer(3, 3000, 10.2, all, occupied, later);
  ASSERT_TRUE(stage.findNewest());
  EXPECT_TRUE(same(stage.takeLatest()->footprints, left_out));
  EXPECT_EQ(stage.reposesApplied(), 1u);
}

}  // namespace
}  // namespace occmap
