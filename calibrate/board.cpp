#include "calibrate/board.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <utility>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calibrate/aruco_dictionary.h"
#include "calibrate/charuco_refine.h"

namespace occmap {
namespace {

constexpr const char* kSpecHelp =
    "write charuco:COLUMNSxROWS:SQUARE_M:MARKER_M:DICTIONARY (squares, e.g. "
    "charuco:7x5:0.04:0.03:DICT_4X4_50) or chessboard:COLUMNSxROWS:SQUARE_M (inner corners, e.g. "
    "chessboard:9x6:0.025)";

std::vector<std::string_view> splitAtColons(std::string_view text) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t colon = text.find(':', start);
    parts.push_back(text.substr(start, colon == std::string_view::npos ? colon : colon - start));
    if (colon == std::string_view::npos) return parts;
    start = colon + 1;
  }
}

template <typename Number>
std::optional<Number> wholeNumber(std::string_view text) {
  Number value{};
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

// "7x5": two whole numbers of at least `least` each.
bool parseSize(std::string_view text, int least, const char* what, BoardSpec& spec,
               std::string& error) {
  const std::size_t x = text.find('x');
  const auto columns =
      x == std::string_view::npos ? std::nullopt : wholeNumber<int>(text.substr(0, x));
  const auto rows =
      x == std::string_view::npos ? std::nullopt : wholeNumber<int>(text.substr(x + 1));
  if (!columns || !rows || *columns < least || *rows < least) {
    error = "the size '" + std::string(text) + "' must be COLUMNSxROWS " + what +
            ", each at least " + std::to_string(least) + " (e.g. 7x5)";
    return false;
  }
  spec.columns = *columns;
  spec.rows = *rows;
  return true;
}

bool parseLength(std::string_view text, const char* what, double& metres, std::string& error) {
  const auto value = wholeNumber<double>(text);
  if (!value || !std::isfinite(*value) || *value <= 0.0 || *value > 10.0) {
    error = std::string("the ") + what + " '" + std::string(text) +
            "' must be a length in metres, more than 0 (e.g. 0.04 for 4 cm)";
    return false;
  }
  metres = *value;
  return true;
}

std::optional<BoardSpec> parseCharuco(const std::vector<std::string_view>& parts,
                                      std::string& error) {
  BoardSpec spec;
  spec.kind = BoardKind::kCharuco;
  if (parts.size() != 5) {
    error = "a ChArUco board has 4 fields after 'charuco:', got " +
            std::to_string(parts.size() - 1) + ": " + kSpecHelp;
    return std::nullopt;
  }
  if (!parseSize(parts[1], 3, "squares", spec, error) ||
      !parseLength(parts[2], "square size", spec.square_m, error) ||
      !parseLength(parts[3], "marker size", spec.marker_m, error)) {
    return std::nullopt;
  }
  if (spec.marker_m >= spec.square_m) {
    error = "the marker (" + std::string(parts[3]) + " m) must be smaller than its square (" +
            std::string(parts[2]) + " m), e.g. three quarters of it";
    return std::nullopt;
  }
  const std::optional<int> known = arucoDictionary(parts[4]);
  if (!known) {
    error = "unknown ArUco dictionary '" + std::string(parts[4]) + "'; OpenCV's are " +
            arucoDictionaryNames();
    return std::nullopt;
  }
  spec.dictionary = *known;
  spec.dictionary_name = std::string(parts[4]);
  // OpenCV puts a marker in every white square, each a different one of the dictionary's.
  const int markers = spec.columns * spec.rows / 2;
  const int available = cv::aruco::getPredefinedDictionary(spec.dictionary)->bytesList.rows;
  if (markers > available) {
    error = "a " + std::to_string(spec.columns) + "x" + std::to_string(spec.rows) +
            " board needs " + std::to_string(markers) + " markers but " + spec.dictionary_name +
            " has only " + std::to_string(available) +
            ": choose a larger dictionary (e.g. DICT_4X4_100)";
    return std::nullopt;
  }
  return spec;
}

std::optional<BoardSpec> parseChessboard(const std::vector<std::string_view>& parts,
                                         std::string& error) {
  BoardSpec spec;
  spec.kind = BoardKind::kChessboard;
  if (parts.size() != 3) {
    error = "a chessboard has 2 fields after 'chessboard:', got " +
            std::to_string(parts.size() - 1) + ": " + kSpecHelp;
    return std::nullopt;
  }
  // OpenCV's chessboard detectors need at least 3 inner corners each way.
  if (!parseSize(parts[1], 3, "inner corners", spec, error) ||
      !parseLength(parts[2], "square size", spec.square_m, error)) {
    return std::nullopt;
  }
  return spec;
}

cv::Ptr<cv::aruco::CharucoBoard> charucoBoard(const BoardSpec& spec) {
  return cv::aruco::CharucoBoard::create(spec.columns, spec.rows, static_cast<float>(spec.square_m),
                                         static_cast<float>(spec.marker_m),
                                         cv::aruco::getPredefinedDictionary(spec.dictionary));
}

// The same board as printed before OpenCV 4.6, and still by calib.io and by later OpenCV with
// setLegacyPattern(true). With an odd number of rows it is the same board; with an even number its
// markers sit on the other squares: the top-left square holds marker 0 instead of being black
// (opencv_contrib#3291; OpenCV 4.6, Debian's, knows only the new layout). The chessboard corners,
// and so the calibration's points, are the same. OpenCV 4.6 offers no way to make it, so the
// markers are laid out here as later OpenCV does (ids row by row over the squares with (x + y)
// even), and each corner's nearest markers and their nearest corners, which
// interpolateCornersCharuco reads, worked out again as CharucoBoard::create does.
cv::Ptr<cv::aruco::CharucoBoard> legacyCharucoBoard(const BoardSpec& spec) {
  cv::Ptr<cv::aruco::CharucoBoard> board = charucoBoard(spec);
  const float square = static_cast<float>(spec.square_m);
  const float marker = static_cast<float>(spec.marker_m);
  const float inset = (square - marker) / 2;
  board->objPoints.clear();
  for (int y = 0; y < spec.rows; ++y) {
    for (int x = 0; x < spec.columns; ++x) {
      if ((x + y) % 2 != 0) continue;  // a black square
      const cv::Point3f top_left(static_cast<float>(x) * square + inset,
                                 static_cast<float>(y) * square + inset, 0);
      board->objPoints.push_back({top_left, top_left + cv::Point3f(marker, 0, 0),
                                  top_left + cv::Point3f(marker, marker, 0),
                                  top_left + cv::Point3f(0, marker, 0)});
    }
  }
  const auto centre = [](const std::vector<cv::Point3f>& corners) {
    return (corners[0] + corners[1] + corners[2] + corners[3]) * 0.25f;
  };
  const auto squared = [](const cv::Point3f& d) {
    return static_cast<double>(d.x * d.x + d.y * d.y);
  };
  const double same = 1e-4 * spec.square_m * spec.square_m;  // (1 % of a square)^2, as OpenCV
  board->nearestMarkerIdx.assign(board->chessboardCorners.size(), {});
  board->nearestMarkerCorners.assign(board->chessboardCorners.size(), {});
  for (std::size_t i = 0; i < board->chessboardCorners.size(); ++i) {
    const cv::Point3f corner = board->chessboardCorners[i];
    std::vector<int>& nearest = board->nearestMarkerIdx[i];
    double least = -1;
    for (std::size_t j = 0; j < board->objPoints.size(); ++j) {
      const double distance = squared(corner - centre(board->objPoints[j]));
      if (j == 0 || std::abs(distance - least) < same) {
        nearest.push_back(static_cast<int>(j));
        least = j == 0 ? distance : least;
      } else if (distance < least) {
        nearest.assign(1, static_cast<int>(j));
        least = distance;
      }
    }
    for (const int j : nearest) {
      const std::vector<cv::Point3f>& corners = board->objPoints[static_cast<std::size_t>(j)];
      int closest = 0;
      for (int k = 1; k < 4; ++k) {
        if (squared(corner - corners[static_cast<std::size_t>(k)]) <
            squared(corner - corners[static_cast<std::size_t>(closest)])) {
          closest = k;
        }
      }
      board->nearestMarkerCorners[i].push_back(closest);
    }
  }
  return board;
}

// Only the markers that lie where the board puts them: markers of the board's dictionary elsewhere
// in the picture (the floor's, for calibrating the pose, often are) with ids the board uses would
// otherwise be taken for the board's own, and every corner beside them misplaced (seen: a 7 x 5
// board in a room with markers 0 to 10 on the floor, calibrated to an RMS of 42 px). The markers'
// centres are mapped from the board into the picture by one homography, found by RANSAC; a marker
// more than half a marker's side off it is not the board's. The lens bends the board's picture
// less than that over a board held up in front of a camera.
void keepTheBoardsMarkers(const cv::aruco::CharucoBoard& board,
                          std::vector<std::vector<cv::Point2f>>& corners, std::vector<int>& ids) {
  std::vector<cv::Point2f> on_board;
  std::vector<cv::Point2f> in_picture;
  std::vector<std::size_t> kept;
  std::vector<double> sides;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const auto at = std::find(board.ids.begin(), board.ids.end(), ids[i]);
    if (at == board.ids.end()) continue;  // not a marker of this board at all
    const std::vector<cv::Point3f>& marker =
        board.objPoints[static_cast<std::size_t>(at - board.ids.begin())];
    cv::Point2f centre(0, 0), seen(0, 0);
    for (std::size_t c = 0; c < 4; ++c) {
      centre += cv::Point2f(marker[c].x, marker[c].y) * 0.25f;
      seen += corners[i][c] * 0.25f;
    }
    on_board.push_back(centre);
    in_picture.push_back(seen);
    kept.push_back(i);
    sides.push_back(cv::norm(corners[i][1] - corners[i][0]));
  }
  std::vector<std::vector<cv::Point2f>> board_corners;
  std::vector<int> board_ids;
  if (kept.size() >= 5) {
    std::nth_element(sides.begin(), sides.begin() + static_cast<std::ptrdiff_t>(sides.size() / 2),
                     sides.end());
    const double threshold = std::max(2.0, 0.5 * sides[sides.size() / 2]);
    std::vector<unsigned char> inlier;
    cv::findHomography(on_board, in_picture, cv::RANSAC, threshold, inlier);
    for (std::size_t j = 0; j < kept.size(); ++j) {
      if (inlier.empty() || inlier[j] != 0) {
        board_corners.push_back(corners[kept[j]]);
        board_ids.push_back(ids[kept[j]]);
      }
    }
  } else {
    // Too few to tell: as they are.
    for (const std::size_t i : kept) {
      board_corners.push_back(corners[i]);
      board_ids.push_back(ids[i]);
    }
  }
  corners.swap(board_corners);
  ids.swap(board_ids);
}

