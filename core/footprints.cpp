#include "core/footprints.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "core/fusion_kernel.h"
#include "core/integral_image.h"

namespace occmap {
namespace {

// kBitsIn[b][byte][g]: the set bits of byte in its g-th group of 2^b bits (bit 0 first).
const auto kBitsIn = [] {
  std::array<std::array<std::array<std::uint8_t, 8>, 256>, 4> bits{};
  for (unsigned b = 0; b < 4; ++b) {
    for (unsigned byte = 0; byte < 256; ++byte) {
      for (unsigned bit = 0; bit < 8; ++bit) {
        std::uint8_t& count = bits[b][byte][bit >> b];
        count = static_cast<std::uint8_t>(count + ((byte >> bit) & 1u));
      }
    }
  }
  return bits;
}();

// kRunning[byte][i]: the set bits of byte among bits 0..i.
const auto kRunning = [] {
  std::array<std::array<std::uint32_t, 8>, 256> running{};
  for (unsigned byte = 0; byte < 256; ++byte) {
    std::uint32_t sum = 0;
    for (unsigned i = 0; i < 8; ++i) {
      sum += (byte >> i) & 1u;
      running[byte][i] = sum;
    }
  }
  return running;
}();

// The integral image's next n (at most 8) entries of a row: out[i] = above[i] + sum + the set bits
// of byte among bits 0..i. Returns the row's running sum past them.
std::uint32_t integrateByte(std::uint32_t* out, const std::uint32_t* above, std::uint32_t sum,
                            unsigned byte, std::size_t n) {
  const std::array<std::uint32_t, 8>& running = kRunning[byte];
  if (n == 8) {
    // As one vector of 8 lanes (two on x86-64's baseline): written as a loop, GCC kept it scalar,
    // since `out` may alias `above`, and the integral images were a fifth of the room's stage
    // (sim://room 0.98 -> 0.81 ms a map, Terrace 0.77 -> 0.64 ms, medians of 5, one run).
    using Lanes = std::uint32_t __attribute__((vector_size(32)));
    Lanes from_above, counts;
    std::memcpy(&from_above, above, sizeof from_above);
    std::memcpy(&counts, running.data(), sizeof counts);
    const Lanes entries = from_above + counts + sum;
    std::memcpy(out, &entries, sizeof entries);
  } else {
    for (std::size_t i = 0; i < n; ++i) out[i] = above[i] + sum + running[i];
  }
  return sum + running[7];
}

}  // namespace

std::optional<std::array<Eigen::Vector2d, 4>> boardCorners(const Camera& camera,
                                                           const Eigen::Vector2d& below,
                                                           const Eigen::Vector2d& at,
                                                           double width_m, double height_m) {
  const Eigen::Vector2d to = at - below;
  const double distance = to.norm();
  if (!(distance > 1e-9)) return std::nullopt;
  const Eigen::Vector2d across = Eigen::Vector2d(-to.y(), to.x()) * (width_m / 2 / distance);
  std::array<Eigen::Vector2d, 4> corners{Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(),
                                         Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  // Around the board: its foot's two ends, then its top's.
  constexpr double kSide[4] = {-1.0, 1.0, 1.0, -1.0};
  for (int corner = 0; corner < 4; ++corner) {
    const double side = kSide[corner];
    const std::optional<Eigen::Vector2d> pixel = camera.worldToStream(
        {at.x() + side * across.x(), at.y() + side * across.y(), corner >= 2 ? height_m : 0.0});
    if (!pixel) return std::nullopt;
    corners[static_cast<std::size_t>(corner)] = *pixel;
  }
  return corners;
}

namespace {

PixelRectangle bounding(const std::array<Eigen::Vector2d, 4>& corners) {
  PixelRectangle r{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                   -std::numeric_limits<double>::infinity(),
                   -std::numeric_limits<double>::infinity()};
  for (const Eigen::Vector2d& pixel : corners) {
    r.u0 = std::min(r.u0, pixel.x());
    r.u1 = std::max(r.u1, pixel.x());
    r.v0 = std::min(r.v0, pixel.y());
    r.v1 = std::max(r.v1, pixel.y());
  }
  return r;
}

}  // namespace

std::optional<PixelRectangle> boardInImage(const Camera& camera, const Eigen::Vector2d& below,
                                           const Eigen::Vector2d& at, double width_m,
                                           double height_m) {
  const auto corners = boardCorners(camera, below, at, width_m, height_m);
  if (!corners) return std::nullopt;
  return bounding(*corners);
}

namespace {

// A person's board as the camera sees it, where the camera has the place's foot point in its image.
std::optional<std::array<Eigen::Vector2d, 4>> boardSeenAt(const Camera& camera,
                                                          const Eigen::Vector2d& below,
                                                          const Eigen::Vector2d& at, double width_m,
                                                          double height_m) {
  const std::optional<Eigen::Vector2d> foot = camera.worldToStream({at.x(), at.y(), 0.0});
  if (!foot || !camera.pixelIndexAt(*foot)) return std::nullopt;
  return boardCorners(camera, below, at, width_m, height_m);
}

// The least and greatest u of the quadrilateral's part between image rows va and vb (va <= vb).
std::pair<double, double> acrossBetween(const std::array<Eigen::Vector2d, 4>& quad, double va,
                                        double vb) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  const auto take = [&](double u) {
    lo = std::min(lo, u);
    hi = std::max(hi, u);
  };
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector2d& a = quad[i];
    const Eigen::Vector2d& b = quad[(i + 1) % 4];
    if (a.y() >= va && a.y() <= vb) take(a.x());
    // Where the edge crosses either row.
    for (const double v : {va, vb}) {
      if ((a.y() - v) * (b.y() - v) < 0)
        take(a.x() + (b.x() - a.x()) * (v - a.y()) / (b.y() - a.y()));
    }
  }
  return {lo, hi};
}

}  // namespace

