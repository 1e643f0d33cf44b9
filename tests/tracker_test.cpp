// People followed on the floor (core/tracker.h) and the scores of tracks (core/track_score.h).
#include "core/tracker.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/track_score.h"

namespace occmap {
namespace {

struct Walker {
  std::int64_t id;
  double x0, y0, vx, vy;
  double hidden_from_s = 1e9, hidden_until_s = -1;  // no detection in between
  FloorPoint at(double t) const { return {x0 + vx * t, y0 + vy * t}; }
  bool hidden(double t) const { return t >= hidden_from_s && t < hidden_until_s; }
};

struct Followed {
  TrackScore score;
  std::vector<std::vector<Track>> tracks;  // per frame
};

// 10 maps a second for `seconds`, detections with 5 cm of noise, the tracker's output scored.
Followed follow(const std::vector<Walker>& walkers, double seconds, Tracker& tracker,
                std::vector<Detection> extra = {}) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0.0, 0.05);
  TrackScorer scorer(0.5);
  Followed run;
  for (int frame = 0; frame <= static_cast<int>(seconds * 10); ++frame) {
    const double t = frame / 10.0;
    std::vector<Detection> detections;
    std::vector<FloorPoint> truth;
    std::vector<std::int64_t> truth_ids;
    for (const Walker& w : walkers) {
      const FloorPoint p = w.at(t);
      truth.push_back(p);
      truth_ids.push_back(w.id);
      if (!w.hidden(t)) detections.push_back({p.x_m + noise(rng), p.y_m + noise(rng), 0.2, 0.5});
    }
    if (frame == 20) detections.insert(detections.end(), extra.begin(), extra.end());
    const std::vector<Track>& tracks = tracker.update(detections, t);
    run.tracks.push_back(tracks);
    std::vector<FloorPoint> points;
    std::vector<std::int64_t> ids;
    for (const Track& track : tracks) {
      points.push_back({track.x_m, track.y_m});
      ids.push_back(track.id);
    }
    scorer.addFrame(truth, truth_ids, points, ids);
  }
  run.score = scorer.score();
  return run;
}

TEST(Tracker, TwoPeopleCrossingWhileOneIsHiddenKeepTheirIdentities) {
  // Walking toward each other at 1 m/s, 0.6 m apart sideways; the first unseen for 1.5 s around
  // the crossing (behind the other, as cameras see it).
  const std::vector<Walker> walkers = {{1, 0.0, 0.0, 1.0, 0.0, 3.5, 5.0}, {2, 8.0, 0.6, -1.0, 0.0}};
  Tracker tracker;
  const Followed run = follow(walkers, 8.0, tracker);
  EXPECT_EQ(run.score.switches, 0u);
  // Misses: the first maps before each track is confirmed, and the hidden one while unseen for
  // more than a map (kept, not reported): 18 of 162 points.
  EXPECT_GE(run.score.mota(), 0.85) << "pairs " << run.score.pairs << " of " << run.score.truth;
  EXPECT_GE(run.score.idf1(), 0.9);
  // The one followed before the crossing is the one followed after it.
  const Track* before = nullptr;
  for (const Track& t : run.tracks[30]) {
    if (std::abs(t.y_m) < 0.3) before = &t;
  }
  ASSERT_NE(before, nullptr);
  bool same_after = false;
  for (const Track& t : run.tracks[70]) same_after |= t.id == before->id && std::abs(t.y_m) < 0.3;
  EXPECT_TRUE(same_after) << "the hidden walker lost their identity";
  // Its velocity, from positions alone. At 10 maps a second, with detections 5 cm off, a steady
  // walker's velocity from the filter has a standard deviation of 0.088 m/s on each axis (the
  // filter's own gain with TrackerSettings' 0.10 m noise; 0.065 m/s with the 0.15 m before): 0.25
  // m/s is about 3 of them, and still tells a walker's speed and heading from any other.
  ASSERT_EQ(run.tracks[80].size(), 2u) << "both walkers are followed at 8 s";
  for (const Track& t : run.tracks[80]) {
    const double expected = std::abs(t.y_m) < 0.3 ? 1.0 : -1.0;
    EXPECT_NEAR(t.vx_m_s, expected, 0.25);
    EXPECT_NEAR(t.vy_m_s, 0.0, 0.25);
  }
}

TEST(Tracker, HiddenLongerThanTwoSecondsIsSomeoneNew) {
  const std::vector<Walker> walkers = {{1, 0.0, 0.0, 0.5, 0.0, 2.0, 4.5}};
  Tracker tracker;
  const Followed run = follow(walkers, 6.0, tracker);
  EXPECT_FALSE(run.tracks[19].empty());
  EXPECT_TRUE(run.tracks[44].empty()) << "ended 2 s after its last detection";
  ASSERT_FALSE(run.tracks[60].empty());
  EXPECT_NE(run.tracks[60][0].id, run.tracks[19][0].id);
}