// The board's markers as found in a picture, before any layout is applied to them.
struct MarkersFound {
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<std::vector<cv::Point2f>> rejected;
  std::vector<int> ids;
};

MarkersFound findMarkers(const cv::Ptr<cv::aruco::Dictionary>& dictionary, const cv::Mat& grey) {
  cv::Ptr<cv::aruco::DetectorParameters> parameters = cv::aruco::DetectorParameters::create();
  parameters->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
  MarkersFound found;
  cv::aruco::detectMarkers(grey, dictionary, found.corners, found.ids, parameters, found.rejected);
  return found;
}

// The corners of `board` between the markers found (a copy: each layout keeps its own).
// `markers_in_place`: how many of them lie where this board's layout puts them.
BoardCorners findCharucoCorners(const cv::Ptr<cv::aruco::CharucoBoard>& board, const cv::Mat& grey,
                                MarkersFound markers, std::size_t& markers_in_place) {
  markers_in_place = 0;
  if (markers.ids.empty()) return {};
  keepTheBoardsMarkers(*board, markers.corners, markers.ids);
  markers_in_place = markers.ids.size();
  if (markers.ids.empty()) return {};
  // Markers missed at first are looked for again where the board says they must be.
  cv::aruco::refineDetectedMarkers(grey, board, markers.corners, markers.ids, markers.rejected);
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(markers.corners, markers.ids, grey, board, corners, ids);
  BoardCorners found;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    found.ids.push_back(ids[i]);
    // OpenCV 4.6's interpolateCornersCharuco returns each corner half a pixel right of and below
    // the saddle point its own cornerSubPix found (opencv_contrib#3024 added the shift,
    // opencv#25539 reported it, opencv#28380 took it out of the later CharucoDetector; measured
    // here on rendered boards: +0.50 px in x and y): taken off.
    found.image_points.push_back(corners[i] - cv::Point2f(0.5f, 0.5f));
    found.board_points.push_back(board->chessboardCorners[static_cast<std::size_t>(ids[i])]);
  }
  refineCharucoCorners(grey, *board, found);
  return found;
}

