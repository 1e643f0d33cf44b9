#pragma once
// People and objects on the map (issue 14, docs/detection.md): where the cameras' evidence says
// something stands, not merely where the floor is hidden.
//
// The occupancy map alone is not a detector: most of its occupied cells are occlusion wedges, the
// floor behind people that no camera can vouch for. What tells a person from a wedge is the rest
// of the column: a person standing at a place changes the image of a person-sized box there in
// every camera that has it in view, while above a wedge some camera sees the background past the
// person who casts it. And in a crowd, where every camera's box at a wrong place is covered by
// other people's silhouettes, the changed pixels are explained jointly: people are taken one at a
// time, the best explained first, and the pixels each one explains no longer count as evidence for
// anyone else (a greedy explanation of the images, in the spirit of POM's joint one at a small
// part of its cost).
//
// Per frame set: each camera's changed pixels (core/fusion_kernel.h's tile layout) and the map.
// Candidates are the places on a grid with an occupied map cell within a quarter of the box's
// width (the map says where nothing stands: column carving keeps a person's own cells occupied).
// Each candidate's box is, in each camera whose image has its foot point, the rectangle of an
// upright board of POM's person (0.5 x 1.75 m) standing there and facing the camera. Its support
// in a camera is the share of the box's pixels that changed; a candidate needs min_support from
// every camera that sees it, and at least min_cameras of them. Of those, the one whose boxes hold
// the largest share of changed pixels not yet explained (its fresh evidence, the mean over its
// cameras) is taken, its boxes' changed pixels become explained, and the rest are judged again,
// until none adds min_fresh; then each detection is judged again against what all the others
// explain, settles where its boxes best explain the pixels no one else's cover, and must have
// changed enough of those (docs/detection.md, "How people are found"). Last, someone a tracker
// expects and the evidence did not find is held there while hidden (hold_hidden): one view of
// them is then enough, when no camera that sees the place shows the floor.
// No I/O, no threads; buffers are made once, nothing is allocated per frame set once the
// detections have their largest count.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/explained_pieces.h"
#include "core/integral_image.h"
#include "core/map_geometry.h"

