#pragma once
// A knocked camera put right without anyone climbing a ladder (issue 13, docs/lighting.md). A
// camera turned on its mount sees the same room from the same centre, so everything it needs can be
// computed rather than learnt: its pose turned by what the view's motion says
// (core/view_motion.h), and its background and floor mask as the turned camera sees the old ones.
// Nothing comes from live frames, so nothing that stood on the floor while it was knocked (a box
// put down, a person standing still) can become background: the safety of the fixed background
// holds. What the old view never saw (a strip along the borders the turn brings in) is left out of
// the floor mask, so it never votes.
// No I/O, no threads. Building the carve table takes as long as at start-up (seconds for column
// tables of large maps): occmapd does it off the capture thread.

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/carve_table.h"
#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap {

struct ReposedCamera {
  Eigen::Vector3d turn = Eigen::Vector3d::Zero();  // what it was turned by (CameraTurn::turn)
  Camera camera;                                   // the old camera turned so
  Image background;                                // the old background as it now sees it
  Image floor_mask;  // the old mask as it now sees it; 0 where the old view had nothing
  CarveTable table;
};

// The re-posed camera of `camera` (whose background and floor mask are given; an empty mask is
// all floor) turned by `turn`, with its carve table for `map` at `column_height_m`.
ReposedCamera reposeCamera(const Camera& camera, const Eigen::Vector3d& turn, ImageView background,
                           ImageView floor_mask, const MapGeometry& map, double column_height_m);

// When to re-pose: a camera found moved by the same turn, and by a turn alone (a camera also moved
// along, or a view otherwise changed, cannot be put right so), in every check for at least
// kSteadyUs. Then someone who knocked it has let go, and the turn is measured on a still view.
// Time is passed in (the checks' capture times).
class ReposePolicy {
 public:
  // One check of the view at `time_us`: moved or not, and the turn found. Returns the turn to
  // re-pose by (the newest check's) once steady; then starts over.
  std::optional<Eigen::Vector3d> check(std::int64_t time_us, bool moved,
                                       const Eigen::Vector3d& turn, double residual_px);
  void reset() { first_us_.reset(); }

  static constexpr std::int64_t kSteadyUs = 2'000'000;
  // Two checks agree when their turns differ by less than this (radians; 0.1 degree).
  static constexpr double kSameTurnRad = 0.1 * 3.14159265358979323846 / 180;
  // A turn alone moves every region of the view as predicted to within this (pixels).
  static constexpr double kMaxResidualPx = 1.5;

 private:
  std::optional<std::int64_t> first_us_;  // the first check of the steady run
  Eigen::Vector3d first_turn_ = Eigen::Vector3d::Zero();
};

}  // namespace occmap