FootprintDetector::FootprintDetector(const MapGeometry& map, std::span<const Camera> cameras,
                                     const FootprintSettings& settings)
    : map_(map), settings_(settings) {
  if (!(settings.box_width_m > 0) || !(settings.box_height_m > 0) || !(settings.step_m > 0)) {
    throw std::invalid_argument("FootprintDetector: the box and the step must be positive");
  }
  const double step = std::max(settings.step_m, map.cell_size_m);
  step_ = step;
  const double map_width_m = map.width * map.cell_size_m;
  const double map_height_m = map.height * map.cell_size_m;
  planes_.resize(cameras.size());
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    CameraPlane& plane = planes_[k];
    plane.width = cameras[k].streamWidth();
    plane.height = cameras[k].streamHeight();
    if (plane.width >= kNotSeen || plane.height >= kNotSeen) {
      throw std::invalid_argument("FootprintDetector: an image wider or higher than 65 534 pixels");
    }
  }
  // Each candidate's board in each camera, its corners in pixels (none where the camera does not
  // see the place), before the blocks are chosen.
  std::vector<std::optional<std::array<Eigen::Vector2d, 4>>> boards;
  std::vector<Eigen::Vector2d> below;  // each camera's centre on the floor
  for (const Camera& camera : cameras) below.push_back(camera.centreMetres().head<2>());
  // People's boxes first, then (object_height_m > 0) the low boxes of what stands lower.
  const double heights[2] = {settings.box_height_m, settings.object_height_m};
  for (int tier = 0; tier < 2; ++tier) {
    const double box_height = heights[tier];
    if (!(box_height > 0)) continue;
    if (tier == 1) first_low_ = candidates_.size();
    std::uint32_t row = 0;
    for (double y = map.origin_y_m + step / 2; y < map.origin_y_m + map_height_m;
         y += step, ++row) {
      std::uint32_t column = 0;
      for (double x = map.origin_x_m + step / 2; x < map.origin_x_m + map_width_m;
           x += step, ++column) {
        grid_across_ = std::max(grid_across_, static_cast<int>(column) + 1);
        grid_down_ = std::max(grid_down_, static_cast<int>(row) + 1);
        const Candidate candidate{x, y, cellsWithin(x, y, settings.box_width_m / 4), boards.size(),
                                  0};
        if (candidate.near.row1 <= candidate.near.row0 ||
            candidate.near.column1 <= candidate.near.column0) {
          continue;
        }
        bool any = false;
        for (std::size_t k = 0; k < cameras.size(); ++k) {
          boards.push_back(
              boardSeenAt(cameras[k], below[k], {x, y}, settings.box_width_m, box_height));
          any = any || boards.back().has_value();
        }
        if (any) {
          candidates_.push_back(candidate);
          candidates_.back().on_grid = row * static_cast<std::uint32_t>(grid_across_) + column;
        } else {
          boards.resize(candidate.boxes);
        }
      }
    }
  }
  // Per camera, blocks as large as leaves the narrowest tenth of the boxes it sees some
  // kBlocksPerBox blocks across: the sums are then as good for the people at the far side as for
  // the near ones, and cost the same for a 360 x 288 image and a 1920 x 1080 one.
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    std::vector<double> widths;
    for (std::size_t c = 0; c < candidates_.size(); ++c) {
      const auto& board = boards[candidates_[c].boxes + k];
      if (board) {
        const PixelRectangle box = bounding(*board);
        widths.push_back(box.u1 - box.u0);
      }
    }
    CameraPlane& plane = planes_[k];
    plane.block = 1;
    if (!widths.empty()) {
      const auto tenth = widths.begin() + static_cast<std::ptrdiff_t>(widths.size() / 10);
      std::nth_element(widths.begin(), tenth, widths.end());
      plane.block = std::max(1, static_cast<int>(*tenth / kBlocksPerBox));
    }
    plane.across = (plane.width + plane.block - 1) / plane.block;
    plane.down = (plane.height + plane.block - 1) / plane.block;
    const std::size_t blocks =
        static_cast<std::size_t>(plane.across) * static_cast<std::size_t>(plane.down);
    const std::size_t entries =
        static_cast<std::size_t>(plane.across + 1) * static_cast<std::size_t>(plane.down + 1);
    plane.counts.assign(blocks, 0);
    plane.changed.assign(entries, 0);
    // Each pixel column's block, and which tiles' 8 columns lie in one block: counting then
    // divides nothing, and a tile row's byte in one block counts with one popcount.
    plane.block_of.resize(tilesAcross(plane.width) * 8);
    for (std::size_t u = 0; u < plane.block_of.size(); ++u) {
      plane.block_of[u] =
          static_cast<std::uint16_t>(std::min(static_cast<int>(u), plane.width - 1) / plane.block);
    }
    plane.whole_tile.resize(tilesAcross(plane.width));
    for (std::size_t tile = 0; tile < plane.whole_tile.size(); ++tile) {
      const std::size_t last = tile * 8 + 7;
      plane.whole_tile[tile] = last < static_cast<std::size_t>(plane.width) &&
                               plane.block_of[tile * 8] == plane.block_of[last];
    }
  }
  strips_ = static_cast<std::size_t>(std::max(1, settings.box_strips));
  boxes_.resize(boards.size() * strips_);
  bounds_.resize(boards.size());
  for (std::size_t i = 0; i < boards.size(); ++i) placeStrips(i, boards[i] ? &*boards[i] : nullptr);
  changed_.assign(cameras.size(), nullptr);
  box_changed_.assign(cameras.size(), 0.0);
  windows_.resize(cameras.size());
  strips_changed_.assign(candidates_.size() * cameras.size(), kNotSummed);
  occupied_.assign(
      static_cast<std::size_t>(map.width + 1) * static_cast<std::size_t>(map.height + 1), 0);
  alive_.reserve(candidates_.size());
  heap_.reserve(candidates_.size());
  // Room for a crowd, so that finding one allocates nothing (more grow the buffers once).
  constexpr std::size_t kRoom = 64;
  detections_.reserve(kRoom);
  chosen_.reserve(kRoom);
  kept_.reserve(kRoom);
  for (CameraPlane& plane : planes_) plane.explained.reset(plane.across, kBandShift, 2 * kRoom);
  grid_.assign(static_cast<std::size_t>(grid_across_) * static_cast<std::size_t>(grid_down_),
               kNoCandidate);
  for (std::size_t c = 0; c < std::min(first_low_, candidates_.size()); ++c) {
    grid_[candidates_[c].on_grid] = static_cast<std::uint32_t>(c);
  }
  low_grid_.assign(grid_.size(), kNoCandidate);
  for (std::size_t c = first_low_; c < candidates_.size(); ++c) {
    low_grid_[candidates_[c].on_grid] = static_cast<std::uint32_t>(c);
  }
  near_found_.assign(grid_.size(), 0);
  near_expected_.assign(grid_.size(), 0);
  was_expected_.reserve(kRoom);
}