namespace occmap {

struct FootprintSettings {
  // Whether occmapd finds people on its maps and follows them (tracks_t); the off-line commands
  // find them when asked to, whatever this says.
  bool enabled = true;
  // The person-sized box: POM's (Fleuret et al. 2008).
  double box_width_m = 0.5;
  double box_height_m = 1.75;
  // What stands lower than a person (a cart, a small robot) fills too little of a person's box:
  // where no person was found, boxes this high are tried next (0: none), with their own least
  // support and fresh evidence. An object fills its low box more than a person fills theirs, and
  // the lower body of someone behind others fills a low box too: these keep such ghosts out
  // (sim://room-crowd, 300 maps: its robot found in 19 % of them with people's boxes alone, in
  // 51 % so; MODA 64.3 -> 66.9 %, precision 94.5 -> 94.2 %; EPFL Terrace's crowd: MODA 73.0 ->
  // 73.9 %, docs/detection.md).
  double object_height_m = 0.5;
  double object_min_support = 0.4;
  double object_min_fresh = 0.3;
  // The candidates' grid (at least the map's cell).
  double step_m = 0.1;
  // The least share of changed pixels among a camera's unexplained pixels of the box for it to
  // support a person there. A person fills well under all of the rectangle bounding the box
  // (measured on EPFL Terrace's masks, docs/detection.md).
  double min_support = 0.2;
  // The least number of cameras that support a person there: one view alone cannot tell a person
  // from the floor behind one, anywhere along its rays (measured on EPFL Terrace's crowd:
  // detections one camera alone supported were 13 people and 524 ghosts, docs/detection.md).
  int min_cameras = 2;
  // The least mean share, over the cameras that see it, of a box's pixels changed and not yet
  // explained by the people found: what a person there would add.
  double min_fresh = 0.1;
  // Two people's centres are at least this far apart on the floor.
  double min_separation_m = 0.35;
  // Once all are found, each person settles where their boxes best explain the images beside
  // everyone else's, up to this far from where the greedy took them (0: not at all). Taken one
  // at a time, people in a crowd land where the silhouettes of several overlap; beside the others
  // they move onto their own (EPFL Terrace's crowd: MODA 73.9 -> 79.5 %, precision 86.6 ->
  // 90.2 %, with the look at what each explains alone; docs/detection.md).
  double settle_reach_m = 0.5;
  // Where no more than two cameras see a person found, the share of their boxes' own pixels (those
  // no one else's box covers) that changed must reach this, instead of min_support (settling's
  // last step). Two views are where ghosts are made: the rays through two people's silhouettes,
  // one in each camera, meet where no one stands, and nothing a third camera sees says otherwise.
  // EPFL Terrace's crowd, settled: at places two cameras see, 26 people found and 31 ghosts; at
  // places three or four see, 404 and 16. Twice min_support: MODA 79.5 -> 81.3 %, precision
  // 90.2 -> 94.8 %, recall 89.2 -> 86.1 % (0.3: 80.9 / 93.5 %; no one found there at all: 80.7 /
  // 96.0 %); the simulated rooms unchanged to the digit (their people and objects are found where
  // three or four cameras see, or fill their boxes well past the bar; docs/detection.md, step 7).
  double two_view_min_own = 0.4;
  // The people a tracker follows (Tracker::expectedAt) are explained first where it expects
  // them: the greedy explanation runs over the candidates within expected_reach_m of such a place
  // (people's boxes, then low ones) before it runs over everyone. One map alone, a ghost where
  // several silhouettes cross can be taken before the people whose silhouettes make it, and then
  // explain so much of theirs that they add too little to be found; someone followed up to the
  // last map is explained first and leaves the ghost little. The bars stay: an expectation is an
  // order, not evidence (expected_fresh_share 1). Measured over 600 maps (docs/detection.md):
  // sim://room MOTA 91.9 -> 94.6 %, IDF1 84.3 -> 89.7 %; sim://room-crowd MODA 71.2 -> 72.8 %,
  // MOTA 70.9 -> 73.5 %. A lower share finds more in the crowd (0.5: MODA 79.1 %) but keeps a
  // track's double alive on the next maps (the room's MOTA 82.7 %). 0 reach: no one expected.
  double expected_reach_m = 0.3;
  double expected_fresh_share = 1.0;
  // Only the tracks found no more than this long before the map are expected (off-line, only when
  // the time between maps is known: a sequence of still images a second apart has none).
  double expected_within_s = 0.2;
  // Each box in each camera as this many bands of its rows, each as wide as the board is between
  // them (1: the rectangle bounding the board). A board leans in the image, the more the nearer
  // the image's edge and the steeper the view: on the paper's rig its rectangle holds 1.35 times
  // its pixels at the median (1.8 at the tenth percentile), pixels of the people beside it, which
  // it then explains away. Measured 2026-12-07 (docs/detection.md, step 2), 3 strips against the
  // rectangle: sim://room-crowd MODA 73.3 -> 84.7 %, MOTA 74.7 -> 87.8 %; EPFL Terrace's crowd
  // 81.3 -> 82.6 %, precision 94.8 -> 95.0 %; sim://room MODA 94.1 -> 95.7 %. It costs time:
  // room-crowd's stage 1.75 -> 3.5 ms a map on a Xeon.
  int box_strips = 3;
  // Whether a zone whose occupied cells are all the floor hidden behind people found is UNSEEN
  // rather than OCCUPIED (core/zones.h, core/hidden_floor.h). Off by default: a zone's state is
  // then the map's cells' alone, as the issue defines it (occupied when any cell is).
  bool hidden_floor_unseen = false;
  // Someone a tracker follows (an expected place) whom this map's evidence alone does not find is
  // held there while hidden rather than gone: when no one was found within a box's width of where
  // they are expected, a place within expected_reach_m of it whose boxes, beside everyone found,
  // have the box's least support changed in every camera that sees it (nothing there shows the
  // floor), and whose own part (the pixels no one else's box covers) changed hold_own_factor
  // times that. One view is then enough. In a crowd most of those missed are seen by one camera
  // alone at that moment (two cameras see 94.5 % of the people's maps, 68.7 % of the robot's),
  // which one map cannot tell from the floor behind someone; a track knows they were there. A
  // held detection (Detection::held) keeps its track but does not count as seeing it, so a track
  // only held ends as one with none (TrackerSettings::lost_after_s). Over 600 maps, against no
  // holds (docs/detection.md, step 11): sim://room-crowd MODA 85.5 -> 91.8 %, MOTA 87.6 -> 90.5 %,
  // IDF1 66.9 -> 70.5 %, precision 96.3 -> 94.6 %; sim://room MODA 95.7 -> 95.8 %, IDF1 91.5 ->
  // 98.2 %; EPFL's still images have no tracks and are unchanged.
  bool hold_hidden = true;
  double hold_own_factor = 1.5;
};

struct Detection {
  double x_m = 0.0;
  double y_m = 0.0;
  double area_m2 = 0.0;   // the occupied map cells that the box's footprint covers or touches
  double score = 0.0;     // the least support of a camera that sees it, 0 to 1
  double height_m = 0.0;  // the box it was found with: a person's, or a low object's
  // Held where a tracker expected someone hidden (FootprintSettings::hold_hidden), not found by
  // the evidence alone: a tracker keeps such a track but does not count it as seen.
  bool held = false;
};

// A rectangle of stream pixels, its corners' coordinates included.
struct PixelRectangle {
  double u0, v0, u1, v1;
};

// The rectangle holding, in the camera's image, an upright board width_m wide and height_m tall
// standing on the floor at `at` and facing the camera (POM's person: the rectangle bounding a 3D
// box's corners is up to 1.4 times wider than any person seen from an angle). `below`: the
// camera's centre on the floor. Empty when a corner has no pixel, or the camera is right above.
std::optional<PixelRectangle> boardInImage(const Camera& camera, const Eigen::Vector2d& below,
                                           const Eigen::Vector2d& at, double width_m,
                                           double height_m);

class FootprintDetector {
 public:
  FootprintDetector(const MapGeometry& map, std::span<const Camera> cameras,
                    const FootprintSettings& settings = {});

