// occmap calibrate intrinsics / board: a camera's intrinsics from pictures of a printed board, and
// the board to print.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <glob.h>
#include <opencv2/imgcodecs.hpp>

#include "calibrate/board.h"
#include "calibrate/intrinsics.h"
#include "capture/image_file.h"
#include "config/calibration_file.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "tools/commands.h"

namespace occmap::tools {
namespace {

constexpr const char* kSpecHelp =
    "SPEC names the printed board:\n"
    "  charuco:COLUMNSxROWS:SQUARE_M:MARKER_M:DICTIONARY  a ChArUco board of COLUMNS x ROWS "
    "squares, SQUARE_M metres each, with ArUco markers of MARKER_M metres (smaller than the "
    "square) from OpenCV's DICTIONARY (DICT_4X4_50, DICT_5X5_100, DICT_6X6_250, ...). Partly seen "
    "boards count, so pictures can reach the image's corners.\n"
    "  chessboard:COLUMNSxROWS:SQUARE_M  a chessboard of COLUMNS x ROWS inner corners (where four "
    "squares meet), SQUARE_M metres each; it must be whole in every picture.\n";

struct IntrinsicsOptions {
  std::vector<std::string> images;
  std::string board;
  std::string out;
};

struct BoardOptions {
  std::string board;
  std::string out;
  double dpi = 300.0;
};

BoardSpec boardOption(const std::string& text) {
  std::string error;
  const std::optional<BoardSpec> spec = parseBoardSpec(text, error);
  if (!spec) throw InputError("", 0, "--board " + text, error);
  return *spec;
}

// Each pattern's files, sorted, in the order given (a shell that expanded the pattern itself
// hands over the files, which match themselves).
std::vector<std::filesystem::path> imageFiles(const std::vector<std::string>& patterns) {
  std::vector<std::filesystem::path> files;
  for (const std::string& pattern : patterns) {
    glob_t matches{};
    const int status = ::glob(pattern.c_str(), 0, nullptr, &matches);
    if (status == 0) {
      for (std::size_t i = 0; i < matches.gl_pathc; ++i) files.emplace_back(matches.gl_pathv[i]);
    }
    ::globfree(&matches);
    if (status != 0) {
      throw InputError("", 0, "--images",
                       "no file matches '" + pattern +
                           "': give the pictures' files or a pattern in quotes, e.g. --images "
                           "'shots/*.png'");
    }
  }
  return files;
}

void printViews(const std::vector<std::filesystem::path>& files, const IntrinsicsReport& report,
                const BoardSpec& spec) {
  std::printf("%-40s %8s %9s\n", "picture", "corners", "error px");
  for (std::size_t i = 0; i < files.size(); ++i) {
    const ViewReport& view = report.views[i];
    if (view.used && report.refusal.empty()) {
      std::printf("%-40s %8d %9.3f\n", files[i].c_str(), view.corners, view.rms_px);
    } else {
      std::printf("%-40s %8d %9s  %s\n", files[i].c_str(), view.corners, "-",
                  view.used ? "usable" : view.why_not.c_str());
    }
  }
  std::printf(
      "%d usable of %zu pictures (a board has %d corners); together they cover %.0f %% of "
      "the image\n",
      report.usable_views, files.size(), spec.cornerCount(), 100.0 * report.covered_share);
}

int runIntrinsics(const IntrinsicsOptions& o) {
  const BoardSpec spec = boardOption(o.board);
  const std::vector<std::filesystem::path> files = imageFiles(o.images);
  std::vector<BoardCorners> views;
  cv::Size image_size;
  std::filesystem::path first;
  int with_board = 0;
  for (std::size_t i = 0; i < files.size(); ++i) {
    std::string error;
    const std::optional<Image> image = readGreyImage(files[i], error);
    if (!image) {
      // readGreyImage's message names the file already.
      throw InputError("", 0, "--images", error + ": replace the picture or leave it out");
    }
    const cv::Size size(image->width(), image->height());
    if (i == 0) {
      image_size = size;
      first = files[i];
    } else if (size != image_size) {
      throw InputError(files[i].string(), 0, "",
                       "this picture is " + std::to_string(size.width) + "x" +
                           std::to_string(size.height) + " but " + first.string() + " is " +
                           std::to_string(image_size.width) + "x" +
                           std::to_string(image_size.height) +
                           ": calibrate one camera at one resolution at a time");
    }
    // The Image outlives the view; OpenCV only reads it.
    const cv::Mat grey(size, CV_8UC1, const_cast<std::uint8_t*>(image->data()));
    views.push_back(findBoardCorners(spec, grey));
    if (!views.back().empty()) ++with_board;
    std::fprintf(stderr, "occmap calibrate intrinsics: picture %zu of %zu, %s: %zu of %d corners\n",
                 i + 1, files.size(), files[i].c_str(), views.back().size(), spec.cornerCount());
  }
  if (with_board == 0) {
    // The pictures by name (the first three), so that a pattern that matched the wrong files shows.
    std::string named;
    for (std::size_t i = 0; i < std::min<std::size_t>(files.size(), 3); ++i) {
      named += (i == 0 ? "" : ", ") + files[i].string();
    }
    if (files.size() > 3) named += " and " + std::to_string(files.size() - 3) + " more";
    throw InputError("", 0, "--images",
                     "the board " + boardSpecText(spec) + " is in none of the " +
                         std::to_string(files.size()) + " pictures (" + named +
                         "): check that --board says the printed board (kind; "
                         "COLUMNSxROWS counts squares for charuco, inner corners for chessboard; "
                         "the dictionary) and that the board is sharp, well lit and, for a "
                         "chessboard, whole in the picture");
  }
  const IntrinsicsResult result = calibrateIntrinsics(spec, views, image_size);
  const IntrinsicsReport& report = result.report;
  printViews(files, report, spec);
  if (!result.camera) throw InputError("", 0, "--images", report.refusal);

  const OpenCvParameters& camera = *result.camera;
  std::printf("RMS reprojection error %.3f px\n", report.rms_px);
  std::printf("fx %.3f +- %.3f  fy %.3f +- %.3f  cx %.3f +- %.3f  cy %.3f +- %.3f px\n", camera.fx,
              report.fx_sigma_px, camera.fy, report.fy_sigma_px, camera.cx, report.cx_sigma_px,
              camera.cy, report.cy_sigma_px);
  const auto& k = camera.distortion;  // the usual model: k1 k2 p1 p2 k3, the rest zero
  std::printf("distortion k1 %.6g  k2 %.6g  p1 %.6g  p2 %.6g  k3 %.6g\n", k[0], k[1], k[2], k[3],
              k[4]);
  const double turn_deg = principalPointTurnDeg(camera, report);
  if (turn_deg > kPrincipalTurnWarningDeg) {
    std::fprintf(stderr,
                 "occmap calibrate intrinsics: warning: the principal point is known to +- %.1f "
                 "px (one standard deviation), which alone may turn the pose found from it by "
                 "%.2f degrees: take more pictures, tilted more and out to the picture's corners, "
                 "or use a chessboard, whose corners are found more precisely than a ChArUco "
                 "board's (docs/calibration.md)\n",
                 std::max(report.cx_sigma_px, report.cy_sigma_px), turn_deg);
  }
  if (report.rms_px > 1.0) {
    std::fprintf(stderr,
                 "occmap calibrate intrinsics: warning: an error over 1 px: look for blurred "
                 "pictures, a board that is not flat, or a square size in --board that is not the "
                 "printed one (the pictures with the largest errors first)\n");
  }
  std::ofstream out(o.out);
  out << openCvYamlText(camera);
  out.close();
  if (!out) {
    std::fprintf(stderr, "occmap calibrate intrinsics: failed: cannot write %s\n", o.out.c_str());
    return kExitFailure;
  }
  std::printf("wrote %s (rvec and tvec are zero: the camera's pose is not calibrated yet)\n",
              o.out.c_str());
  return kExitOk;
}

int runBoard(const BoardOptions& o) {
  const BoardSpec spec = boardOption(o.board);
  if (!(o.dpi >= 50.0 && o.dpi <= 2400.0)) {
    throw InputError("", 0, "--dpi", "give the printer's resolution in dots per inch, 50 to 2400");
  }
  constexpr double kMetresPerInch = 0.0254;
  const int pixels_per_metre = static_cast<int>(std::lround(o.dpi / kMetresPerInch));
  const int square = squarePixels(spec, pixels_per_metre);
  // OpenCV's chessboard detectors want a white border about a square wide; markers need less.
  const int margin = spec.kind == BoardKind::kChessboard ? square : square / 2;
  const cv::Mat picture = boardPicture(spec, pixels_per_metre, margin);
  bool written = false;
  try {
    written = cv::imwrite(o.out, picture);
  } catch (const cv::Exception& e) {
    std::fprintf(stderr, "occmap calibrate board: failed: cannot write %s: %s\n", o.out.c_str(),
                 e.what());
    return kExitFailure;
  }
  if (!written) {
    std::fprintf(stderr, "occmap calibrate board: failed: cannot write %s\n", o.out.c_str());
    return kExitFailure;
  }
  const double mm_per_pixel = 25.4 / o.dpi;
  const double width_mm = picture.cols * mm_per_pixel;
  const double height_mm = picture.rows * mm_per_pixel;
  std::printf(
      "wrote %s: %d x %d pixels; printed at %.0f dpi and 100 %% scale (not 'fit to page') it is "
      "%.1f x %.1f mm with its white margin, squares of %.2f mm",
      o.out.c_str(), picture.cols, picture.rows, o.dpi, width_mm, height_mm, square * mm_per_pixel);
  if (spec.kind == BoardKind::kCharuco) {
    std::printf(", markers of about %.2f mm", spec.marker_m * 1000.0);
  }
  std::printf(
      ".\nMeasure a printed square across several squares with a ruler, and give what you measure "
      "in --board when calibrating; glue the print to something flat and rigid.\n");
  if (std::min(width_mm, height_mm) > 210.0 || std::max(width_mm, height_mm) > 297.0) {
    std::printf(
        "It is larger than A4 (210 x 297 mm): print it on larger paper, or choose smaller "
        "squares or fewer of them.\n");
  }
  return kExitOk;
}

}  // namespace

Command addCalibrateIntrinsicsCommand(CLI::App& calibrate) {
  auto intrinsics_options = std::make_shared<IntrinsicsOptions>();
  CLI::App* intrinsics = calibrate.add_subcommand(
      "intrinsics",
      std::string(
          "A camera's focal lengths, principal point and lens distortion from its pictures of a "
          "printed board (make one with 'occmap calibrate board').\n"
          "Take 15 to 25 sharp pictures at the resolution the camera will run at, the board "
          "flat and still, tilted up to about 40 degrees in different directions, near the "
          "image's corners and edges as well as its centre. Pictures that show no board are left "
          "out.\n"
          "Prints the RMS reprojection error and each picture's; writes the OpenCV YAML "
          "calibration occmap reads (image size, camera_matrix, 5 distortion coefficients k1 k2 "
          "p1 p2 k3; rvec and tvec zero, as the pose is not calibrated yet).\n"
          "Refused (exit 2) with fewer than 6 usable pictures, or when the board's pictures "
          "together cover less than half of the image or never reach one of the nine parts of a "
          "3 x 3 grid over it (corners, edges, centre).\n\n") +
          kSpecHelp +
          "\nExample:\n"
          "  occmap calibrate intrinsics --images 'shots/*.png' "
          "--board charuco:7x5:0.04:0.03:DICT_4X4_50 --out calib/c0.yaml");
  intrinsics
      ->add_option("--images", intrinsics_options->images,
                   "The pictures: files or patterns in quotes ('shots/*.png'), each sorted by name")
      ->required();
  intrinsics->add_option("--board", intrinsics_options->board, "The board's SPEC (above)")
      ->required();
  intrinsics->add_option("--out", intrinsics_options->out, "The calibration file to write (.yaml)")
      ->required();
  return [intrinsics_options] { return runIntrinsics(*intrinsics_options); };
}

Command addCalibrateBoardCommand(CLI::App& calibrate) {
  auto board_options = std::make_shared<BoardOptions>();
  CLI::App* board = calibrate.add_subcommand(
      "board",
      std::string("The picture of a calibration board to print (PNG), and its printed size.\n"
                  "Print it at the given resolution and 100 % scale, measure a square, and give "
                  "that size in --board to 'occmap calibrate intrinsics'.\n\n") +
          kSpecHelp +
          "\nExamples:\n"
          "  occmap calibrate board --board charuco:7x5:0.03:0.022:DICT_4X4_50 --out board.png\n"
          "  occmap calibrate board --board chessboard:9x6:0.02 --out board.png --dpi 600");
  board->add_option("--board", board_options->board, "The board's SPEC (above)")->required();
  board->add_option("--out", board_options->out, "The PNG to write")->required();
  board->add_option("--dpi", board_options->dpi, "The printer's resolution (default 300)");
  return [board_options] { return runBoard(*board_options); };
}

}  // namespace occmap::tools