void FootprintDetector::placeStrips(std::size_t i, const std::array<Eigen::Vector2d, 4>* board) {
  const CameraPlane& plane = planes_[i % planes_.size()];
  Box* strips = boxes_.data() + i * strips_;
  if (board == nullptr) {
    std::fill_n(strips, strips_, Box{kNotSeen, kNotSeen, kNotSeen, kNotSeen, 0.0f});
    bounds_[i] = strips[0];
    return;
  }
  const PixelRectangle r = bounding(*board);
  const double u_min = r.u0, v_min = r.v0, u_max = r.u1, v_max = r.v1;
  // Pixel centres are integers, so pixel p spans [p - 0.5, p + 0.5): the rectangle's edges
  // to the nearest block edges, at least one block.
  const double b = plane.block;
  const auto edge = [&](double at, int blocks) {
    return std::clamp(static_cast<int>(std::lround((at + 0.5) / b)), 0, blocks);
  };
  int u0 = edge(u_min, plane.across), u1 = edge(u_max, plane.across);
  int v0 = edge(v_min, plane.down), v1 = edge(v_max, plane.down);
  if (u1 == u0) u1 < plane.across ? ++u1 : --u0;
  if (v1 == v0) v1 < plane.down ? ++v1 : --v0;
  // The rectangle's rows in strips_ bands, each as wide as the board is between its rows (a
  // board leans in the image: on the paper's rig it fills 74 % of its rectangle at the median).
  const int rows = v1 - v0;
  float pixels = 0.0f;
  for (std::size_t s = 0; s < strips_; ++s) {
    const int va = v0 + static_cast<int>(static_cast<std::size_t>(rows) * s / strips_);
    const int vb = v0 + static_cast<int>(static_cast<std::size_t>(rows) * (s + 1) / strips_);
    if (va == vb) {
      strips[s] = {static_cast<std::uint16_t>(u0), static_cast<std::uint16_t>(va),
                   static_cast<std::uint16_t>(u0), static_cast<std::uint16_t>(va), 0.0f};
      continue;
    }
    int su0 = u0, su1 = u1;
    if (strips_ > 1) {
      const double top = std::max(va * b - 0.5, v_min), bottom = std::min(vb * b - 0.5, v_max);
      const auto [lo, hi] = top <= bottom ? acrossBetween(*board, top, bottom)
                                          : acrossBetween(*board, bottom, bottom);
      if (lo <= hi) {
        su0 = std::clamp(edge(lo, plane.across), u0, u1);
        su1 = std::clamp(edge(hi, plane.across), u0, u1);
        if (su1 == su0) su1 < u1 ? ++su1 : --su0;
      }
    }
    const int pixels_across = std::min(su1 * plane.block, plane.width) - su0 * plane.block;
    const int pixels_down = std::min(vb * plane.block, plane.height) - va * plane.block;
    strips[s] = {static_cast<std::uint16_t>(su0), static_cast<std::uint16_t>(va),
                 static_cast<std::uint16_t>(su1), static_cast<std::uint16_t>(vb),
                 static_cast<float>(pixels_across * pixels_down)};
    pixels += strips[s].pixels;
  }
  bounds_[i] = {static_cast<std::uint16_t>(u0), static_cast<std::uint16_t>(v0),
                static_cast<std::uint16_t>(u1), static_cast<std::uint16_t>(v1), pixels};
}