TEST(Tracker, OneStrayDetectionIsNoTrack) {
  Tracker tracker;
  const Followed run = follow({{1, 0.0, 0.0, 0.0, 0.0}}, 4.0, tracker, {{3.0, 3.0, 0.2, 0.5}});
  for (const std::vector<Track>& tracks : run.tracks) EXPECT_LE(tracks.size(), 1u);
  EXPECT_EQ(run.score.tracks, run.score.pairs) << "no false positive";
  EXPECT_THROW(tracker.update({}, 1.0), std::invalid_argument) << "time went back";
}

// A ghost found beside someone for a few maps starts a tentative track; when the person's
// detection then lies nearer the ghost's track than the person's own prediction, it still goes to
// the person's confirmed track, which keeps its identity and its place.
TEST(Tracker, AConfirmedTrackKeepsItsPersonFromATentativeOneNearer) {
  Tracker tracker;
  const double dt = 1.0 / 30;
  double t = 0.0;
  // A person standing at (1, 1) for a second: confirmed.
  std::vector<Track> tracks;
  for (int i = 0; i < 30; ++i, t += dt)
    tracks = tracker.update(std::vector<Detection>{{1.0, 1.0}}, t);
  ASSERT_EQ(tracks.size(), 1u);
  const std::uint32_t id = tracks[0].id;
  // Then hidden for half a second, while a ghost appears 0.8 m away (beyond the 0.75 m gate) for
  // two maps: a tentative track of its own.
  for (int i = 0; i < 13; ++i, t += dt) tracker.update({}, t);
  for (int i = 0; i < 2; ++i, t += dt) tracker.update(std::vector<Detection>{{1.8, 1.0}}, t);
  // The person is found again at (1.45, 1.0): 0.35 m from the ghost's track, 0.45 m from their
  // own (which stood still). Both within the gate; the confirmed track takes it.
  tracks = tracker.update(std::vector<Detection>{{1.45, 1.0}}, t);
  ASSERT_EQ(tracks.size(), 1u) << "the ghost's track is not confirmed";
  EXPECT_EQ(tracks[0].id, id);
  EXPECT_EQ(tracks[0].unseen_s, 0.0) << "the person's track was given the detection";
  EXPECT_GT(tracks[0].x_m, 1.2) << "corrected towards the detection";
}

// Someone held where a confirmed track expected them (FootprintSettings::hold_hidden) keeps that
// track reported, but is never seen: held detections alone start and confirm no track, and a track
// only held ends lost_after_s after it was last found.
TEST(Tracker, AHeldDetectionKeepsAConfirmedTrackButNeverMakesOne) {
  const double dt = 1.0 / 30;
  Detection held{1.0, 1.0, 0.2, 0.5, 1.75};
  held.held = true;
  Tracker never;
  double t = 0.0;
  for (int i = 0; i < 60; ++i, t += dt) {
    EXPECT_TRUE(never.update(std::vector<Detection>{held}, t).empty());
  }
  Tracker tracker;
  t = 0.0;
  std::vector<Track> tracks;
  for (int i = 0; i < 30; ++i, t += dt) {
    tracks = tracker.update(std::vector<Detection>{{1.0, 1.0, 0.2, 0.5, 1.75}}, t);
  }
  ASSERT_EQ(tracks.size(), 1u);
  const std::uint32_t id = tracks[0].id;
  const double found_s = t - dt;
  // Held on every map from here: reported, unseen since it was found, until 2 s after that.
  for (; t < found_s + 1.9; t += dt) {
    tracks = tracker.update(std::vector<Detection>{held}, t);
    ASSERT_EQ(tracks.size(), 1u) << t;
    EXPECT_EQ(tracks[0].id, id);
    EXPECT_NEAR(tracks[0].unseen_s, t - found_s, 1e-9);
  }
  for (; t < found_s + 2.1; t += dt) tracker.update(std::vector<Detection>{held}, t);
  EXPECT_TRUE(tracker.update(std::vector<Detection>{held}, t).empty()) << "ended";
}

// A confirmed track missing one map is still reported, missing two it is not (reported_missed_maps
// 1), and is reported again, the same track, when found.
TEST(Tracker, AConfirmedTrackIsReportedOneMapWithoutADetection) {
  const double dt = 1.0 / 30;
  Tracker tracker;
  double t = 0.0;
  const std::vector<Detection> there = {{1.0, 1.0, 0.2, 0.5, 1.75}};
  std::vector<Track> tracks;
  for (int i = 0; i < 30; ++i, t += dt) tracks = tracker.update(there, t);
  ASSERT_EQ(tracks.size(), 1u);
  const std::uint32_t id = tracks[0].id;
  EXPECT_EQ(tracker.update({}, t).size(), 1u);
  t += dt;
  EXPECT_TRUE(tracker.update({}, t).empty());
  t += dt;
  tracks = tracker.update(there, t);
  ASSERT_EQ(tracks.size(), 1u);
  EXPECT_EQ(tracks[0].id, id);
}