  // changed[k]: camera k's changed-pixel tiles, or nullptr when it has no frame in this set (it
  // then says nothing). `cells` is the map fused from them. `expected`: where a tracker expects
  // the people it follows (settings' expected_reach_m). Valid until the next call.
  const std::vector<Detection>& detect(std::span<const std::uint8_t* const> changed,
                                       std::span<const CellState> cells,
                                       std::span<const Eigen::Vector2d> expected = {});

  // Camera k's boxes for its new pose (a camera re-posed after a knock, core/repose.h), its image
  // of the same size; each candidate stays where it is on the floor, and camera k's blocks keep
  // their size. Allocates nothing, but projects every candidate's board anew: not for a map's
  // path.
  void replaceCamera(std::size_t k, const Camera& camera);

 private:
  using Box = BlockBox;  // a candidate's rectangle in one camera
  // A camera's changed pixels counted in square blocks (their size: the constructor's).
  struct CameraPlane {
    int width = 0;  // pixels
    int height = 0;
    int block = 1;   // pixels a side
    int across = 0;  // blocks
    int down = 0;
    std::vector<std::uint16_t> block_of;   // each pixel column's block column
    std::vector<std::uint8_t> whole_tile;  // 1: a tile's 8 columns lie in one block
    std::vector<std::uint32_t> counts;     // changed pixels per block
    std::vector<std::uint32_t> changed;    // integral image of counts
    // The union of the boxes of the people found so far.
    ExplainedPieces explained;
  };
  static constexpr int kBlocksPerBox = 16;
  // Explained pieces are kept by bands of 2^kBandShift columns of blocks, two narrow boxes wide:
  // sim://room-crowd's stage 3.42 -> 2.79 ms a map against one list (bands one box wide: 2.98 ms;
  // four: 2.80 ms), the room's and Terrace's, with fewer pieces, some 0.05 ms longer.
  static constexpr int kBandShift = 5;
  // Map cells [row0, row1) x [column0, column1).
  struct CellRange {
    int row0, column0, row1, column1;
  };
  static void integratePixels(CameraPlane& plane, const std::uint8_t* changed);
  // Entry i of boxes_ and bounds_ (candidate i / cameras, camera i % cameras) from the board's
  // corners in the camera's image (nullptr: the camera does not see the place).
  void placeStrips(std::size_t i, const std::array<Eigen::Vector2d, 4>* board);
  // The changed pixels of a box's `count` strips that the people found cover (their boxes' union
  // is kept as disjoint pieces, so each piece's overlap counts once), and with kBlocks the blocks
  // those pieces cover (the greedy's evidence() needs only the first, and is the detector's hot
  // loop). `bound`: the rectangle holding the strips, against which most pieces fail at once.
  struct Overlap {
    double changed = 0.0;
    double blocks = 0.0;
  };
  template <bool kBlocks>
  static Overlap piecesIn(const CameraPlane& plane, const Box& bound, const Box* strips,
                          std::size_t count) {
    Overlap overlap;
    plane.explained.forEachMeeting(bound, [&](const Box& piece) {
      for (std::size_t s = 0; s < count; ++s) {
        const Box& box = strips[s];
        const int u0 = std::max(box.u0, piece.u0), u1 = std::min(box.u1, piece.u1);
        const int v0 = std::max(box.v0, piece.v0), v1 = std::min(box.v1, piece.v1);
        if (u0 < u1 && v0 < v1) {
          overlap.changed += rectangleSum(plane.changed, plane.across, u0, v0, u1, v1);
          if constexpr (kBlocks) overlap.blocks += static_cast<double>((u1 - u0) * (v1 - v0));
        }
      }
    });
    return overlap;
  }
  void integrateOccupied(std::span<const CellState> cells);
  CellRange cellsWithin(double x_m, double y_m, double reach_m) const;
  std::uint32_t occupiedWithin(const CellRange& range) const;
  struct Candidate;
  // The occupied map cells that a person's footprint there covers or touches, m².
  double footprintArea(const Candidate& candidate) const;
  struct Candidate {
    double x_m, y_m;
    // The cells within a quarter of the box's width of its centre: the annotation's and the
    // carving's slack. One of them must be occupied.
    CellRange near;
    std::size_t boxes;      // first of its cameras_.size() entries in boxes_
    std::uint32_t on_grid;  // its place in grid_: row * grid_across_ + column
  };
  static constexpr std::uint16_t kNotSeen = 0xffff;