void FootprintDetector::replaceCamera(std::size_t k, const Camera& camera) {
  if (k >= planes_.size()) throw std::invalid_argument("FootprintDetector: no such camera");
  if (camera.streamWidth() != planes_[k].width || camera.streamHeight() != planes_[k].height) {
    throw std::invalid_argument("FootprintDetector: a camera's new pose for another image size");
  }
  const Eigen::Vector2d below = camera.centreMetres().head<2>();
  for (std::size_t c = 0; c < candidates_.size(); ++c) {
    const Candidate& candidate = candidates_[c];
    const double height = c >= first_low_ ? settings_.object_height_m : settings_.box_height_m;
    const auto board =
        boardSeenAt(camera, below, {candidate.x_m, candidate.y_m}, settings_.box_width_m, height);
    placeStrips(candidate.boxes + k, board ? &*board : nullptr);
  }
}

FootprintDetector::CellRange FootprintDetector::cellsWithin(double x_m, double y_m,
                                                            double reach_m) const {
  const auto cellOf = [&](double metres, double origin) {
    return static_cast<int>(std::floor((metres - origin) / map_.cell_size_m));
  };
  return {std::clamp(cellOf(y_m - reach_m, map_.origin_y_m), 0, map_.height),
          std::clamp(cellOf(x_m - reach_m, map_.origin_x_m), 0, map_.width),
          std::clamp(cellOf(y_m + reach_m, map_.origin_y_m) + 1, 0, map_.height),
          std::clamp(cellOf(x_m + reach_m, map_.origin_x_m) + 1, 0, map_.width)};
}

std::uint32_t FootprintDetector::occupiedWithin(const CellRange& range) const {
  return rectangleSum(occupied_, map_.width, range.column0, range.row0, range.column1, range.row1);
}

double FootprintDetector::footprintArea(const Candidate& candidate) const {
  return occupiedWithin(cellsWithin(candidate.x_m, candidate.y_m, settings_.box_width_m / 2)) *
         map_.cell_size_m * map_.cell_size_m;
}

FootprintDetector::Evidence FootprintDetector::evidence(std::size_t c, double bar,
                                                        double veto_support,
                                                        int veto_cameras) const {
  const Candidate& candidate = candidates_[c];
  Evidence e;
  // With a veto, first the rectangle holding each camera's strips: their changed pixels are at
  // most its, and a candidate whose rectangle holds too few fails with a third of the sums.
  if (veto_support > 0 && strips_ > 1) {
    for (std::size_t k = 0; k < planes_.size(); ++k) {
      const Box& bound = boundOf(candidate, k);
      if (bound.u0 == kNotSeen || changed_[k] == nullptr) continue;
      const CameraPlane& plane = planes_[k];
      const double most =
          rectangleSum(plane.changed, plane.across, bound.u0, bound.v0, bound.u1, bound.v1);
      if (most < veto_support * static_cast<double>(pixelsOf(candidate, k))) {
        e.support = 0.0;
        return e;  // fresh 0: it fails
      }
    }
  }
  // First the support, from one sum per camera: most candidates fail on it, and then what the
  // people found explain (a look at every piece) need not be counted.
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    const Box* strips = boxAt(candidate, k);
    if (strips->u0 == kNotSeen || changed_[k] == nullptr) continue;
    const double changed = changedIn(c, k);
    box_changed_[k] = changed;
    ++e.cameras;
    e.support = std::min(e.support, changed / static_cast<double>(pixelsOf(candidate, k)));
  }
  if (e.cameras == 0) {
    e.support = 0.0;
    return e;
  }
  if (e.cameras < veto_cameras || e.support < veto_support) return e;  // fresh 0: it fails
  // What it adds is counted a camera at a time, and the count stops once even the cameras not yet
  // counted, had the people found explained none of their pixels, could not lift it to the bar.
  double most = 0.0;  // the cameras not yet counted: their shares of changed pixels
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    if (boxAt(candidate, k)->u0 == kNotSeen || changed_[k] == nullptr) continue;
    most += box_changed_[k] / static_cast<double>(pixelsOf(candidate, k));
  }
  // A hair under the bar, so that rounding in the sums cannot stop a count that would reach it.
  const double needed = bar * e.cameras - 1e-9;
  double fresh = 0.0;
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    const Box* strips = boxAt(candidate, k);
    if (strips->u0 == kNotSeen || changed_[k] == nullptr) continue;
    const double pixels = static_cast<double>(pixelsOf(candidate, k));
    const double explained =
        piecesIn<false>(planes_[k], boundOf(candidate, k), strips, strips_).changed;
    fresh += (box_changed_[k] - explained) / pixels;
    most -= box_changed_[k] / pixels;
    if (fresh + most < needed) {
      e.fresh = (fresh + std::max(0.0, most)) / e.cameras;  // below the bar: all that is asked
      return e;
    }
  }
  e.fresh = fresh / e.cameras;
  return e;
}