TEST(TrackScore, CountsASwitchAndPairsIdentitiesOnceForIdf1) {
  TrackScorer scorer(0.5);
  const std::vector<std::int64_t> person = {7};
  const std::vector<FloorPoint> here = {{0, 0}};
  // Frames 1-3 followed by track 1, frames 4-5 by track 2: one switch, 5 pairs.
  for (int f = 0; f < 5; ++f) {
    const std::vector<std::int64_t> track = {f < 3 ? 1 : 2};
    scorer.addFrame(here, person, here, track);
  }
  // Frame 6: nobody followed (a miss); frame 7: a track where nobody is (a false positive).
  scorer.addFrame(here, person, {}, {});
  scorer.addFrame({}, {}, std::vector<FloorPoint>{{5, 5}}, std::vector<std::int64_t>{3});
  const TrackScore s = scorer.score();
  EXPECT_EQ(s.truth, 6u);
  EXPECT_EQ(s.tracks, 6u);
  EXPECT_EQ(s.pairs, 5u);
  EXPECT_EQ(s.switches, 1u);
  EXPECT_NEAR(s.mota(), 1.0 - (1.0 + 1.0 + 1.0) / 6.0, 1e-12);
  // Identity 7 is paired with track 1 (3 frames together, more than track 2's 2): IDTP 3.
  EXPECT_EQ(s.id_pairs, 3u);
  EXPECT_NEAR(s.idf1(), 2.0 * 3.0 / 12.0, 1e-12);
}

// Where the detector should look first on the next map: each confirmed track seen lately, moved
// on at its velocity; not a tentative track, nor one unseen for longer than asked.
TEST(Tracker, ExpectsThePeopleItFollowsWhereTheyWillBe) {
  Tracker tracker;
  std::vector<Eigen::Vector2d> expected;
  tracker.expectedAt(0.0, 0.2, expected);
  EXPECT_TRUE(expected.empty()) << "nothing followed yet";
  // A walker at 1 m/s along x, 10 maps a second, and a stray seen once.
  for (int frame = 0; frame <= 10; ++frame) {
    const double t = frame / 10.0;
    std::vector<Detection> detections = {{1.0 + t, 2.0, 0.2, 0.5, 1.75}};
    if (frame == 10) detections.push_back({4.0, 4.0, 0.2, 0.5, 1.75});
    tracker.update(detections, t);
  }
  tracker.expectedAt(1.1, 0.2, expected);
  ASSERT_EQ(expected.size(), 1u) << "the stray's track is tentative";
  EXPECT_NEAR(expected[0].x(), 2.1, 0.05);
  EXPECT_NEAR(expected[0].y(), 2.0, 0.05);
  // Unseen since t = 1 s: expected until 0.2 s later, then no more.
  tracker.update({}, 1.1);
  expected.clear();
  tracker.expectedAt(1.15, 0.2, expected);
  EXPECT_EQ(expected.size(), 1u);
  expected.clear();
  tracker.expectedAt(1.3, 0.2, expected);
  EXPECT_TRUE(expected.empty());
}

// Found twice (a chair wider than a person's box, found again beside itself): the second track is
// never confirmed, while someone a step away is.
TEST(Tracker, WhatIsFoundTwiceIsOneTrack) {
  Tracker tracker;
  std::vector<Track> tracks;
  for (int frame = 0; frame <= 20; ++frame) {
    const double t = frame / 10.0;
    std::vector<Detection> detections = {{2.0, 2.0, 0.2, 0.5, 1.75}};
    // From 0.5 s on, the same thing again 0.4 m beside it, and a person 0.7 m away.
    if (frame >= 5) {
      detections.push_back({2.4, 2.0, 0.2, 0.5, 1.75});
      detections.push_back({2.0, 2.7, 0.2, 0.5, 1.75});
    }
    const std::vector<Track>& out = tracker.update(detections, t);
    tracks.assign(out.begin(), out.end());
  }
  ASSERT_EQ(tracks.size(), 2u);
  std::sort(tracks.begin(), tracks.end(),
            [](const Track& a, const Track& b) { return a.y_m < b.y_m; });
  EXPECT_NEAR(tracks[0].x_m, 2.0, 0.1);
  EXPECT_NEAR(tracks[1].y_m, 2.7, 0.1);
  // Without the rule, three.
  TrackerSettings lenient;
  lenient.confirm_apart_m = 0;
  Tracker twice(lenient);
  std::size_t most = 0;
  for (int frame = 0; frame <= 20; ++frame) {
    std::vector<Detection> detections = {{2.0, 2.0, 0.2, 0.5, 1.75}};
    if (frame >= 5) detections.push_back({2.4, 2.0, 0.2, 0.5, 1.75});
    most = std::max(most, twice.update(detections, frame / 10.0).size());
  }
  EXPECT_EQ(most, 2u) << "the rule, not the gate";
}

}  // namespace
}  // namespace occmap