  struct Evidence {
    int cameras = 0;       // that see the place
    double support = 1.0;  // the least share of changed pixels in a camera's box
    double fresh = 0.0;    // the mean share of changed pixels not yet explained
  };
  // Its fresh evidence is exact when it reaches `bar`; below, it is some figure below the bar (the
  // count stops once the bar is out of reach). With a veto: a candidate seen by fewer cameras, or
  // with less support, is given no fresh evidence (it fails) without counting what the people
  // found explain.
  Evidence evidence(std::size_t candidate, double bar, double veto_support = 0.0,
                    int veto_cameras = 0) const;
  mutable std::vector<double> box_changed_;  // evidence()'s: changed pixels in each camera's box
  // The changed pixels in the candidate's strips in camera k, summed once a map: the greedy judges
  // a candidate again and again, and settling the places around each person.
  std::uint32_t changedIn(std::size_t candidate, std::size_t k) const {
    std::uint32_t& changed = strips_changed_[candidate * planes_.size() + k];
    if (changed == kNotSummed) {
      const Box* strips = boxAt(candidates_[candidate], k);
      const CameraPlane& plane = planes_[k];
      changed = 0;
      for (std::size_t s = 0; s < strips_; ++s) {
        const Box& box = strips[s];
        changed += rectangleSum(plane.changed, plane.across, box.u0, box.v0, box.u1, box.v1);
      }
    }
    return changed;
  }
  static constexpr std::uint32_t kNotSummed = 0xffffffff;
  mutable std::vector<std::uint32_t> strips_changed_;  // candidates x cameras
  // How well the candidate's boxes would explain, beside the people found, the pixels that they
  // leave open (no one found covers them).
  struct Fit {
    double gain = 0.0;     // per camera that sees it, the mean of (changed - lambda * unchanged)
                           // open pixels, as a share of the box's pixels
    double own = 0.0;      // the share changed of the open pixels, each camera's counted as
                           // shares of its box (0 where none is open)
    double support = 0.0;  // as Evidence's
    int cameras = 0;       // that see the place and have a frame in this set
    int in_view = 0;       // whose images have the place, with a frame in this set or not
  };
  Fit fit(std::size_t candidate) const;
  // Whether the boxes of the people found from chosen_[first_found] on meet the candidate's in
  // some camera (their bounds do).
  bool touchedSince(std::size_t candidate, std::size_t first_found) const;
  // The changed pixels of the candidate's boxes become explained. With near_windows, only in the
  // cameras where its boxes meet windows_'s: what the others explain is looked at only near one
  // person (keepOnly, settle, mergeDoubles), and there the union is the same.
  void markExplained(std::size_t candidate, bool near_windows = false);
  // windows_ per camera: none (clearWindows), the rectangle holding the boxes of the people's
  // candidates within `steps` of the grid's place (row, column), widened by a candidate's boxes.
  void clearWindows();
  void windowsNear(int row, int column, int steps);
  void widenWindows(std::size_t candidate);
  void forgetExplained();
  // expected_only: only the candidates near an expected place (near_expected_), their bars of
  // fresh evidence times expected_fresh_share.
  void explainGreedily(std::size_t begin, std::size_t end, bool expected_only);
  // Marks near_expected_; false when no candidate is near an expected place.
  bool markExpected(std::span<const Eigen::Vector2d> expected);
  // Each detection, the last found first, judged against the pixels that all the others kept
  // explain; those for which fails(i) holds go.
  template <class Fails>
  void keepOnly(Fails fails);
  void settle();
  void mergeDoubles();
  void holdHidden();
  // How near another one found may be to a person found (min_separation_m) or to something lower
  // (a box's width at least: the two footprints do not overlap).
  double separationFor(bool low) const {
    return low ? std::max(settings_.min_separation_m, settings_.box_width_m)
               : settings_.min_separation_m;
  }
  // Whether someone found stands nearer than distance_m to the floor point.
  bool anyFoundWithin(double x_m, double y_m, double distance_m) const {
    return std::any_of(detections_.begin(), detections_.end(), [&](const Detection& d) {
      const double dx = d.x_m - x_m, dy = d.y_m - y_m;
      return dx * dx + dy * dy < distance_m * distance_m;
    });
  }
  std::span<const Eigen::Vector2d> expected_;  // detect()'s, during the call
  // Whether the places where detections i and j are expected (the nearest to each within a box's
  // width) are two, a box's width apart or more: two people followed, whom step 10 leaves two.
  bool followedApart(std::size_t i, std::size_t j) const;
  // The candidates' grid place nearest a floor point (place i along an axis is at origin +
  // (i + 1/2) step), as {row, column}: perhaps off the grid.
  std::pair<int, int> gridPlaceOf(double x_m, double y_m) const {
    return {static_cast<int>(std::lround((y_m - map_.origin_y_m) / step_ - 0.5)),
            static_cast<int>(std::lround((x_m - map_.origin_x_m) / step_ - 0.5))};
  }
  // Calls visit(candidate) for each people's candidate on the grid within `steps` places of
  // (row, column) across and down (or each of `grid`'s: low_grid_).
  template <class Visit>
  void forEachNear(int row, int column, int steps, Visit visit) const {
    forEachNearIn(grid_, row, column, steps, visit);
  }
  template <class Visit>
  void forEachNearIn(const std::vector<std::uint32_t>& grid, int row, int column, int steps,
                     Visit visit) const {
    for (int r = std::max(0, row - steps); r <= std::min(grid_down_ - 1, row + steps); ++r) {
      for (int col = std::max(0, column - steps); col <= std::min(grid_across_ - 1, column + steps);
           ++col) {
        const std::uint32_t n =
            grid[static_cast<std::size_t>(r) * static_cast<std::size_t>(grid_across_) +
                 static_cast<std::size_t>(col)];
        if (n != kNoCandidate) visit(static_cast<std::size_t>(n));
      }
    }
  }

