// Settling (docs/detection.md, "How people are found", steps 6 and 7): once the greedy
// explanation has found everyone, each person moves to where their boxes best explain the pixels
// that no one else's box covers, and must have changed enough of those. Taken one at a time,
// people in a crowd land where the silhouettes of several overlap; beside the others they move
// onto their own.

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/footprints.h"
#include "core/integral_image.h"

namespace occmap {

FootprintDetector::Fit FootprintDetector::fit(std::size_t c) const {
  // An unchanged open pixel costs what makes a box whose open pixels changed at exactly
  // min_support gain nothing: lambda = s / (1 - s).
  const double lambda = settings_.min_support / std::max(1e-9, 1.0 - settings_.min_support);
  const Candidate& candidate = candidates_[c];
  Fit f;
  f.support = 1.0;
  double own_weight = 0.0;
  for (std::size_t k = 0; k < planes_.size(); ++k) {
    const Box* strips = boxAt(candidate, k);
    if (strips->u0 == kNotSeen) continue;
    ++f.in_view;
    if (changed_[k] == nullptr) continue;
    const CameraPlane& plane = planes_[k];
    const double pixels = static_cast<double>(pixelsOf(candidate, k));
    const double changed = changedIn(c, k);
    const Overlap explained = piecesIn<true>(plane, boundOf(candidate, k), strips, strips_);
    // Blocks to pixels (a box at the image's edge may hold fewer than its blocks).
    const double covered = std::min(pixels, explained.blocks * plane.block * plane.block);
    const double fresh = changed - explained.changed, open = pixels - covered;
    ++f.cameras;
    f.support = std::min(f.support, changed / pixels);
    f.gain += (fresh - lambda * std::max(0.0, open - fresh)) / pixels;
    f.own += fresh / pixels;
    own_weight += open / pixels;
  }
  if (f.cameras == 0) return {.in_view = f.in_view};
  f.gain /= f.cameras;
  // Each camera weighs by how much of the box is open to it: a sliver beside someone else's box
  // is mostly the box's margin around the person, and says little (averaged per camera, the
  // room's people were found on 93 % of maps instead of 99 %).
  f.own = own_weight > 0 ? f.own / own_weight : 0.0;
  return f;
}

// Each person, with everyone else's boxes explained, moves to the place on the candidates' grid
// within settle_reach_m of where they were found whose gain is the largest, never closer than
// min_separation_m to another, and only where they keep the cameras and the support that found
// them. Every place within reach is judged: climbing from neighbour to neighbour stopped at
// nearer, worse places (EPFL Terrace's crowd: MODA 77.6 % against 79.7 %).
void FootprintDetector::settle() {
  const double reach2 = settings_.settle_reach_m * settings_.settle_reach_m;
  const double separation2 = settings_.min_separation_m * settings_.min_separation_m;
  for (std::size_t i = 0; i < detections_.size(); ++i) {
    if (chosen_[i] >= first_low_) continue;
    const Candidate& start = candidates_[chosen_[i]];
    const int row = static_cast<int>(start.on_grid) / grid_across_;
    const int column = static_cast<int>(start.on_grid) % grid_across_;
    const int steps = static_cast<int>(std::floor(settings_.settle_reach_m / step_ + 1e-9));
    forgetExplained();
    windowsNear(row, column, steps);
    for (std::size_t j = 0; j < chosen_.size(); ++j) {
      if (j != i) markExplained(chosen_[j], true);
    }
    std::size_t at = chosen_[i];
    double best = fit(at).gain;
    double support = 0.0;  // at the best place, once it is another
    forEachNear(row, column, steps, [&](std::size_t n) {
      if (n == chosen_[i]) return;
      const Candidate& there = candidates_[n];
      const double sx = there.x_m - start.x_m, sy = there.y_m - start.y_m;
      if (sx * sx + sy * sy > reach2 || occupiedWithin(there.near) == 0) return;
      const bool crowded = std::any_of(chosen_.begin(), chosen_.end(), [&](std::size_t o) {
        const double dx = candidates_[o].x_m - there.x_m, dy = candidates_[o].y_m - there.y_m;
        return o != chosen_[i] && dx * dx + dy * dy < separation2;
      });
      if (crowded) return;
      const Fit f = fit(n);
      if (f.cameras < settings_.min_cameras || f.support < settings_.min_support) return;
      if (f.gain > best) {
        best = f.gain;
        support = f.support;
        at = n;
      }
    });
    if (at == chosen_[i]) continue;
    chosen_[i] = at;
    const Candidate& settled = candidates_[at];
    detections_[i].x_m = settled.x_m;
    detections_[i].y_m = settled.y_m;
    detections_[i].area_m2 = footprintArea(settled);
    detections_[i].score = support;
  }
}

bool FootprintDetector::followedApart(std::size_t i, std::size_t j) const {
  const auto nearest = [&](const Detection& d) {
    const Eigen::Vector2d* found = nullptr;
    double best = settings_.box_width_m * settings_.box_width_m;
    for (const Eigen::Vector2d& at : expected_) {
      const double dx = at.x() - d.x_m, dy = at.y() - d.y_m;
      if (dx * dx + dy * dy < best) {
        best = dx * dx + dy * dy;
        found = &at;
      }
    }
    return found;
  };
  const Eigen::Vector2d* a = nearest(detections_[i]);
  const Eigen::Vector2d* b = nearest(detections_[j]);
  return a != nullptr && b != nullptr && (*a - *b).norm() >= settings_.box_width_m;
}

// Two found within one and a half boxes' width of each other whom one place explains about as well
// are one: something wider than a person's box (a chair seen across its diagonal, 0.7 m) fills a
// box on either side of its centre once the boxes follow the board (box_strips). The pair stays
// only when, everyone else explained, the first's gain and the second's beside it exceed the best
// single place within two grid steps of their midpoint by min_fresh, the least that a person found
// must add. sim://room's 600 maps with 3 strips: false positives 273 -> 25 (its chairs found
// twice), MODA 88.8 -> 95.7 %; room-crowd 84.3 -> 84.7 %; two people 0.6 m apart are two
// (Footprints.FindsEveryoneInRandomCrowdsAndNoGhosts, Footprints.WhatIsWiderThanABoxIsFoundOnce).
// Nor are two one whom a tracker follows as two, expected a box's width apart or more (the
// tracker's own rule against doubles, TrackerSettings::confirm_apart_m): two people walking
// shoulder to shoulder fill the images as one wide thing does, and a track knows they are two.
// With the tracker, 600 maps each: the room MOTA 95.2 -> 96.9 %, IDF1 85.4 -> 91.5 %, identity
// switches 8 -> 2; room-crowd MOTA 87.8 -> 87.6 %, IDF1 58.3 -> 66.9 %, switches 48 -> 34
// (Footprints.TwoFollowedSideBySideStayTwo; docs/detection.md, step 10).
void FootprintDetector::mergeDoubles() {
  const double near = 1.5 * settings_.box_width_m;
  for (std::size_t i = 0; i < detections_.size(); ++i) {
    if (chosen_[i] >= first_low_) continue;
    for (std::size_t j = i + 1; j < detections_.size(); ++j) {
      if (chosen_[j] >= first_low_) continue;
      const double dx = detections_[j].x_m - detections_[i].x_m;
      const double dy = detections_[j].y_m - detections_[i].y_m;
      if (dx * dx + dy * dy > near * near) continue;
      if (followedApart(i, j)) continue;
      const auto [row, column] = gridPlaceOf((detections_[i].x_m + detections_[j].x_m) / 2,
                                             (detections_[i].y_m + detections_[j].y_m) / 2);
      forgetExplained();
      windowsNear(row, column, 2);
      widenWindows(chosen_[i]);
      widenWindows(chosen_[j]);
      for (std::size_t o = 0; o < chosen_.size(); ++o) {
        if (o != i && o != j) markExplained(chosen_[o], true);
      }
      double single = -1e9;
      std::size_t at = SIZE_MAX;
      double single_support = 0.0;
      forEachNear(row, column, 2, [&](std::size_t n) {
        if (occupiedWithin(candidates_[n].near) == 0) return;
        const Fit f = fit(n);
        if (f.cameras < settings_.min_cameras || f.support < settings_.min_support) return;
        if (f.gain > single) {
          single = f.gain;
          single_support = f.support;
          at = n;
        }
      });
      if (at == SIZE_MAX) continue;
      const double first = fit(chosen_[i]).gain;
      markExplained(chosen_[i]);
      const double pair = first + fit(chosen_[j]).gain;
      if (pair - single >= settings_.min_fresh) continue;
      chosen_[i] = at;
      detections_[i].x_m = candidates_[at].x_m;
      detections_[i].y_m = candidates_[at].y_m;
      detections_[i].area_m2 = footprintArea(candidates_[at]);
      detections_[i].score = single_support;
      detections_.erase(detections_.begin() + static_cast<std::ptrdiff_t>(j));
      chosen_.erase(chosen_.begin() + static_cast<std::ptrdiff_t>(j));
      was_expected_.erase(was_expected_.begin() + static_cast<std::ptrdiff_t>(j));
      j = i;  // i moved: its neighbours again
    }
  }
}

// Each expected place with no one found within a box's width: the best place (by fit's gain)
// within expected_reach_m, no nearer anyone found than the greedy allows, whose boxes beside
// everyone found keep their least support in every camera that sees it (nothing there shows the
// floor) and whose own part changed hold_own_factor times that: a person's box first, then a low
// one. Taken one after another, each held one's boxes explained for the next.
void FootprintDetector::holdHidden() {
  const double reach2 = settings_.expected_reach_m * settings_.expected_reach_m;
  const int steps = static_cast<int>(std::ceil(settings_.expected_reach_m / step_));
  for (const Eigen::Vector2d& at : expected_) {
    if (anyFoundWithin(at.x(), at.y(), settings_.box_width_m)) continue;
    const auto [row, column] = gridPlaceOf(at.x(), at.y());
    if (row < 0 || row >= grid_down_ || column < 0 || column >= grid_across_) continue;
    // What everyone found explains, near both kinds of boxes within reach.
    forgetExplained();
    clearWindows();
    for (const std::vector<std::uint32_t>* grid : {&grid_, &low_grid_}) {
      forEachNearIn(*grid, row, column, steps, [&](std::size_t n) { widenWindows(n); });
    }
    for (const std::size_t c : chosen_) markExplained(c, true);
    for (const bool low : {false, true}) {
      const double bar = low ? settings_.object_min_support : settings_.min_support;
      std::size_t best = SIZE_MAX;
      Fit best_fit;
      best_fit.gain = -1e9;
      forEachNearIn(low ? low_grid_ : grid_, row, column, steps, [&](std::size_t n) {
        const Candidate& there = candidates_[n];
        const double dx = there.x_m - at.x(), dy = there.y_m - at.y();
        if (dx * dx + dy * dy > reach2 || occupiedWithin(there.near) == 0 ||
            anyFoundWithin(there.x_m, there.y_m, separationFor(low))) {
          return;
        }
        const Fit f = fit(n);
        if (f.cameras == 0 || f.support < bar || f.own < settings_.hold_own_factor * bar) return;
        if (f.gain > best_fit.gain) {
          best_fit = f;
          best = n;
        }
      });
      if (best == SIZE_MAX) continue;
      const Candidate& held = candidates_[best];
      detections_.push_back({held.x_m, held.y_m, footprintArea(held), best_fit.support,
                             low ? settings_.object_height_m : settings_.box_height_m, true});
      chosen_.push_back(best);
      was_expected_.push_back(1);
      break;
    }
  }
}

}  // namespace occmap