void FootprintDetector::forgetExplained() {
  for (CameraPlane& plane : planes_) plane.explained.clear();
}

void FootprintDetector::markExplained(std::size_t c, bool near_windows) {
  const Candidate& candidate = candidates_[c];
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    const Box* strips = boxAt(candidate, k);
    if (strips->u0 == kNotSeen || changed_[k] == nullptr) continue;
    if (near_windows && !meet(boundOf(candidate, k), windows_[k])) continue;
    for (std::size_t s = 0; s < strips_; ++s) planes_[k].explained.add(strips[s]);
  }
}

void FootprintDetector::clearWindows() {
  std::fill(windows_.begin(), windows_.end(), Box{kNotSeen, kNotSeen, 0, 0, 0.0f});
}

void FootprintDetector::windowsNear(int row, int column, int steps) {
  clearWindows();
  forEachNear(row, column, steps, [&](std::size_t n) { widenWindows(n); });
}

void FootprintDetector::widenWindows(std::size_t c) {
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    const Box& bound = boundOf(candidates_[c], k);
    if (bound.u0 == kNotSeen) continue;
    Box& window = windows_[k];
    window = {std::min(window.u0, bound.u0), std::min(window.v0, bound.v0),
              std::max(window.u1, bound.u1), std::max(window.v1, bound.v1), 0.0f};
  }
}