  MapGeometry map_;
  FootprintSettings settings_;
  std::vector<Candidate> candidates_;  // people's boxes, then from first_low_ the low ones
  std::size_t first_low_ = SIZE_MAX;
  // candidates x cameras x strips_; u0 == kNotSeen where not in view
  std::vector<Box> boxes_;
  // candidates x cameras: the rectangle holding its strips, with the strips' pixels
  std::vector<Box> bounds_;
  std::size_t strips_ = 1;
  const Box* boxAt(const Candidate& candidate, std::size_t k) const {
    return boxes_.data() + (candidate.boxes + k) * strips_;
  }
  float pixelsOf(const Candidate& candidate, std::size_t k) const {
    return bounds_[candidate.boxes + k].pixels;
  }
  const Box& boundOf(const Candidate& candidate, std::size_t k) const {
    return bounds_[candidate.boxes + k];
  }
  // The people's candidates by their place on the grid (kNoCandidate where there is none), for
  // settle()'s neighbours.
  static constexpr std::uint32_t kNoCandidate = 0xffffffff;
  double step_ = 0.0;  // the grid's, metres
  int grid_across_ = 0;
  int grid_down_ = 0;
  std::vector<std::uint32_t> grid_;
  std::vector<std::uint32_t> low_grid_;      // the low boxes' candidates, as grid_
  std::vector<std::uint8_t> near_found_;     // explainGreedily's: places near someone found
  std::vector<std::uint8_t> near_expected_;  // places near where someone is expected
  std::vector<std::uint8_t> was_expected_;   // per detection: found near where one was expected
  std::vector<CameraPlane> planes_;
  std::vector<const std::uint8_t*> changed_;
  std::vector<std::uint32_t> occupied_;  // integral image of the map's occupied cells
  std::vector<std::size_t> alive_;
  // explainGreedily's candidates by what they would add, as of the people found by `round`.
  struct Ranked {  // 24 bytes: with a std::size_t candidate (32), a map took 2 to 5 % longer
    double fresh;
    double support;
    std::uint32_t candidate;
    std::uint32_t round;
    // The heap's top is the most fresh evidence, then the smallest index.
    bool operator<(const Ranked& other) const {
      return fresh < other.fresh || (fresh == other.fresh && candidate > other.candidate);
    }
  };
  std::vector<Ranked> heap_;
  std::vector<Detection> detections_;
  std::vector<std::size_t> chosen_;  // the candidate of each detection
  std::vector<std::uint8_t> kept_;
  std::vector<Box> windows_;  // per camera
};

}  // namespace occmap