// A board with an even number of rows may have been printed in either layout (legacyCharucoBoard):
// both are tried on the same markers found, and the board in the picture is the layout that more
// of them agree with (keepTheBoardsMarkers' one homography). Read in the wrong layout, a legacy
// 7 x 6 board still gave 25 of its 30 corners, every one a square off, as if it were right; the
// count of corners alone is a poor judge of that, while most markers sit where the wrong layout
// has none.
BoardCorners findCharucoCorners(const BoardSpec& spec, const cv::Mat& grey) {
  const cv::Ptr<cv::aruco::CharucoBoard> board = charucoBoard(spec);
  const MarkersFound markers = findMarkers(board->dictionary, grey);
  std::size_t in_place = 0, legacy_in_place = 0;
  BoardCorners found = findCharucoCorners(board, grey, markers, in_place);
  if (spec.rows % 2 != 0) return found;
  BoardCorners legacy =
      findCharucoCorners(legacyCharucoBoard(spec), grey, markers, legacy_in_place);
  if (legacy_in_place != in_place) return legacy_in_place > in_place ? legacy : found;
  return legacy.size() > found.size() ? legacy : found;
}

// The largest cornerSubPix half-window that stays within each corner's own squares: under half the
// smallest distance between neighbouring corners, across or down.
int refinementHalfWindow(const BoardSpec& spec, const std::vector<cv::Point2f>& corners) {
  double spacing = 1e9;
  const auto at = [&](int row, int column) {
    return corners[static_cast<std::size_t>(row * spec.columns + column)];
  };
  for (int row = 0; row < spec.rows; ++row) {
    for (int column = 0; column < spec.columns; ++column) {
      if (column + 1 < spec.columns) {
        spacing = std::min(spacing, cv::norm(at(row, column + 1) - at(row, column)));
      }
      if (row + 1 < spec.rows)
        spacing = std::min(spacing, cv::norm(at(row + 1, column) - at(row, column)));
    }
  }
  return std::clamp(static_cast<int>(spacing * 0.4), 2, 11);
}

