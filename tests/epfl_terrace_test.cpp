// Real data: EPFL Terrace (../shared/data/epfl-terrace). With column carving every annotated person
// keeps an occupied cell within 20 cm of the annotated position; the floor point alone is printed
// for comparison. Runs the example config examples/epfl-terrace.yaml through `occmap fuse`, with
// its data paths pointed at wherever this build found ../shared/data.
#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
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
  replace_all("epfl-terrace/black",
              std::string(OCCMAP_SOURCE_DIR) + "/examples/epfl-terrace/black");
  std::ostringstream height;
  height << "column_height_m: " << column_height_m;
  replace_all("column_height_m: 0.3", height.str());
  return text;
}

// How many annotated people keep an occupied cell within `radius` of their annotated position.
int peopleFound(double column_height_m, const std::vector<Annotation>& annotations, double radius) {
  TemporaryFolder folder;
  writeText(folder / "terrace.yaml", exampleConfig(column_height_m));
  const auto result =
      runCommand({OCCMAP_BINARY_DIR "/tools/occmap", "fuse", "--config",
                  (folder / "terrace.yaml").string(), "--out", (folder / "maps").string()});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("wrote 10 maps"), std::string::npos) << result.out;
  // The map as examples/epfl-terrace.yaml defines it.
  const double origin_x = -0.5, origin_y = -1.5, cell = 0.025;
  int found = 0;
  for (const Annotation& a : annotations) {
    char name[32];
    std::snprintf(name, sizeof name, "map_%06d.png", a.moment);
    const cv::Mat map = cv::imread((folder / "maps" / name).string(), cv::IMREAD_UNCHANGED);
    if (map.empty()) {
      ADD_FAILURE() << "no " << name;
      continue;
    }
    bool occupied = false;
    for (int row = 0; row < map.rows && !occupied; ++row) {
      for (int column = 0; column < map.cols && !occupied; ++column) {
        const double x = origin_x + (column + 0.5) * cell;
        const double y = origin_y + (row + 0.5) * cell;
        if (std::hypot(x - a.x_m, y - a.y_m) <= radius &&
            map.at<std::uint8_t>(row, column) == 255) {
          occupied = true;
        }
      }
    }
    std::printf("  column %.2f m, moment %d, person at (%.3f, %.3f) m: %s\n", column_height_m,
                a.moment, a.x_m, a.y_m, occupied ? "occupied cell within 20 cm" : "MISSED");
    found += occupied ? 1 : 0;
  }
  return found;
}

TEST(EpflTerrace, ColumnCarvingFindsEveryAnnotatedPerson) {
  if (!fs::exists(kData / "epfl-terrace" / "gt.txt")) {
    GTEST_SKIP() << "EPFL Terrace data not found at " << (kData / "epfl-terrace").string()
                 << " (the shared reference data sits next to the repository as ../shared/data)";
  }
  const std::vector<Annotation> annotations = readGroundTruth();
  ASSERT_GE(annotations.size(), 8u);
  const int floor_found = peopleFound(0.0, annotations, 0.2);
  const int column_found = peopleFound(0.3, annotations, 0.2);
  std::printf(
      "people with an occupied cell within 20 cm: floor point %d of %zu, 0.3 m columns "
      "%d of %zu\n",
      floor_found, annotations.size(), column_found, annotations.size());
  EXPECT_EQ(column_found, static_cast<int>(annotations.size()));
}

}  // namespace
}  // namespace occmap
