// Several camera PCs' maps made one (issue 16): the merge rule (core/map_merge.h) on its own, and
// `occmap merge` of two halves of the simulated room's cameras against `occmap fuse` of all four,
// from the very same recorded frames, in floor and in column mode: equal cell for cell.
#include "core/map_merge.h"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "command_runner.h"
#include "core/merge_inputs.h"
#include "temporary_folder.h"

namespace occmap {
namespace {

namespace fs = std::filesystem;
using testing::runCommand;

const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";
const std::string kRoomConfig = OCCMAP_SOURCE_DIR "/examples/sim-room.yaml";

constexpr CellState F = CellState::kFree;
constexpr CellState O = CellState::kOccupied;
constexpr CellState U = CellState::kUnseen;

MapGeometry strip(int width) {
  MapGeometry g;
  g.origin_x_m = 0;
  g.origin_y_m = 0;
  g.cell_size_m = 1;
  g.width = width;
  g.height = 1;
  return g;
}

OccupancyMap mapOf(const MapGeometry& g, const std::vector<CellState>& cells) {
  OccupancyMap map(g);
  map.cells = cells;
  return map;
}

TEST(MapMerger, FreeWhenAnyFreesUnseenWhenNoneSeesOccupiedOtherwise) {
  const MapGeometry g = strip(6);
  // Cells: freed by one; occupied by one, unseen by the rest; unseen by all; occupied by all;
  // freed by one and occupied by another; occupied by one and freed by the third.
  const OccupancyMap a = mapOf(g, {F, O, U, O, F, O});
  const OccupancyMap b = mapOf(g, {U, U, U, O, O, U});
  const OccupancyMap c = mapOf(g, {O, U, U, O, U, F});
  MapMerger merger(g, {g, g, g});
  OccupancyMap merged(g);
  merger.merge({&a, &b, &c}, merged);
  EXPECT_EQ(merged.cells, (std::vector<CellState>{F, O, U, O, F, F}));
  // Whatever the order of the inputs.
  OccupancyMap again(g);
  merger.merge({&c, &a, &b}, again);
  EXPECT_EQ(again.cells, merged.cells);
  // An input that is down sees nothing: its cells turn unseen where no other sees them.
  merger.merge({&a, nullptr, nullptr}, merged);
  EXPECT_EQ(merged.cells, a.cells);
  merger.merge({nullptr, nullptr, nullptr}, merged);
  EXPECT_EQ(merged.cells, (std::vector<CellState>(6, U)));
}

TEST(MapMerger, InputsOfAnotherGeometryAreResampled) {
  // The merged map: 8 cells of 0.5 m from x = 0. The input: 3 cells of 1 m from x = 1 (covering
  // x 1..4): merged cell i (centre 0.25 + 0.5 i) takes the input cell under its centre.
  const MapGeometry merged_geometry{0.0, 0.0, 0.5, 8, 1};
  const MapGeometry input_geometry{1.0, 0.0, 1.0, 3, 1};
  const OccupancyMap input = mapOf(input_geometry, {F, O, U});
  MapMerger merger(merged_geometry, {input_geometry});
  OccupancyMap merged(merged_geometry);
  merger.merge({&input}, merged);
  EXPECT_EQ(merged.cells, (std::vector<CellState>{U, U, F, F, O, O, U, U}));
  // Maps of the wrong size are refused, not read past their end.
  const OccupancyMap wrong(strip(2));
  EXPECT_THROW(merger.merge({&wrong}, merged), std::invalid_argument);
}

// The merged map kept up to date input by input is, after every update, the rule applied afresh
// to every input's current map: inputs finer, coarser, shifted and partly off the merged map, maps
// changing and inputs going down and up at random.
TEST(MapMerger, KeptUpToDateInputByInputAndReshapedItIsTheRuleAppliedAfresh) {
  const MapGeometry merged_geometry{0.0, 0.0, 0.1, 40, 30};
  std::vector<MapGeometry> inputs = {{0.0, 0.0, 0.1, 40, 30},    // the same
                                     {-0.5, 1.0, 0.05, 50, 30},  // finer, off the edge
                                     {1.0, -0.3, 0.25, 10, 10},  // coarser, shifted
                                     {3.5, 2.5, 0.1, 20, 20}};   // partly beyond the map
  MapMerger merger(merged_geometry, inputs);
  // Now and then an input's maps change geometry (a PC reconfigured): it takes one of these.
  const std::vector<MapGeometry> others = {{0.5, 0.5, 0.1, 20, 20}, {-1.0, -1.0, 0.2, 30, 25}};
  std::vector<OccupancyMap> maps;
  for (const MapGeometry& g : inputs) maps.emplace_back(g);
  std::vector<bool> up(inputs.size(), false);
  std::uint32_t state = 7;
  const auto next = [&](std::uint32_t n) {
    state = state * 1664525u + 1013904223u;
    return (state >> 8) % n;
  };
  for (int step = 0; step < 200; ++step) {
    const std::size_t k = next(static_cast<std::uint32_t>(inputs.size()));
    if (step % 23 == 22) {
      inputs[k] = others[next(2)];
      maps[k] = OccupancyMap(inputs[k], U);
      merger.reshape(k, inputs[k]);  // down until its next map
      up[k] = false;
    } else {
      up[k] = next(5) != 0;
    }
    for (CellState& cell : maps[k].cells) {
      if (next(4) == 0) cell = static_cast<CellState>(next(3));
    }
    if (step % 23 != 22) merger.update(k, up[k] ? &maps[k] : nullptr);
    // The rule afresh, cell by cell.
    for (int row = 0; row < merged_geometry.height; ++row) {
      for (int column = 0; column < merged_geometry.width; ++column) {
        const Eigen::Vector2d centre = merged_geometry.cellCentre(row, column);
        bool freed = false, seen = false;
        for (std::size_t j = 0; j < inputs.size(); ++j) {
          const std::optional<int> cell = inputs[j].cellAt(centre.x(), centre.y());
          if (!up[j] || !cell) continue;
          const CellState s = maps[j].cells[static_cast<std::size_t>(*cell)];
          freed = freed || s == F;
          seen = seen || s != U;
        }
        ASSERT_EQ(merger.merged().at(row, column), freed  ? F
                                                   : seen ? O
                                                          : U)
            << "step " << step << ", cell " << row << ", " << column;
      }
    }
  }
}

TEST(MergeInputs, AnInputStaleByMaxAgeIsDownAndFreshAgainWithItsNextMap) {
  MergeInputs inputs(2, 0.150);
  EXPECT_FALSE(inputs.fresh(0));  // nothing heard yet
  // Both at 30 Hz, 30 ms on the way; input 1 stops after its map of t = 1 s and comes back at 2 s.
  for (int frame = 0; frame <= 90; ++frame) {
    const double t = frame / 30.0;
    inputs.heard(0, t, t + 0.030);
    if (frame <= 30 || frame >= 60) inputs.heard(1, t, t + 0.030);
    if (frame == 33) {
      EXPECT_TRUE(inputs.fresh(1)) << t;  // 0.1 s behind
    } else if (frame == 36) {
      EXPECT_FALSE(inputs.fresh(1)) << t;  // 0.2 s behind: down
    } else if (frame == 60) {
      EXPECT_TRUE(inputs.fresh(1)) << t;  // its next map
    }
    EXPECT_TRUE(inputs.fresh(0)) << t;
  }
  // A map reordered on the way does not make the input older.
  inputs.heard(1, 2.5, 3.1);
  EXPECT_EQ(*inputs.captureS(1), 3.0);
}

TEST(MergeInputs, ClockOffsetsAreFoundFromTheLeastLag) {
  MergeInputs inputs(2, 0.150);
  // Input 1's clock runs 25 ms ahead; both take 20 to 45 ms from capture to the node.
  std::uint32_t state = 1;
  const auto latency = [&] {
    state = state * 1664525u + 1013904223u;
    return 0.020 + 0.025 * (state >> 8) / double{1u << 24};
  };
  for (int frame = 0; frame < 300; ++frame) {
    const double t = frame / 30.0;
    inputs.heard(0, t, t + latency());
    inputs.heard(1, t + 0.025, t + latency());
  }
  // Ahead, input 1's maps seem to arrive 25 ms sooner: its lag is the smaller, and the offsets are
  // counted from it, so input 0 shows the 25 ms (the offsets say how far apart the clocks are).
  EXPECT_NEAR(*inputs.clockOffsetS(1), 0.0, 1e-12);
  EXPECT_NEAR(*inputs.clockOffsetS(0), 0.025, 0.003);
  EXPECT_GT(std::abs(*inputs.clockOffsetS(0) - *inputs.clockOffsetS(1)),
            MergeInputs::kOffsetWarningS);
  // Its clock is corrected (stepped back by 25 ms): the estimate follows at 1 ms a second.
  for (int frame = 300; frame < 300 + 40 * 30; ++frame) {
    const double t = frame / 30.0;
    inputs.heard(0, t, t + latency());
    inputs.heard(1, t, t + latency());
  }
  EXPECT_NEAR(*inputs.clockOffsetS(0) - *inputs.clockOffsetS(1), 0.0, 0.003);
}

// The replay config with only the cameras named, and the carving height given.
std::string camerasOf(const std::string& replay, const std::vector<std::string>& names,
                      const std::string& column_height) {
  const std::size_t cameras = replay.find("cameras:\n");
  std::string text = replay.substr(0, cameras + 9);
  for (std::size_t at = replay.find("  - name: ", cameras); at != std::string::npos;) {
    const std::size_t next = replay.find("  - name: ", at + 1);
    const std::string entry = replay.substr(at, next == std::string::npos ? next : next - at);
    for (const std::string& name : names) {
      if (entry.starts_with("  - name: " + name + "\n")) text += entry;
    }
    at = next;
  }
  const std::string column = "column_height_m: 0.3";
  text.replace(text.find(column), column.size(), "column_height_m: " + column_height);
  return text;
}

TEST(OccmapMerge, TwoPcsMapsMergeIntoTheMapOfOnePcWithAllTheirCameras) {
  const testing::TemporaryFolder folder;
  const fs::path recorded = folder / "recorded";
  auto result = runCommand(
      {kOccmap, "record", "--config", kRoomConfig, "--frames", "12", "--out", recorded.string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::string replay = testing::readWhole(recorded / "replay.yaml");
  for (const std::string mode : {"0", "0.3"}) {  // floor and column carving
    const std::vector<std::pair<std::string, std::vector<std::string>>> pcs = {
        {"all", {"c0", "c1", "c2", "c3"}}, {"west", {"c0", "c1"}}, {"east", {"c2", "c3"}}};
    for (const auto& [pc, cameras] : pcs) {
      std::ofstream(recorded / (pc + ".yaml")) << camerasOf(replay, cameras, mode);
      result = runCommand({kOccmap, "fuse", "--config", (recorded / (pc + ".yaml")).string(),
                           "--out", (folder / (pc + mode)).string()});
      ASSERT_EQ(result.exit_code, 0) << pc << " " << mode << ": " << result.err;
    }
    result = runCommand({kOccmap, "merge", "--input", (folder / ("west" + mode)).string(),
                         "--input", (folder / ("east" + mode)).string(), "--out",
                         (folder / ("merged" + mode)).string()});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    EXPECT_NE(result.out.find("merged 12 maps of 2 inputs"), std::string::npos) << result.out;
    long long cells = 0, differ = 0, occupied = 0;
    for (int k = 0; k < 12; ++k) {
      char name[32];
      std::snprintf(name, sizeof name, "map_%06d.png", k);
      const cv::Mat all =
          cv::imread((folder / ("all" + mode) / name).string(), cv::IMREAD_GRAYSCALE);
      const cv::Mat merged =
          cv::imread((folder / ("merged" + mode) / name).string(), cv::IMREAD_GRAYSCALE);
      ASSERT_FALSE(all.empty() || merged.empty()) << name;
      cells += all.rows * all.cols;
      differ += cv::countNonZero(all != merged);
      occupied += cv::countNonZero(all == 255);
    }
    EXPECT_EQ(differ, 0) << "column height " << mode;
    EXPECT_GT(occupied, 0) << "the maps hold occupied cells, or the test would say little";
    std::printf("column height %s m: %lld cells, %lld differ\n", mode.c_str(), cells, differ);
  }
}

}  // namespace
}  // namespace occmap
