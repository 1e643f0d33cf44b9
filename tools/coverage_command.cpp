// occmap coverage: which cameras see each cell, as a picture, for setting cameras up.
#include <bit>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/config.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "config/rig.h"
#include "tools/commands.h"
#include "tools/pictures.h"
#include "tools/progress.h"

namespace occmap::tools {
namespace {

struct CoverageOptions {
  std::string config;
  std::string out;
  std::optional<double> column_height;
};

int run(const CoverageOptions& o) {
  const Config config = loadConfig(o.config);
  if (config.cameras.size() > 32) {
    throw InputError(o.config, 0, "cameras", "coverage draws at most 32 cameras");
  }
  const PreparedRig prepared = prepareRigWithProgress(config, "coverage", o.column_height);
  const Rig& rig = prepared.rig;
  const std::vector<CarveTable>& tables = prepared.tables;
  const double column_height = prepared.column_height_m;
  const MapGeometry& map = config.map;
  std::vector<std::uint32_t> seen_by(map.cellCount(), 0);
  for (std::size_t k = 0; k < tables.size(); ++k) {
    for (std::size_t cell = 0; cell < map.cellCount(); ++cell) {
      if (tables[k].sees(cell)) seen_by[cell] |= 1u << k;
    }
  }
  // Each cell: the mean colour of the cameras that see it, brighter the more see it.
  const int scale = std::max(1, 600 / std::max(map.width, map.height));
  std::size_t counts[33] = {};
  for (const std::uint32_t mask : seen_by) ++counts[std::popcount(mask)];
  const cv::Mat cells = coverageCells(map, seen_by, tables.size());
  cv::Mat picture;
  cv::resize(cells, picture, cv::Size(), scale, scale, cv::INTER_NEAREST);
  drawScaleBar(picture, map, scale);
  // Cameras where they stand (if over the map), and a legend.
  for (std::size_t k = 0; k < rig.cameras().size(); ++k) {
    const Eigen::Vector3d centre = rig.cameras()[k].camera->centreMetres();
    const cv::Point at = floorPlanPoint(map, scale, centre.x(), centre.y());
    cv::circle(picture, at, 6, {255, 255, 255}, cv::FILLED);
    cv::circle(picture, at, 4, cameraColour(k), cv::FILLED);
  }
  const int legend_rows = static_cast<int>(rig.cameras().size()) + 2;
  cv::Mat legend(20 * legend_rows + 10, picture.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  std::printf("camera   cells seen   share of map\n");
  for (std::size_t k = 0; k < rig.cameras().size(); ++k) {
    const std::size_t seen = tables[k].cellsInView();
    const double share = 100.0 * static_cast<double>(seen) / static_cast<double>(map.cellCount());
    std::printf("%-8s %10zu   %6.2f %%\n", rig.cameras()[k].name.c_str(), seen, share);
    char line[128];
    std::snprintf(line, sizeof line, "%s: %.1f %% of the map", rig.cameras()[k].name.c_str(),
                  share);
    const int y = 20 * static_cast<int>(k) + 18;
    cv::rectangle(legend, {10, y - 11}, {24, y + 3}, cameraColour(k), cv::FILLED);
    cv::putText(legend, line, {32, y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 1, cv::LINE_AA);
  }
  std::size_t at_least[3] = {0, 0, 0};
  for (int n = 1; n <= 32; ++n) {
    for (int m = 1; m <= std::min(n, 2); ++m) at_least[m] += counts[n];
  }
  const double total = static_cast<double>(map.cellCount());
  char summary[160];
  std::snprintf(summary, sizeof summary,
                "seen by 1+ cameras: %.1f %%, by 2+: %.1f %%, by none: %.1f %% (column %.2g m)",
                100.0 * static_cast<double>(at_least[1]) / total,
                100.0 * static_cast<double>(at_least[2]) / total,
                100.0 * static_cast<double>(counts[0]) / total, column_height);
  std::printf("%s\n", summary);
  // How many see each cell seen: where two alone do, rays through two people's silhouettes meet
  // where no one stands, and the detector asks more of a person found there.
  if (at_least[1] > 0) {
    std::printf("of the cells seen, seen by exactly");
    for (std::size_t n = 1; n <= tables.size(); ++n) {
      std::printf("%s %zu: %.1f %%", n == 1 ? "" : ",", n,
                  100.0 * static_cast<double>(counts[n]) / static_cast<double>(at_least[1]));
    }
    std::printf(
        " (people found where no more than two cameras see must fill more of their "
        "boxes: footprints.two_view_min_own, docs/detection.md)\n");
  }
  // The summary in two lines, split after the first comma, so that it fits a small map's width.
  const std::string text(summary);
  const std::size_t split = text.find(", ") + 2;
  const int first_line = 20 * (legend_rows - 1) + 2;
  cv::putText(legend, text.substr(0, split), {10, first_line}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
              {0, 0, 0}, 1, cv::LINE_AA);
  cv::putText(legend, text.substr(split), {10, first_line + 18}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
              {0, 0, 0}, 1, cv::LINE_AA);
  cv::vconcat(picture, legend, picture);
  if (!cv::imwrite(o.out, picture)) {
    std::fprintf(stderr, "occmap coverage: cannot write %s\n", o.out.c_str());
    return kExitFailure;
  }
  std::printf("wrote %s (floor plan, +y up; brighter where more cameras see)\n", o.out.c_str());
  return kExitOk;
}

}  // namespace

Command addCoverageCommand(CLI::App& app) {
  auto options = std::make_shared<CoverageOptions>();
  CLI::App* command = app.add_subcommand(
      "coverage",
      "Which cameras see each cell of the map, as a picture, for setting cameras up.\n"
      "Draws the map as a floor plan (+y up), each cell in the mixed colour of the cameras that "
      "see it (brighter where more do; dark where none does), marks the cameras that stand over "
      "the map, and prints each camera's share of the map.\n\n"
      "Example:\n"
      "  occmap coverage --config examples/sim-room.yaml --out coverage.png");
  command->add_option("--config", options->config, "Config file (YAML; see README)")->required();
  command->add_option("--out", options->out, "Picture to write (PNG)")->required();
  command
      ->add_option("--column-height", options->column_height,
                   "Column height in metres (default: the config's fusion.column_height_m)")
      ->check(CLI::NonNegativeNumber);
  return [options] { return run(*options); };
}

}  // namespace occmap::tools
