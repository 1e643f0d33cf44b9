#include "calibrate/marker_corners.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <opencv2/aruco.hpp>

namespace occmap {
namespace {

// Ink and paper must differ by this many grey levels where an edge is measured.
constexpr double kLeastContrast = 20.0;
// Edge points further than this from the line fitted to them are left out and the line fitted
// again: a speck of dirt or a bit of the marker's inside, not the edge.
constexpr double kLeastPointFit = 0.3;

struct Line {
  Eigen::Vector2d point;
  Eigen::Vector2d direction;
};

// Bilinear grey level at (x, y), pixel centres at whole numbers; the border repeated.
double greyAt(const cv::Mat& grey, double x, double y) {
  const double cx = std::clamp(x, 0.0, grey.cols - 1.0);
  const double cy = std::clamp(y, 0.0, grey.rows - 1.0);
  const int x0 = std::min(static_cast<int>(cx), grey.cols - 2);
  const int y0 = std::min(static_cast<int>(cy), grey.rows - 2);
  const double fx = cx - x0;
  const double fy = cy - y0;
  const auto at = [&](int dy, int dx) {
    return static_cast<double>(grey.at<std::uint8_t>(y0 + dy, x0 + dx));
  };
  return (at(0, 0) * (1 - fx) + at(0, 1) * fx) * (1 - fy) +
         (at(1, 0) * (1 - fx) + at(1, 1) * fx) * fy;
}

// The line through the points, fitted by total least squares; nothing for fewer than 4.
std::optional<Line> fitLine(const std::vector<Eigen::Vector2d>& points) {
  if (points.size() < 4) return std::nullopt;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const Eigen::Vector2d& p : points) scatter += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(scatter);
  return Line{mean, solver.eigenvectors().col(1)};
}

// The outer edge from corner a to corner b of a marker whose centre is `centre`, `cell` pixels a
// cell (its black border is one cell wide, inside it the cells may be white). Each point is found
// along the edge's normal within most of a cell either way, where the grey crosses halfway between
// the ink inside and the paper outside, nearest where the outline says the edge is.
std::optional<Line> measureEdge(const cv::Mat& grey, const Eigen::Vector2d& a,
                                const Eigen::Vector2d& b, const Eigen::Vector2d& centre,
                                double cell) {
  const double length = (b - a).norm();
  const Eigen::Vector2d along = (b - a) / length;
  Eigen::Vector2d normal(-along.y(), along.x());
  if (normal.dot((a + b) / 2 - centre) < 0) normal = -normal;  // outward, towards the paper
  const double reach = std::max(1.5, 0.7 * cell);
  constexpr double kStep = 0.1;
  const int steps = static_cast<int>(std::ceil(reach / kStep));
  std::vector<Eigen::Vector2d> points;
  std::vector<double> profile(static_cast<std::size_t>(2 * steps + 1));
  // Away from the corners, where the other edge is in reach: a fifth of the side at each end.
  for (double t = 0.2 * length; t <= 0.8 * length; t += 0.5) {
    const Eigen::Vector2d p = a + t * along;
    for (int i = -steps; i <= steps; ++i) {
      const Eigen::Vector2d q = p + (i * kStep) * normal;
      profile[static_cast<std::size_t>(i + steps)] = greyAt(grey, q.x(), q.y());
    }
    const double ink = *std::min_element(profile.begin(), profile.begin() + steps);
    const double paper = *std::max_element(profile.begin() + steps, profile.end());
    if (paper - ink < kLeastContrast) continue;
    const double half = (ink + paper) / 2;
    // The crossing from ink to paper nearest the outline.
    std::optional<double> crossing;
    for (int i = 0; i < 2 * steps; ++i) {
      const double g0 = profile[static_cast<std::size_t>(i)];
      const double g1 = profile[static_cast<std::size_t>(i + 1)];
      if (g0 < half && g1 >= half) {
        const double s = (i - steps + (half - g0) / (g1 - g0)) * kStep;
        if (!crossing || std::abs(s) < std::abs(*crossing)) crossing = s;
      }
    }
    if (crossing) points.push_back(p + *crossing * normal);
  }
  std::optional<Line> line = fitLine(points);
  if (!line) return std::nullopt;
  const Eigen::Vector2d across(-line->direction.y(), line->direction.x());
  std::erase_if(points, [&](const Eigen::Vector2d& p) {
    return std::abs((p - line->point).dot(across)) > kLeastPointFit;
  });
  return fitLine(points);
}

std::optional<Eigen::Vector2d> meet(const Line& first, const Line& second) {
  Eigen::Matrix2d m;
  m << first.direction, -second.direction;
  if (std::abs(m.determinant()) < 1e-6) return std::nullopt;
  const Eigen::Vector2d st = m.partialPivLu().solve(second.point - first.point);
  return first.point + st.x() * first.direction;
}

// The corners from the edges, twice (the second time from the first's corners, whose normals are
// truer); nothing when an edge cannot be measured.
std::optional<std::array<cv::Point2f, 4>> cornersFromEdges(const cv::Mat& grey,
                                                           std::array<cv::Point2f, 4> corners,
                                                           int cells) {
  for (int pass = 0; pass < 2; ++pass) {
    std::array<Eigen::Vector2d, 4> c;
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    double perimeter = 0;
    for (std::size_t j = 0; j < 4; ++j) {
      c[j] = Eigen::Vector2d(corners[j].x, corners[j].y);
      centre += c[j] / 4;
    }
    for (std::size_t j = 0; j < 4; ++j) perimeter += (c[(j + 1) % 4] - c[j]).norm();
    const double cell = perimeter / 4 / cells;
    std::array<Line, 4> edges;
    for (std::size_t j = 0; j < 4; ++j) {
      const std::optional<Line> edge = measureEdge(grey, c[j], c[(j + 1) % 4], centre, cell);
      if (!edge) return std::nullopt;
      edges[j] = *edge;
    }
    for (std::size_t j = 0; j < 4; ++j) {
      // Corner j is where the edge into it (j - 1) meets the edge out of it (j).
      const std::optional<Eigen::Vector2d> at = meet(edges[(j + 3) % 4], edges[j]);
      if (!at || (*at - c[j]).norm() > cell) return std::nullopt;  // not this marker's corner
      corners[j] = cv::Point2f(static_cast<float>(at->x()), static_cast<float>(at->y()));
    }
  }
  return corners;
}

}  // namespace

std::vector<MarkerSighting> findMarkers(const cv::Mat& grey, int dictionary) {
  const cv::Ptr<cv::aruco::Dictionary> words = cv::aruco::getPredefinedDictionary(dictionary);
  const cv::Ptr<cv::aruco::DetectorParameters> parameters = cv::aruco::DetectorParameters::create();
  // The outline's corners, unrefined: the edges are measured from them.
  parameters->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
  std::vector<std::vector<cv::Point2f>> outlines;
  std::vector<int> ids;
  cv::aruco::detectMarkers(grey, words, outlines, ids, parameters);
  const int cells = words->markerSize + 2;  // the bits and the black border round them
  std::vector<MarkerSighting> seen;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    MarkerSighting sighting;
    sighting.id = ids[i];
    std::copy_n(outlines[i].begin(), 4, sighting.corners.begin());
    if (const auto refined = cornersFromEdges(grey, sighting.corners, cells)) {
      sighting.corners = *refined;
    } else {
      sighting.refined = false;
    }
    seen.push_back(sighting);
  }
  return seen;
}

}  // namespace occmap