// The greedy explanation over candidates [begin, end): the one with the most fresh evidence is
// taken, its boxes' pixels explained, until none adds min_fresh.
void FootprintDetector::explainGreedily(std::size_t begin, std::size_t end, bool expected_only) {
  const bool low = begin >= first_low_;
  // What stands lower is found only where no one was: its footprint and a person's do not
  // overlap, so it is at least a box's width from anyone found (at min_separation_m, a chair's
  // seat beside the person's box found on its back was a second detection: sim://room-crowd's
  // first 300 maps, false positives 443 -> 363 with the tracker's order; EPFL's crowd the same).
  const double separation = separationFor(low);
  const double separation2 = separation * separation;
  const auto tooClose = [&](std::size_t c, double x_m, double y_m) {
    const double dx = candidates_[c].x_m - x_m, dy = candidates_[c].y_m - y_m;
    return dx * dx + dy * dy < separation2;
  };
  // The grid's places near someone already found, marked a little wider than min_separation_m
  // (each candidate marked is then measured): looking at every one found for each of the low
  // boxes' candidates took some 0.1 ms a map in a crowd.
  std::fill(near_found_.begin(), near_found_.end(), std::uint8_t{0});
  const int reach = static_cast<int>(std::ceil(separation / step_)) + 1;
  for (const std::size_t c : chosen_) {
    const int row = static_cast<int>(candidates_[c].on_grid) / grid_across_;
    const int column = static_cast<int>(candidates_[c].on_grid) % grid_across_;
    for (int r = std::max(0, row - reach); r <= std::min(grid_down_ - 1, row + reach); ++r) {
      std::uint8_t* marks =
          near_found_.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(grid_across_);
      std::fill(marks + std::max(0, column - reach),
                marks + std::min(grid_across_ - 1, column + reach) + 1, std::uint8_t{1});
    }
  }
  alive_.clear();
  for (std::size_t c = begin; c < end; ++c) {
    if (expected_only && near_expected_[candidates_[c].on_grid] == 0) continue;
    if (occupiedWithin(candidates_[c].near) == 0) continue;
    if (near_found_[candidates_[c].on_grid] != 0 &&
        std::any_of(detections_.begin(), detections_.end(),
                    [&](const Detection& d) { return tooClose(c, d.x_m, d.y_m); })) {
      continue;
    }
    alive_.push_back(c);
  }
  const double min_support = low ? settings_.object_min_support : settings_.min_support;
  const double min_fresh = (low ? settings_.object_min_fresh : settings_.min_fresh) *
                           (expected_only ? settings_.expected_fresh_share : 1.0);
  // The most new evidence first: a person where one stands explains the whole of their own
  // silhouette in every camera, a ghost between people only parts of theirs (ranked by the least
  // support instead, the crowd set scored MODA 23 % against 65 %, docs/detection.md). Lazily:
  // what a candidate would add only shrinks as people are found, so its last figure bounds it,
  // and only the candidates on top of the heap are judged again (the best one, the smallest
  // index among equals, as a judgement of every candidate at every round would take). A
  // candidate that fails once fails for good: its cameras and support do not change.
  heap_.clear();
  for (const std::size_t c : alive_) {
    const Evidence e = evidence(c, min_fresh, min_support, settings_.min_cameras);
    if (e.cameras < settings_.min_cameras || e.support < min_support || e.fresh < min_fresh) {
      continue;
    }
    heap_.push_back({e.fresh, e.support, static_cast<std::uint32_t>(c), 0});
  }
  std::make_heap(heap_.begin(), heap_.end());
  std::uint32_t round = 0;  // people found in this pass: what each figure is up to date with
  while (!heap_.empty()) {
    std::pop_heap(heap_.begin(), heap_.end());
    const Ranked top = heap_.back();
    heap_.pop_back();
    const Candidate& found = candidates_[top.candidate];
    if (std::any_of(detections_.end() - static_cast<std::ptrdiff_t>(round), detections_.end(),
                    [&](const Detection& d) { return tooClose(top.candidate, d.x_m, d.y_m); })) {
      continue;  // too close to someone found since it was judged
    }
    if (top.round != round) {
      // Unless the boxes of someone found since touch its boxes in some camera, it would add just
      // what it did (the pieces explained are only ever added to): judged again only then.
      const std::size_t since = chosen_.size() - (round - top.round);
      if (!touchedSince(top.candidate, since)) {
        heap_.push_back({top.fresh, top.support, top.candidate, round});
        std::push_heap(heap_.begin(), heap_.end());
        continue;
      }
      const Evidence e = evidence(top.candidate, min_fresh);
      if (e.fresh < min_fresh) continue;
      heap_.push_back({e.fresh, e.support, top.candidate, round});
      std::push_heap(heap_.begin(), heap_.end());
      continue;
    }
    detections_.push_back({found.x_m, found.y_m, footprintArea(found), top.support,
                           low ? settings_.object_height_m : settings_.box_height_m});
    chosen_.push_back(top.candidate);
    markExplained(top.candidate);
    ++round;
  }
}

bool FootprintDetector::touchedSince(std::size_t c, std::size_t first_found) const {
  const Candidate& candidate = candidates_[c];
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    const Box& bound = boundOf(candidate, k);
    if (bound.u0 == kNotSeen) continue;
    for (std::size_t i = first_found; i < chosen_.size(); ++i) {
      const Box& other = boundOf(candidates_[chosen_[i]], k);
      if (other.u0 != kNotSeen && meet(other, bound)) return true;
    }
  }
  return false;
}

// With blocks of one pixel, the integral image straight from the changed bits: no counts to
// clear, scatter and sum again. A tile row's byte gives its 8 pixels' running counts from a
// table, so each row is a few adds per 8 pixels with one running sum between bytes.
void FootprintDetector::integratePixels(CameraPlane& plane, const std::uint8_t* changed) {
  const std::size_t tiles_across = tilesAcross(plane.width);
  const std::size_t stride = static_cast<std::size_t>(plane.across) + 1;
  const std::size_t width = static_cast<std::size_t>(plane.width);
  for (std::size_t v = 0; v < static_cast<std::size_t>(plane.height); ++v) {
    const std::uint8_t* bytes = changed + (v / 8) * tiles_across * 8 + v % 8;
    const std::uint32_t* above = plane.changed.data() + v * stride + 1;
    std::uint32_t* row = plane.changed.data() + (v + 1) * stride + 1;
    std::uint32_t sum = 0;
    for (std::size_t tile = 0; tile < tiles_across; ++tile) {
      const std::size_t u0 = tile * 8;
      const std::size_t n = std::min<std::size_t>(8, width - u0);
      // Bits past the image's width (the last tile's padding) do not count.
      const unsigned byte = bytes[tile * 8] & ((1u << n) - 1u);
      // A whole tile with the count a constant, which the compiler unrolls (with n alone,
      // Terrace's stage took some 4 % longer).
      sum = n == 8 ? integrateByte(row + u0, above + u0, sum, byte, 8)
                   : integrateByte(row + u0, above + u0, sum, byte, n);
    }
  }
}

