// Real data: EPFL Terrace (../shared/data/epfl-terrace). With column carving every annotated person
// keeps an occupied cell within 20 cm of the annotated position while the floor a camera sees far
// from them is free; the floor point alone is printed for comparison. Runs the example config
// examples/epfl-terrace.yaml through `occmap fuse`, with its data paths pointed at wherever this
// build found ../shared/data.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "command_runner.h"

namespace occmap {
namespace {

namespace fs = std::filesystem;
using testing::readWhole;
using testing::runCommand;
using testing::TemporaryFolder;
using testing::writeText;

const fs::path kData = OCCMAP_SHARED_DATA;

struct Annotation {
  int moment;
  double x_m, y_m;
};

std::vector<Annotation> readGroundTruth() {
  std::ifstream in(kData / "epfl-terrace" / "gt.txt");
  std::vector<Annotation> annotations;
  int moment = 0, source_frame = 0;
  double x_mm = 0, y_mm = 0;
  while (in >> moment >> source_frame >> x_mm >> y_mm) {
    annotations.push_back({moment, x_mm / 1000.0, y_mm / 1000.0});
  }
  return annotations;
}

// The example config, made to read the data where this build found it.
std::string exampleConfig(double column_height_m) {
  std::string text = readWhole(fs::path(OCCMAP_SOURCE_DIR) / "examples" / "epfl-terrace.yaml");
  auto replace_all = [&](const std::string& from, const std::string& to) {
    for (std::size_t at = text.find(from); at != std::string::npos;
         at = text.find(from, at + to.size())) {
      text.replace(at, from.size(), to);
    }
  };
  replace_all("../../shared/data", fs::weakly_canonical(kData).string());
  // A path, not a concatenation: GCC 12's -Warray-bounds misreads the inlined operator+ here.
  replace_all("epfl-terrace/black",
              (fs::path(OCCMAP_SOURCE_DIR) / "examples" / "epfl-terrace" / "black").string());
  std::ostringstream height;
  height << "column_height_m: " << column_height_m;
  replace_all("column_height_m: 0.3", height.str());
  return text;
}

// What one run of `occmap fuse` on the sample gives, against the annotations.
struct TerraceScore {
  int people_found = 0;  // annotated people with an occupied cell within 20 cm
  // Cells a camera sees (not UNSEEN), over the annotated moments, whose centres are more than
  // 1 m from every person annotated at that moment: where the map must be free.
  std::uint64_t far_seen = 0, far_seen_free = 0;
  std::uint64_t cells = 0, occupied = 0;  // over every map written

