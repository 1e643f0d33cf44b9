#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

namespace occmap {

// The printed board a camera is calibrated with, as the user names it on the command line:
//   charuco:7x5:0.04:0.03:DICT_4X4_50  7 x 5 squares of 0.04 m, ArUco markers of 0.03 m in the
//                                      white squares, from OpenCV's dictionary DICT_4X4_50
//   chessboard:9x6:0.025               9 x 6 inner corners (10 x 7 squares) of 0.025 m
// ChArUco corners are told apart by the markers beside them, so a board that is only partly in the
// picture still counts; a chessboard must be whole.
enum class BoardKind { kCharuco, kChessboard };

struct BoardSpec {
  BoardKind kind = BoardKind::kChessboard;
  int columns = 0;  // ChArUco: squares across; chessboard: inner corners across
  int rows = 0;     // likewise down
  double square_m = 0.0;
  double marker_m = 0.0;        // ChArUco only
  int dictionary = 0;           // ChArUco only: cv::aruco::PREDEFINED_DICTIONARY_NAME
  std::string dictionary_name;  // ChArUco only: "DICT_4X4_50"

  // The corners calibration uses: where four squares meet (ChArUco (columns-1) x (rows-1)).
  int cornerCount() const;
  // The squares printed across and down.
  int squaresAcross() const;
  int squaresDown() const;
};

// The SPEC text read; nothing, with `error` saying what is wrong and how to write it, for an
// unknown kind, sizes that are missing or not positive, a marker not smaller than its square, an
// unknown dictionary (the message lists the valid names) or one with too few markers.
std::optional<BoardSpec> parseBoardSpec(std::string_view text, std::string& error);
// The SPEC text of a board, as parseBoardSpec reads it.
std::string boardSpecText(const BoardSpec& spec);

// The board to print: white, the squares `pixels_per_metre` * square_m pixels each (rounded to a
// whole pixel; the squares' true printed size is squarePixels / pixels_per_metre), with a white
// margin of `margin_px` all round, which both detectors need. 8-bit grey.
cv::Mat boardPicture(const BoardSpec& spec, int pixels_per_metre, int margin_px);
int squarePixels(const BoardSpec& spec, int pixels_per_metre);

// The board's corners found in one picture: for each, its id (ChArUco: OpenCV's corner id;
// chessboard: row * columns + column), where it is in the image (pixels, sub-pixel accurate; the
// centre of the top-left pixel is (0, 0)) and where it is on the board (metres, z = 0).
struct BoardCorners {
  std::vector<int> ids;
  std::vector<cv::Point2f> image_points;
  std::vector<cv::Point3f> board_points;

  bool empty() const { return ids.empty(); }
  std::size_t size() const { return ids.size(); }
};

// The corners of `spec`'s board in an 8-bit grey image; empty when the board is not found.
// ChArUco: the markers found (without their own corner refinement, which interpolating the
// chessboard corners redoes better), then the corners between them, refined. Chessboard:
// cv::findChessboardCornersSB (which finds more boards), else cv::findChessboardCorners, the
// corners then refined with cv::cornerSubPix (more accurate than either detector's own).
BoardCorners findBoardCorners(const BoardSpec& spec, const cv::Mat& grey);

}  // namespace occmap