// The map's occupied cells' integral image, 8 cells at a time as integratePixels does: the 8
// cells' occupied bits gathered into a byte (kOccupied is 1, the other states 0 and 2), then its
// running counts from the table (one cell at a time, a 512 x 512 map took some 0.2 ms).
void FootprintDetector::integrateOccupied(std::span<const CellState> cells) {
  static_assert(static_cast<int>(CellState::kOccupied) == 1 &&
                static_cast<int>(CellState::kFree) == 0 &&
                static_cast<int>(CellState::kUnseen) == 2);
  static_assert(std::endian::native == std::endian::little, "cell i of 8 is byte i");
  constexpr std::uint64_t kLowBits = 0x0101010101010101ull;
  // Byte i's bit 0 to bit 56 + i: each bit's product lands alone, so nothing carries.
  constexpr std::uint64_t kGather = 0x0102040810204080ull;
  const std::size_t width = static_cast<std::size_t>(map_.width);
  const std::size_t stride = width + 1;
  for (std::size_t row = 0; row < static_cast<std::size_t>(map_.height); ++row) {
    const CellState* in = cells.data() + row * width;
    const std::uint32_t* above = occupied_.data() + row * stride + 1;
    std::uint32_t* out = occupied_.data() + (row + 1) * stride + 1;
    std::uint32_t sum = 0;
    std::size_t column = 0;
    for (; column + 8 <= width; column += 8) {
      std::uint64_t states;
      std::memcpy(&states, in + column, sizeof states);
      const std::uint64_t occupied = states & ~(states >> 1) & kLowBits;
      sum = integrateByte(out + column, above + column, sum,
                          static_cast<unsigned>((occupied * kGather) >> 56), 8);
    }
    for (; column < width; ++column) {
      sum += in[column] == CellState::kOccupied;
      out[column] = above[column] + sum;
    }
  }
}

const std::vector<Detection>& FootprintDetector::detect(
    std::span<const std::uint8_t* const> changed, std::span<const CellState> cells,
    std::span<const Eigen::Vector2d> expected) {
  if (changed.size() != planes_.size()) {
    throw std::invalid_argument("FootprintDetector: one changed-pixel mask per camera");
  }
  if (cells.size() != map_.cellCount()) {
    throw std::invalid_argument("FootprintDetector: the map is not the detector's");
  }
  detections_.clear();
  chosen_.clear();
  expected_ = expected;
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    changed_[k] = changed[k];
    if (changed[k] == nullptr) continue;
    CameraPlane& plane = planes_[k];
    if (plane.block == 1) {
      integratePixels(plane, changed[k]);
      continue;
    }
    // Changed pixels counted per block, a tile row's byte (8 pixels) at a time: most are 0.
    std::fill(plane.counts.begin(), plane.counts.end(), 0u);
    const std::size_t tiles_across = tilesAcross(plane.width);
    for (int v = 0; v < plane.height; ++v) {
      const std::uint8_t* bytes = changed[k] + static_cast<std::size_t>(v / 8) * tiles_across * 8 +
                                  static_cast<std::size_t>(v % 8);
      std::uint32_t* counts = plane.counts.data() + static_cast<std::size_t>(v / plane.block) *
                                                        static_cast<std::size_t>(plane.across);
      for (std::size_t tile = 0; tile < tiles_across; ++tile) {
        unsigned byte = bytes[tile * 8];
        if (byte == 0) continue;
        if (plane.whole_tile[tile]) {
          counts[plane.block_of[tile * 8]] += kBitsIn[3][byte][0];
          continue;
        }
        if (8 % plane.block == 0) {
          // Blocks of 2 or 4 pixels: the tile's 8 columns are 8 / block whole blocks from its
          // first, each counted from a table (a bit at a time, room-crowd's two 640 x 480 cameras
          // with blocks of 2 took some 0.2 ms a map more; std::popcount is no instruction on
          // x86-64's baseline).
          const std::size_t u0 = tile * 8;
          const std::size_t valid =
              std::min<std::size_t>(8, static_cast<std::size_t>(plane.width) - u0);
          const auto& groups = kBitsIn[static_cast<std::size_t>(
              std::countr_zero(static_cast<unsigned>(plane.block)))][byte & ((1u << valid) - 1u)];
          const std::size_t first = plane.block_of[u0];
          const std::size_t n =
              std::min<std::size_t>(8 / static_cast<std::size_t>(plane.block),
                                    static_cast<std::size_t>(plane.across) - first);
          for (std::size_t g = 0; g < n; ++g) counts[first + g] += groups[g];
          continue;
        }
        while (byte != 0) {
          const std::size_t u = tile * 8 + static_cast<std::size_t>(std::countr_zero(byte));
          byte &= byte - 1;
          if (u < static_cast<std::size_t>(plane.width)) ++counts[plane.block_of[u]];
        }
      }
    }
    const std::size_t stride = static_cast<std::size_t>(plane.across) + 1;
    for (int v = 0; v < plane.down; ++v) {
      const std::uint32_t* above = plane.changed.data() + static_cast<std::size_t>(v) * stride;
      std::uint32_t* row = plane.changed.data() + static_cast<std::size_t>(v + 1) * stride;
      const std::uint32_t* counts =
          plane.counts.data() +
          static_cast<std::size_t>(v) * static_cast<std::size_t>(plane.across);
      std::uint32_t sum = 0;
      for (int u = 0; u < plane.across; ++u) {
        sum += counts[u];
        row[u + 1] = above[u + 1] + sum;
      }
    }
  }
  forgetExplained();
  std::fill(strips_changed_.begin(), strips_changed_.end(), kNotSummed);
  integrateOccupied(cells);
  // The people expected first, then everyone, then what stands lower where no one was found.
  first_low_ = std::min(first_low_, candidates_.size());
  if (markExpected(expected)) {
    explainGreedily(0, first_low_, true);
    explainGreedily(first_low_, candidates_.size(), true);
  }
  const std::size_t expected_found = detections_.size();
  explainGreedily(0, first_low_, false);
  explainGreedily(first_low_, candidates_.size(), false);
  was_expected_.assign(detections_.size(), 0);
  std::fill_n(was_expected_.begin(), expected_found, std::uint8_t{1});
  // Then each detection, the last found first, is judged again against the pixels all the others
  // explain: a ghost taken early, before the people whose silhouettes make it, is then seen to add
  // nothing and goes (the crowd set: false positives 108 -> 64, misses 62 -> 66).
  keepOnly([&](std::size_t i) {
    const double bar =
        settings_.min_fresh * (was_expected_[i] != 0 ? settings_.expected_fresh_share : 1.0);
    return evidence(chosen_[i], bar).fresh < bar;
  });
  if (settings_.settle_reach_m > 0) {
    settle();
    // And once settled, a person's own part of the images (the pixels of their boxes that no one
    // else's cover) must have changed as much as a person fills a box: what is left of a ghost
    // once the people around it have settled is mostly the floor between them (EPFL Terrace's
    // crowd, settled: false positives 55 -> 47, misses 51 -> 52).
    // Where two cameras alone see them, more of it (ghosts are made where two views' rays meet).
    // Counted by the rig's geometry, not by the frames that came: a frame set short of a camera
    // under load must not make everyone harder to find.
    keepOnly([&](std::size_t i) {
      if (chosen_[i] >= first_low_) return false;
      const Fit f = fit(chosen_[i]);
      return f.own < (f.in_view <= 2 ? settings_.two_view_min_own : settings_.min_support);
    });
    // And two whom one place explains about as well are one.
    mergeDoubles();
  }
  if (settings_.hold_hidden) holdHidden();
  return detections_;
}