  double farSeenFreeShare() const {
    return far_seen == 0 ? 0.0 : static_cast<double>(far_seen_free) / static_cast<double>(far_seen);
  }
  double occupiedShare() const {
    return cells == 0 ? 0.0 : static_cast<double>(occupied) / static_cast<double>(cells);
  }
};

constexpr double kFoundRadius = 0.2;  // m, the README's promise
constexpr double kFarRadius = 1.0;    // m, well past a person and the annotation grid's ±12.5 cm

TerraceScore score(double column_height_m, const std::vector<Annotation>& annotations) {
  TemporaryFolder folder;
  writeText(folder / "terrace.yaml", exampleConfig(column_height_m));
  const auto result =
      runCommand({OCCMAP_BINARY_DIR "/tools/occmap", "fuse", "--config",
                  (folder / "terrace.yaml").string(), "--out", (folder / "maps").string()});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("wrote 10 maps"), std::string::npos) << result.out;
  // The map as examples/epfl-terrace.yaml defines it.
  const double origin_x = -0.5, origin_y = -1.5, cell = 0.025;
  const auto centre = [&](int row, int column) {
    return std::pair(origin_x + (column + 0.5) * cell, origin_y + (row + 0.5) * cell);
  };
  TerraceScore score;
  for (int moment = 0; moment < 10; ++moment) {
    char name[32];
    std::snprintf(name, sizeof name, "map_%06d.png", moment);
    const cv::Mat map = cv::imread((folder / "maps" / name).string(), cv::IMREAD_UNCHANGED);
    if (map.empty()) {
      ADD_FAILURE() << "no " << name;
      continue;
    }
    score.cells += map.total();
    score.occupied += static_cast<std::uint64_t>(cv::countNonZero(map == 255));
    std::vector<Annotation> people;
    for (const Annotation& a : annotations) {
      if (a.moment == moment) people.push_back(a);
    }
    // Moments without annotations (0 and 1) may still show people: no cell there is "far".
    for (int row = 0; row < map.rows && !people.empty(); ++row) {
      for (int column = 0; column < map.cols; ++column) {
        const auto [x, y] = centre(row, column);
        const std::uint8_t state = map.at<std::uint8_t>(row, column);
        const bool far = std::all_of(people.begin(), people.end(), [&](const Annotation& a) {
          return std::hypot(x - a.x_m, y - a.y_m) > kFarRadius;
        });
        if (far && state != 128) {
          ++score.far_seen;
          score.far_seen_free += state == 0 ? 1 : 0;
        }
      }
    }
    for (const Annotation& a : people) {
      bool occupied = false;
      for (int row = 0; row < map.rows && !occupied; ++row) {
        for (int column = 0; column < map.cols && !occupied; ++column) {
          const auto [x, y] = centre(row, column);
          occupied = std::hypot(x - a.x_m, y - a.y_m) <= kFoundRadius &&
                     map.at<std::uint8_t>(row, column) == 255;
        }
      }
      std::printf("  column %.2f m, moment %d, person at (%.3f, %.3f) m: %s\n", column_height_m,
                  a.moment, a.x_m, a.y_m, occupied ? "occupied cell within 20 cm" : "MISSED");
      score.people_found += occupied ? 1 : 0;
    }
  }
  std::printf(
      "  column %.2f m: %.2f %% of seen cells over 1 m from every annotated person free; "
      "%.2f %% of all cells occupied\n",
      column_height_m, 100 * score.farSeenFreeShare(), 100 * score.occupiedShare());
  return score;
}

// gt.txt annotates 8 of the 10 moments (2 to 9, one person each; see ../shared/data/README.md):
// every one of them must be found, and finding them must not come from a map that is occupied
// everywhere, so the floor away from them must be free where a camera sees it.
TEST(EpflTerrace, ColumnCarvingFindsEveryAnnotatedPersonAndClearsTheRest) {
  if (!fs::exists(kData / "epfl-terrace" / "gt.txt")) {
    GTEST_SKIP() << "EPFL Terrace data not found at " << (kData / "epfl-terrace").string()
                 << " (the shared reference data sits next to the repository as ../shared/data)";
  }
  const std::vector<Annotation> annotations = readGroundTruth();
  ASSERT_EQ(annotations.size(), 8u) << "gt.txt annotates 8 moments, one person each";
  const TerraceScore floor = score(0.0, annotations);
  const TerraceScore column = score(0.3, annotations);
  std::printf(
      "people with an occupied cell within 20 cm: floor point %d of %zu, 0.3 m columns "
      "%d of %zu\n",
      floor.people_found, annotations.size(), column.people_found, annotations.size());
  EXPECT_EQ(column.people_found, static_cast<int>(annotations.size()));
  // A map that kept much of the floor occupied would find every person too; these bounds catch
  // it. Measured with 0.3 m columns: 98.37 % of the seen cells over 1 m from the annotated person
  // are free, and 1.45 % of all cells are occupied (floor point: 98.46 % and 1.22 %).
  EXPECT_GE(column.farSeenFreeShare(), 0.95)
      << "the floor far from every annotated person should be free where a camera sees it";
  EXPECT_LE(column.occupiedShare(), 0.05) << "the map is mostly occupied";
}

// People found on the map (occmap detect, core/footprints.h), scored with occmap score against
// EPFL's truth (docs/detection.md), on the sample and on the crowd set: the example config as it
// is, only its cameras' sources changed for the crowd. Reference on the crowd: EPFL's POM, MODA
// 66.0 %, MODP 59.2 %, precision 90.4 %, recall 73.9 % (../shared/data/README.md).
nlohmann::json detectAndScore(const TemporaryFolder& folder, const std::string& set, int moments) {
  std::string config = exampleConfig(0.3);
  if (set != "epfl-terrace") {
    for (std::size_t at = config.find("epfl-terrace/masks"); at != std::string::npos;
         at = config.find("epfl-terrace/masks", at + 1)) {
      config.replace(at, std::string("epfl-terrace").size(), set);
    }
  }
  const fs::path config_file = folder / (set + ".yaml");
  writeText(config_file, config);
  const std::string occmap = OCCMAP_BINARY_DIR "/tools/occmap";
  const fs::path detections = folder / (set + "-detections.csv");
  const fs::path truth = folder / (set + "-truth.csv");
  const testing::CommandResult detected = runCommand(
      {occmap, "detect", "--config", config_file.string(), "--out", detections.string()});
  EXPECT_EQ(detected.exit_code, 0) << detected.err;
  const testing::CommandResult converted = runCommand(
      {occmap, "truth", "--epfl", (kData / set / "gt.txt").string(), "--out", truth.string()});
  EXPECT_EQ(converted.exit_code, 0) << converted.err;
  const testing::CommandResult scored =
      runCommand({occmap, "score", "--truth", truth.string(), "--detections", detections.string(),
                  "--frames", std::to_string(moments), "--json"});
  EXPECT_EQ(scored.exit_code, 0) << scored.err;
  const nlohmann::json score = nlohmann::json::parse(scored.out);
  std::printf(
      "%s, %d moments: MODA %.1f %%, MODP %.1f %%, precision %.1f %%, recall %.1f %% (%d "
      "people, %d detections)\n",
      set.c_str(), moments, 100 * score["moda"].get<double>(), 100 * score["modp"].get<double>(),
      100 * score["precision"].get<double>(), 100 * score["recall"].get<double>(),
      score["people"].get<int>(), score["detections"].get<int>());
  return score;
}

TEST(EpflTerrace, PeopleAreFoundAsWellAsPomFindsThemInTheCrowd) {
  if (!fs::exists(kData / "epfl-terrace-crowd" / "gt.txt") ||
      !fs::exists(kData / "epfl-terrace" / "gt.txt")) {
    GTEST_SKIP() << "EPFL Terrace data not found at " << kData.string()
                 << " (the shared reference data sits next to the repository as ../shared/data)";
  }
  TemporaryFolder folder;
  // Measured 2026-12-07: the sample 87.5 % MODA (7 of 8 people, no false positive); the crowd
  // MODA 81.3 %, MODP 64.8 %, precision 94.8 %, recall 86.1 % (before places two cameras alone
  // see were judged more strictly, two_view_min_own: 79.5 %, 64.9 %, 90.1 %, 89.2 %; before
  // people settled beside each other: 73.9 %, 61.8 %, 86.6 %, 87.3 %). The target on
  // further moments: MODA 70 % with precision 90 %, which the precision here holds with a margin.
  const nlohmann::json sample = detectAndScore(folder, "epfl-terrace", 10);
  EXPECT_GE(sample["recall"].get<double>(), 0.75);
  const nlohmann::json crowd = detectAndScore(folder, "epfl-terrace-crowd", 94);
  EXPECT_EQ(crowd["people"].get<int>(), 482);
  EXPECT_GE(crowd["moda"].get<double>(), 0.70) << "POM scores 0.660 here";
  EXPECT_GE(crowd["modp"].get<double>(), 0.592) << "POM's";
  EXPECT_GE(crowd["precision"].get<double>(), 0.93);
  EXPECT_GE(crowd["recall"].get<double>(), 0.80);
}

}  // namespace
}  // namespace occmap
