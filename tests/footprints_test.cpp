// People found on the floor from the cameras' changed pixels (core/footprints.h), on synthetic
// scenes whose truth is known exactly: four cameras in the corners of a 6 x 6 m floor, people as
// upright cylinders, each camera's changed pixels those whose ray meets one. The map is all
// occupied, so the map's prior helps nothing: what is found is found from the images alone.
#include "core/footprints.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/detection_score.h"
#include "core/explained_pieces.h"
#include "core/fusion_kernel.h"
#include "corner_cameras.h"

namespace occmap {
namespace {

constexpr double kRadius = 0.2;   // a person's, on the floor
constexpr double kHeight = 1.75;  // as POM's box
constexpr int kWidth = 320, kHeight_px = 240;

struct Room {
  MapGeometry map = testing::cornerRoomMap();
  std::vector<Camera> cameras = testing::cornerRoomCameras(kWidth, kHeight_px);
};

// Camera k's changed pixels: those whose ray passes through a person's cylinder (kRadius,
// kHeight) or another's, wider and lower.
std::vector<std::uint8_t> render(const Camera& camera, const std::vector<FloorPoint>& people,
                                 std::vector<testing::Cylinder> others = {}) {
  for (const FloorPoint& person : people) {
    others.push_back({person.x_m, person.y_m, kRadius, kHeight});
  }
  return testing::changedWhereCylinders(camera, others, kWidth, kHeight_px);
}

std::vector<FloorPoint> randomPeople(std::mt19937_64& rng, int count) {
  std::uniform_real_distribution<double> place(0.8, 5.2);
  std::vector<FloorPoint> people;
  while (static_cast<int>(people.size()) < count) {
    const FloorPoint p{place(rng), place(rng)};
    bool apart = true;
    for (const FloorPoint& q : people)
      apart = apart && std::hypot(p.x_m - q.x_m, p.y_m - q.y_m) > 0.6;
    if (apart) people.push_back(p);
  }
  return people;
}

const std::vector<Detection>& detect(FootprintDetector& detector, const Room& room,
                                     const std::vector<FloorPoint>& people,
                                     std::vector<std::vector<std::uint8_t>>& masks,
                                     std::size_t left_out = 99,
                                     std::span<const Eigen::Vector2d> expected = {}) {
  masks.clear();
  std::vector<const std::uint8_t*> changed;
  for (const Camera& camera : room.cameras) masks.push_back(render(camera, people));
  for (std::size_t k = 0; k < masks.size(); ++k) {
    changed.push_back(k == left_out ? nullptr : masks[k].data());
  }
  const std::vector<CellState> cells(room.map.cellCount(), CellState::kOccupied);
  return detector.detect(changed, cells, expected);
}

std::vector<FloorPoint> points(const std::vector<Detection>& detections) {
  std::vector<FloorPoint> out;
  for (const Detection& d : detections) out.push_back({d.x_m, d.y_m});
  return out;
}

TEST(Footprints, FindsEveryoneInRandomCrowdsAndNoGhosts) {
  const Room room;
  FootprintDetector detector(room.map, room.cameras);
  std::mt19937_64 rng(3);
  DetectionScorer scorer(0.3);
  std::vector<std::vector<std::uint8_t>> masks;
  for (int scene = 0; scene < 30; ++scene) {
    const std::vector<FloorPoint> people = randomPeople(rng, 1 + scene % 8);
    scorer.addFrame(people, points(detect(detector, room, people, masks)));
  }
  const DetectionScore& s = scorer.score();
  std::printf("%zu people: MODA %.3f, precision %.3f, recall %.3f, mean distance %.3f m\n",
              s.people, s.moda(), s.precision(), s.recall(),
              s.distance_m / static_cast<double>(std::max<std::size_t>(1, s.pairs)));
  // Measured 2026-12-07 with strips: MODA 1.000, precision 1.000, recall 1.000 (with rectangles,
  // 2026-12-06: 0.992, 1.000, 0.992; 0.930, 0.969, 0.961 before people settled beside each other).
  EXPECT_GE(s.moda(), 0.97) << "misses " << s.misses() << ", false positives "
                            << s.falsePositives();
  EXPECT_GE(s.precision(), 0.98);
  EXPECT_GE(s.recall(), 0.97);
  EXPECT_GE(s.modp(), 0.5) << "a mean distance of " << s.distance_m / static_cast<double>(s.pairs)
                           << " m";
}

// Where a tracker expects the people it follows, they are explained first: in crowds too dense
// for the greedy alone (12 to 16 people on 6 x 6 m, seen from 2.5 m up), the same detector finds
// more of them when told where they were a moment ago (the truth 0.1 m off, as a prediction is).
TEST(Footprints, PeopleExpectedWhereTheyStandAreFoundFirst) {
  const Room room;
  FootprintDetector detector(room.map, room.cameras);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> off(0.0, 0.1 / std::sqrt(2.0));
  DetectionScorer alone(0.3), told(0.3);
  std::vector<std::vector<std::uint8_t>> masks;
  std::vector<Eigen::Vector2d> expected;
  for (int scene = 0; scene < 12; ++scene) {
    const std::vector<FloorPoint> people = randomPeople(rng, 12 + scene % 5);
    alone.addFrame(people, points(detect(detector, room, people, masks)));
    expected.clear();
    for (const FloorPoint& p : people) expected.emplace_back(p.x_m + off(rng), p.y_m + off(rng));
    told.addFrame(people, points(detect(detector, room, people, masks, 99, expected)));
  }
  const DetectionScore& a = alone.score();
  const DetectionScore& t = told.score();
  std::printf(
      "%zu people: alone MODA %.3f (misses %zu, ghosts %zu); expected MODA %.3f (%zu, %zu)\n",
      a.people, a.moda(), a.misses(), a.falsePositives(), t.moda(), t.misses(), t.falsePositives());
  EXPECT_GT(t.moda(), a.moda() + 0.02);
  EXPECT_LE(t.falsePositives(), a.falsePositives());
}

// A board leans in the image: the rectangle bounding it holds pixels of the people beside it,
// which then count as explained by it (docs/detection.md, step 2). Strips that follow the board
// find more of a dense crowd (12 to 16 people on 6 x 6 m, seen from 2.5 m up) than rectangles.
TEST(Footprints, StripsThatFollowTheBoardFindMoreOfADenseCrowd) {
  const Room room;
  FootprintSettings rectangles;
  rectangles.box_strips = 1;
  FootprintDetector strips(room.map, room.cameras);  // the default: 3 strips
  FootprintDetector rectangle(room.map, room.cameras, rectangles);
  std::mt19937_64 rng(11);
  DetectionScorer with_strips(0.3), with_rectangles(0.3);
  std::vector<std::vector<std::uint8_t>> masks;
  for (int scene = 0; scene < 12; ++scene) {
    const std::vector<FloorPoint> people = randomPeople(rng, 12 + scene % 5);
    with_strips.addFrame(people, points(detect(strips, room, people, masks)));
    with_rectangles.addFrame(people, points(detect(rectangle, room, people, masks)));
  }
  const DetectionScore& s = with_strips.score();
  const DetectionScore& r = with_rectangles.score();
  std::printf(
      "%zu people: strips MODA %.3f (misses %zu, ghosts %zu); rectangles MODA %.3f "
      "(%zu, %zu)\n",
      s.people, s.moda(), s.misses(), s.falsePositives(), r.moda(), r.misses(), r.falsePositives());
  EXPECT_GT(s.moda(), r.moda() + 0.03);
  EXPECT_LE(s.falsePositives(), r.falsePositives() + 2);
}

// Something wider than a person's box (a round table 0.7 m across, 0.9 m high, as wide as a chair
// seen across its diagonal) fills a box on either side of its centre; one detection explains it
// about as well as two, so it is one.
TEST(Footprints, WhatIsWiderThanABoxIsFoundOnce) {
  const Room room;
  FootprintDetector detector(room.map, room.cameras);
  std::vector<const std::uint8_t*> changed;
  const std::vector<CellState> cells(room.map.cellCount(), CellState::kOccupied);
  for (const FloorPoint at : {FloorPoint{3.0, 3.0}, FloorPoint{2.2, 3.7}, FloorPoint{3.9, 2.4}}) {
    std::vector<std::vector<std::uint8_t>> masks;
    changed.clear();
    for (const Camera& camera : room.cameras)
      masks.push_back(render(camera, {}, {{at.x_m, at.y_m, 0.35, 0.9}}));
    for (const auto& mask : masks) changed.push_back(mask.data());
    const std::vector<Detection>& found = detector.detect(changed, cells);
    ASSERT_EQ(found.size(), 1u) << "at (" << at.x_m << ", " << at.y_m << ")";
    EXPECT_LT(std::hypot(found[0].x_m - at.x_m, found[0].y_m - at.y_m), 0.25);
  }
}

// Two people shoulder to shoulder fill the images as one thing 0.7 m across does, which one
// detection explains about as well as two (step 10). Where a tracker follows two people there,
// more than a box's width apart, they stay two; where it follows one, one.
TEST(Footprints, TwoFollowedSideBySideStayTwo) {
  const Room room;
  FootprintDetector detector(room.map, room.cameras);
  std::vector<const std::uint8_t*> changed;
  const std::vector<CellState> cells(room.map.cellCount(), CellState::kOccupied);
  for (const FloorPoint at : {FloorPoint{3.0, 3.0}, FloorPoint{2.2, 3.7}}) {
    std::vector<std::vector<std::uint8_t>> masks;
    changed.clear();
    for (const Camera& camera : room.cameras)
      masks.push_back(render(camera, {}, {{at.x_m, at.y_m, 0.35, 0.9}}));
    for (const auto& mask : masks) changed.push_back(mask.data());
    for (const double angle : {0.0, 1.6}) {
      const Eigen::Vector2d across(0.3 * std::cos(angle), 0.3 * std::sin(angle));
      const Eigen::Vector2d centre(at.x_m, at.y_m);
      const std::vector<Eigen::Vector2d> two = {centre - across, centre + across};
      EXPECT_EQ(detector.detect(changed, cells, two).size(), 2u)
          << "at (" << at.x_m << ", " << at.y_m << "), across at " << angle;
      const std::vector<Eigen::Vector2d> one = {centre + across};
      EXPECT_EQ(detector.detect(changed, cells, one).size(), 1u);
    }
    EXPECT_EQ(detector.detect(changed, cells).size(), 1u);
  }
}

// An expectation is an order, not evidence: expected where no one stands, no one is found.
TEST(Footprints, NoOneIsFoundWhereOnlyATrackerExpectsThem) {
  const Room room;
  FootprintDetector detector(room.map, room.cameras);
  const std::vector<FloorPoint> one = {{3.0, 3.0}};
  std::vector<std::vector<std::uint8_t>> masks;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Eigen::Vector2d> expected = {{1.5, 1.5},  {4.5, 2.0},  {2.0, 4.5},
                                                 {3.0, 3.05}, {-1e300, 7}, {nan, 2.0}};
  const std::vector<Detection>& found = detect(detector, room, one, masks, 99, expected);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_LT(std::hypot(found[0].x_m - 3.0, found[0].y_m - 3.0), 0.15);
  EXPECT_TRUE(detect(detector, room, {}, masks, 99, expected).empty());
}

// Someone followed and hidden behind others from every camera but one is held where the tracker
// expects them (hold_hidden): one view is enough for a person known to be there, never for a place
// where that view shows the floor, and never for someone nobody expects.
TEST(Footprints, SomeoneFollowedAndHiddenFromAllButOneCameraIsHeld) {
  const Room room;
  // In the middle, with someone 2 m tall 0.7 m in front of them as cameras 0 and 2 see them
  // (cameras 3 m up see the head of someone as tall over the one in front), camera 3 without a
  // frame: camera 1 alone sees them.
  const FloorPoint hidden{3.0, 3.0};
  const std::vector<FloorPoint> tall = {{2.5, 2.5}, {3.5, 3.5}};
  std::vector<testing::Cylinder> in_front;
  for (const FloorPoint& p : tall) in_front.push_back({p.x_m, p.y_m, kRadius, 2.0});
  std::vector<Eigen::Vector2d> expected = {{hidden.x_m, hidden.y_m}};
  for (const FloorPoint& p : tall) expected.emplace_back(p.x_m, p.y_m);
  const std::vector<CellState> cells(room.map.cellCount(), CellState::kOccupied);
  std::vector<std::vector<std::uint8_t>> masks;
  const auto find = [&](FootprintDetector& detector, bool there,
                        std::span<const Eigen::Vector2d> expecting) {
    masks.clear();
    std::vector<const std::uint8_t*> changed;
    for (const Camera& camera : room.cameras) {
      masks.push_back(render(
          camera, there ? std::vector<FloorPoint>{hidden} : std::vector<FloorPoint>{}, in_front));
      changed.push_back(masks.size() == 4 ? nullptr : masks.back().data());
    }
    return detector.detect(changed, cells, expecting);
  };
  const auto near = [](const std::vector<Detection>& found, const FloorPoint& p) {
    return std::count_if(found.begin(), found.end(), [&](const Detection& d) {
      return std::hypot(d.x_m - p.x_m, d.y_m - p.y_m) < 0.2;
    });
  };
  // Their one view adds too little to what the others explain for a bar of new evidence above the
  // default (0.1): their box there is 0.78 changed, the three cameras' mean 0.26.
  FootprintSettings strict;
  strict.min_fresh = 0.3;
  strict.hold_hidden = false;
  FootprintDetector plain(room.map, room.cameras, strict);
  const std::vector<Detection>& unheld = find(plain, true, expected);
  EXPECT_EQ(unheld.size(), 2u);
  EXPECT_EQ(near(unheld, hidden), 0) << "not found by the evidence alone";
  FootprintSettings holding = strict;
  holding.hold_hidden = true;
  FootprintDetector detector(room.map, room.cameras, holding);
  const std::vector<Detection>& found = find(detector, true, expected);
  ASSERT_EQ(found.size(), 3u);
  for (const Detection& d : found) {
    EXPECT_EQ(d.held, std::hypot(d.x_m - hidden.x_m, d.y_m - hidden.y_m) < 0.2)
        << d.x_m << ", " << d.y_m;
  }
  EXPECT_EQ(near(found, hidden), 1);
  // Nobody expects them: not held.
  EXPECT_EQ(near(find(detector, true, {}), hidden), 0);
  // Expected, but gone: the camera that saw them sees the floor there.
  const std::vector<Detection>& left = find(detector, false, expected);
  EXPECT_EQ(left.size(), 2u);
  EXPECT_EQ(near(left, hidden), 0);
}

TEST(Footprints, NeedsTwoCamerasToTellAPersonFromTheFloorBehind) {
  const Room room;
  FootprintDetector detector(room.map, room.cameras);
  const std::vector<FloorPoint> one = {{3.0, 3.0}};
  std::vector<std::vector<std::uint8_t>> masks;
  // With every camera: found, and its box holds a person in each of them.
  const std::vector<Detection>& found = detect(detector, room, one, masks);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_LT(std::hypot(found[0].x_m - 3.0, found[0].y_m - 3.0), 0.15);
  EXPECT_GT(found[0].score, 0.4);
  EXPECT_GT(found[0].area_m2, 0.2) << "the map is all occupied: the whole box's footprint";
  // A camera without a frame says nothing; the other three still find the person.
  EXPECT_EQ(detect(detector, room, one, masks, /*left_out=*/2).size(), 1u);
  // Two cameras alone find them: a person fills their box well past the bar where two views are
  // all there is (two_view_min_own), which a higher bar shows is what is judged.
  const std::span<const Camera> two(room.cameras.data(), 2);
  FootprintDetector pair(room.map, two);
  const std::vector<std::uint8_t> first = render(room.cameras[0], one);
  const std::vector<std::uint8_t> second = render(room.cameras[1], one);
  const std::uint8_t* both[] = {first.data(), second.data()};
  const std::vector<CellState> all_occupied(room.map.cellCount(), CellState::kOccupied);
  ASSERT_EQ(pair.detect(both, all_occupied).size(), 1u);
  FootprintSettings strict;
  strict.two_view_min_own = 0.99;
  FootprintDetector strict_pair(room.map, two, strict);
  EXPECT_TRUE(strict_pair.detect(both, all_occupied).empty());
  // One camera alone cannot place anyone.
  FootprintDetector single(room.map, std::span<const Camera>(room.cameras.data(), 1));
  const std::vector<std::uint8_t> mask = render(room.cameras[0], one);
  const std::uint8_t* changed[] = {mask.data()};
  const std::vector<CellState> cells(room.map.cellCount(), CellState::kOccupied);
  EXPECT_TRUE(single.detect(changed, cells).empty());
  FootprintSettings lenient;
  lenient.min_cameras = 1;
  FootprintDetector lenient_single(room.map, std::span<const Camera>(room.cameras.data(), 1),
                                   lenient);
  EXPECT_FALSE(lenient_single.detect(changed, cells).empty()) << "the rule, not the geometry";
}

// A camera knocked on its mount and re-posed (core/repose.h) gets boxes for its new pose: the same
// detections as a detector built for the knocked rig, while the boxes of its old pose miss the
// people it now sees elsewhere in its image.
TEST(Footprints, ACameraReposedAfterAKnockGetsItsNewBoxes) {
  const Room room;
  std::vector<Camera> knocked = room.cameras;
  knocked[0] = room.cameras[0].turned({0.0, 0.05, 0.03});  // some 3.3 degrees
  FootprintDetector old_boxes(room.map, room.cameras);
  FootprintDetector replaced(room.map, room.cameras);
  replaced.replaceCamera(0, knocked[0]);
  FootprintDetector built(room.map, knocked);
  std::mt19937_64 rng(11);
  DetectionScorer with_old(0.3), with_new(0.3);
  const std::vector<CellState> cells(room.map.cellCount(), CellState::kOccupied);
  for (int scene = 0; scene < 12; ++scene) {
    const std::vector<FloorPoint> people = randomPeople(rng, 1 + scene % 6);
    std::vector<std::vector<std::uint8_t>> masks;
    std::vector<const std::uint8_t*> changed;
    for (const Camera& camera : knocked) masks.push_back(render(camera, people));
    for (const std::vector<std::uint8_t>& mask : masks) changed.push_back(mask.data());
    with_old.addFrame(people, points(old_boxes.detect(changed, cells)));
    const std::vector<FloorPoint> found = points(replaced.detect(changed, cells));
    with_new.addFrame(people, found);
    const std::vector<FloorPoint> expected = points(built.detect(changed, cells));
    ASSERT_EQ(found.size(), expected.size()) << "scene " << scene;
    for (std::size_t i = 0; i < found.size(); ++i) {
      EXPECT_EQ(found[i].x_m, expected[i].x_m) << "scene " << scene;
      EXPECT_EQ(found[i].y_m, expected[i].y_m) << "scene " << scene;
    }
  }
  std::printf("knocked camera: MODA %.3f with its old boxes, %.3f with its new ones\n",
              with_old.score().moda(), with_new.score().moda());
  EXPECT_GE(with_new.score().moda(), 0.97);
  // Measured 2026-12-07: 0.929 against 1.000 (the other three cameras find most people still).
  EXPECT_LT(with_old.score().moda(), with_new.score().moda());
  EXPECT_THROW(replaced.replaceCamera(4, knocked[0]), std::invalid_argument);
}

TEST(Footprints, TheMapSaysWhereNoOneCanStand) {
  const Room room;
  FootprintDetector detector(room.map, room.cameras);
  const std::vector<FloorPoint> one = {{3.0, 3.0}};
  std::vector<const std::uint8_t*> changed;
  std::vector<std::vector<std::uint8_t>> masks;
  for (const Camera& camera : room.cameras) masks.push_back(render(camera, one));
  for (const auto& mask : masks) changed.push_back(mask.data());
  // Everything free but a cell 1 m away: no one is found where the map says no one stands.
  std::vector<CellState> cells(room.map.cellCount(), CellState::kFree);
  cells[static_cast<std::size_t>(*room.map.cellAt(4.0, 3.0))] = CellState::kOccupied;
  EXPECT_TRUE(detector.detect(changed, cells).empty());
  // A cell 0.4 m away: what is found is within a quarter of the box (and a step) of that cell.
  cells[static_cast<std::size_t>(*room.map.cellAt(4.0, 3.0))] = CellState::kFree;
  cells[static_cast<std::size_t>(*room.map.cellAt(3.4, 3.0))] = CellState::kOccupied;
  for (const Detection& d : detector.detect(changed, cells)) {
    EXPECT_LE(std::hypot(d.x_m - 3.4, d.y_m - 3.0), 0.125 + 0.1 + 0.05) << d.x_m << ", " << d.y_m;
  }
  cells[static_cast<std::size_t>(*room.map.cellAt(3.4, 3.0))] = CellState::kFree;
  // Its own cell occupied: found.
  cells[static_cast<std::size_t>(*room.map.cellAt(3.02, 3.02))] = CellState::kOccupied;
  EXPECT_EQ(detector.detect(changed, cells).size(), 1u);
  EXPECT_THROW(detector.detect(changed, std::vector<CellState>(3)), std::invalid_argument);
  changed.pop_back();
  EXPECT_THROW(detector.detect(changed, cells), std::invalid_argument);
}

}  // namespace
}  // namespace occmap