template <class Fails>
void FootprintDetector::keepOnly(Fails fails) {
  if (detections_.empty()) return;
  kept_.assign(detections_.size(), 1);
  for (std::size_t i = detections_.size(); i-- > 0;) {
    forgetExplained();
    clearWindows();
    widenWindows(chosen_[i]);
    for (std::size_t j = 0; j < chosen_.size(); ++j) {
      if (j != i && kept_[j] != 0) markExplained(chosen_[j], true);
    }
    if (fails(i)) kept_[i] = 0;
  }
  std::size_t out = 0;
  for (std::size_t i = 0; i < detections_.size(); ++i) {
    if (kept_[i] == 0) continue;
    chosen_[out] = chosen_[i];
    was_expected_[out] = was_expected_[i];
    detections_[out++] = detections_[i];
  }
  detections_.resize(out);
  chosen_.resize(out);
  was_expected_.resize(out);
}

bool FootprintDetector::markExpected(std::span<const Eigen::Vector2d> expected) {
  if (expected.empty() || !(settings_.expected_reach_m > 0)) return false;
  std::fill(near_expected_.begin(), near_expected_.end(), std::uint8_t{0});
  const double reach2 = settings_.expected_reach_m * settings_.expected_reach_m;
  const int steps = static_cast<int>(std::ceil(settings_.expected_reach_m / step_));
  bool any = false;
  const double map_width_m = map_.width * map_.cell_size_m;
  const double map_height_m = map_.height * map_.cell_size_m;
  for (const Eigen::Vector2d& at : expected) {
    // A track coasting off the map (or a prediction gone wrong) has no candidate near it.
    const double x = at.x() - map_.origin_x_m, y = at.y() - map_.origin_y_m;
    if (!(x > -settings_.expected_reach_m && x < map_width_m + settings_.expected_reach_m &&
          y > -settings_.expected_reach_m && y < map_height_m + settings_.expected_reach_m)) {
      continue;
    }
    const auto [row, column] = gridPlaceOf(at.x(), at.y());
    forEachNear(row, column, steps, [&](std::size_t n) {
      const double dx = candidates_[n].x_m - at.x(), dy = candidates_[n].y_m - at.y();
      if (dx * dx + dy * dy > reach2) return;
      near_expected_[candidates_[n].on_grid] = 1;
      any = true;
    });
  }
  return any;
}

}  // namespace occmap
