// `occmap view` on maps sent in tiles (map_tile_t on the map channel + _TILES, transport.tiles)
// from the test publisher over LCM's UDP multicast, in a network namespace of the test's own: the
// maps are received, tiles left out are counted in the summary line and their cells drawn unseen,
// undecodable tiles are said and counted.
#include <chrono>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "child_process.h"
#include "command_runner.h"
#include "map_scenes.h"
#include "network_namespace.h"
#include "temporary_folder.h"

namespace occmap {
namespace {

using namespace std::chrono_literals;
using testing::ChildProcess;
using testing::runCommand;
using testing::TemporaryFolder;

const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";
const std::string kPublisher = OCCMAP_BINARY_DIR "/tests/map_publisher";

TEST(ViewTiles, ShowsTiledMapsAndCountsTheTilesLost) {
  if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
    GTEST_SKIP() << problem;
  }
  TemporaryFolder folder;
  const std::string png = (folder / "last.png").string();
  ChildProcess view({kOccmap, "view", "--count", "9", "--timeout", "20", "--png", png},
                    folder / "view");
  ASSERT_TRUE(view.waitForOutput("listening for maps", 10s)) << view.out() << view.err();
  EXPECT_NE(view.out().find("(tiled on OCCMAP_MAP_TILES)"), std::string::npos) << view.out();
  // 1000 x 700 cells: 5 x 3 tiles of 240. Tiles 7 and 8 of map 3 and tile 7 of map 8 (cells
  // 480..719 of rows 240..479) left out; two undecodable messages first.
  const auto result = runCommand({kPublisher, "--tiles", "--count", "10", "--rate", "20", "--width",
                                  "1000", "--height", "700", "--drop-tile", "3:7", "--drop-tile",
                                  "3:8", "--drop-tile", "8:7", "--garbage", "2"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  const auto code = view.waitExit(20s);
  ASSERT_TRUE(code) << view.out() << view.err();
  EXPECT_EQ(*code, 0) << view.out() << view.err();
  EXPECT_NE(view.out().find("summary: received 9 maps"), std::string::npos) << view.out();
  EXPECT_NE(view.out().find("lost 0 (0 seq gaps), undecodable 2, tiles lost 3 (2 maps "
                            "incomplete)"),
            std::string::npos)
      << view.out();
  EXPECT_NE(view.err().find("an undecodable message on OCCMAP_MAP_TILES (100 bytes): not an "
                            "occmap.map_tile_t"),
            std::string::npos)
      << view.err();

  // The last map (seq 8) drawn, +y up, with its lost tile unseen.
  const cv::Mat picture = cv::imread(png);
  ASSERT_EQ(picture.cols, 1000);
  ASSERT_EQ(picture.rows, 700);
  MapFrame expected(MapGeometry{-0.5, -1.5, 0.02, 1000, 700}, 4);
  testing::fillScene(expected, 8);
  const cv::Vec3b colours[] = {{245, 245, 245}, {35, 35, 35}, {170, 140, 120}};
  int wrong = 0, unseen_in_lost_tile = 0;
  for (int row = 0; row < 700; ++row) {
    for (int column = 0; column < 1000; ++column) {
      if (row < 40 && column < 200) continue;  // the scale bar
      const bool lost = row >= 240 && row < 480 && column >= 480 && column < 720;
      const auto state =
          lost ? std::size_t{2} : static_cast<std::size_t>(expected.map.at(row, column));
      wrong += picture.at<cv::Vec3b>(699 - row, column) != colours[state];
      unseen_in_lost_tile += lost && expected.map.at(row, column) != CellState::kUnseen;
    }
  }
  EXPECT_EQ(wrong, 0) << "pixels of the picture that do not show their cell's state";
  EXPECT_GT(unseen_in_lost_tile, 10000) << "the lost tile is mostly seen floor: it shows";
}

}  // namespace
}  // namespace occmap