namespace occmap {
namespace {

// The explained pieces (core/explained_pieces.h) against a plain grid of explained blocks: random
// boxes of every size, across one band or many, and for each query every block of the union that it
// holds is visited exactly once, whichever bands the pieces and the query span.
TEST(ExplainedPieces, EachExplainedBlockIsCountedOnceWhateverTheBands) {
  constexpr int kAcross = 100, kDown = 60;
  std::mt19937 random(7);
  const auto box = [&](int widest) {
    std::uniform_int_distribution<int> width(1, widest), height(1, 30);
    const int w = width(random), h = height(random);
    const int u0 = std::uniform_int_distribution<int>(0, kAcross - w)(random);
    const int v0 = std::uniform_int_distribution<int>(0, kDown - h)(random);
    return BlockBox{static_cast<std::uint16_t>(u0), static_cast<std::uint16_t>(v0),
                    static_cast<std::uint16_t>(u0 + w), static_cast<std::uint16_t>(v0 + h), 0.0f};
  };
  for (const int shift : {0, 2, 4, 7}) {
    ExplainedPieces pieces;
    pieces.reset(kAcross, shift, 4);  // little room: the bands grow
    for (int trial = 0; trial < 20; ++trial) {
      pieces.clear();
      std::vector<std::uint8_t> explained(kAcross * kDown, 0);
      const int boxes = std::uniform_int_distribution<int>(0, 12)(random);
      for (int b = 0; b < boxes; ++b) {
        const BlockBox added = box(40);
        pieces.add(added);
        for (int v = added.v0; v < added.v1; ++v) {
          for (int u = added.u0; u < added.u1; ++u) explained[v * kAcross + u] = 1;
        }
      }
      for (int q = 0; q < 30; ++q) {
        const BlockBox query = box(kAcross);
        int expected = 0;
        for (int v = query.v0; v < query.v1; ++v) {
          for (int u = query.u0; u < query.u1; ++u) expected += explained[v * kAcross + u];
        }
        int counted = 0;
        pieces.forEachMeeting(query, [&](const BlockBox& piece) {
          const int u0 = std::max(piece.u0, query.u0), u1 = std::min(piece.u1, query.u1);
          const int v0 = std::max(piece.v0, query.v0), v1 = std::min(piece.v1, query.v1);
          ASSERT_LT(u0, u1);  // only pieces that meet the query are visited
          ASSERT_LT(v0, v1);
          counted += (u1 - u0) * (v1 - v0);
        });
        ASSERT_EQ(counted, expected) << "bands of " << (1 << shift) << ", trial " << trial;
      }
    }
  }
}

}  // namespace
}  // namespace occmap