BoardCorners findChessboardCorners(const BoardSpec& spec, const cv::Mat& grey) {
  const cv::Size pattern(spec.columns, spec.rows);
  std::vector<cv::Point2f> corners;
  if (!cv::findChessboardCornersSB(grey, pattern, corners, cv::CALIB_CB_NORMALIZE_IMAGE)) {
    corners.clear();
    if (!cv::findChessboardCorners(grey, pattern, corners,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
      return {};
    }
  }
  // The sector-based detector finds boards more reliably, but its own corners (even with
  // CALIB_CB_ACCURACY) put the focal length of rendered pictures of a known camera 0.5 % off at an
  // RMS of 0.08 px; refined with cornerSubPix, 0.1 % off at 0.045 px
  // (tests/calibrate_intrinsics_test.cpp).
  const int half = refinementHalfWindow(spec, corners);
  cv::cornerSubPix(grey, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-3));
  BoardCorners found;
  for (int row = 0; row < spec.rows; ++row) {
    for (int column = 0; column < spec.columns; ++column) {
      const int id = row * spec.columns + column;
      found.ids.push_back(id);
      found.image_points.push_back(corners[static_cast<std::size_t>(id)]);
      found.board_points.emplace_back(static_cast<float>(column * spec.square_m),
                                      static_cast<float>(row * spec.square_m), 0.0f);
    }
  }
  return found;
}

}  // namespace

int BoardSpec::cornerCount() const {
  return kind == BoardKind::kCharuco ? (columns - 1) * (rows - 1) : columns * rows;
}
int BoardSpec::squaresAcross() const { return kind == BoardKind::kCharuco ? columns : columns + 1; }
int BoardSpec::squaresDown() const { return kind == BoardKind::kCharuco ? rows : rows + 1; }

std::optional<BoardSpec> parseBoardSpec(std::string_view text, std::string& error) {
  const std::vector<std::string_view> parts = splitAtColons(text);
  if (parts[0] == "charuco") return parseCharuco(parts, error);
  if (parts[0] == "chessboard") return parseChessboard(parts, error);
  error = "unknown board kind '" + std::string(parts[0]) + "': " + kSpecHelp;
  return std::nullopt;
}

std::string boardSpecText(const BoardSpec& spec) {
  const auto number = [](double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.10g", value);
    return std::string(text);
  };
  const std::string size = std::to_string(spec.columns) + "x" + std::to_string(spec.rows);
  if (spec.kind == BoardKind::kChessboard)
    return "chessboard:" + size + ":" + number(spec.square_m);
  return "charuco:" + size + ":" + number(spec.square_m) + ":" + number(spec.marker_m) + ":" +
         spec.dictionary_name;
}

int squarePixels(const BoardSpec& spec, int pixels_per_metre) {
  return std::max(1, static_cast<int>(std::lround(spec.square_m * pixels_per_metre)));
}

cv::Mat boardPicture(const BoardSpec& spec, int pixels_per_metre, int margin_px) {
  const int square = squarePixels(spec, pixels_per_metre);
  const cv::Size size(spec.squaresAcross() * square + 2 * margin_px,
                      spec.squaresDown() * square + 2 * margin_px);
  cv::Mat picture;
  if (spec.kind == BoardKind::kCharuco) {
    // The size is whole squares plus the margins, so OpenCV draws each square `square` pixels.
    charucoBoard(spec)->draw(size, picture, margin_px, 1);
    return picture;
  }
  picture = cv::Mat(size, CV_8UC1, cv::Scalar(255));
  for (int row = 0; row < spec.squaresDown(); ++row) {
    for (int column = 0; column < spec.squaresAcross(); ++column) {
      if ((row + column) % 2 != 0) continue;
      picture(cv::Rect(margin_px + column * square, margin_px + row * square, square, square))
          .setTo(0);
    }
  }
  return picture;
}

BoardCorners findBoardCorners(const BoardSpec& spec, const cv::Mat& grey) {
  return spec.kind == BoardKind::kCharuco ? findCharucoCorners(spec, grey)
                                          : findChessboardCorners(spec, grey);
}

}  // namespace occmap
