// The optimal assignment and the CLEAR MOD scores (core/assignment.h, core/detection_score.h).
#include "core/detection_score.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/assignment.h"

namespace occmap {
namespace {

struct Best {
  std::size_t pairs = 0;
  double cost = 0.0;
};

// Every way of giving each row a column or none, columns used once: the most pairs under the gate,
// then the least cost.
void bruteForce(const std::vector<double>& cost, std::size_t rows, std::size_t columns, double gate,
                std::size_t row, std::vector<char>& used, Best now, Best& best) {
  if (row == rows) {
    if (now.pairs > best.pairs || (now.pairs == best.pairs && now.cost < best.cost - 1e-9)) {
      best = now;
    }
    return;
  }
  bruteForce(cost, rows, columns, gate, row + 1, used, now, best);
  for (std::size_t j = 0; j < columns; ++j) {
    const double c = cost[row * columns + j];
    if (used[j] != 0 || !(c < gate)) continue;
    used[j] = 1;
    bruteForce(cost, rows, columns, gate, row + 1, used, {now.pairs + 1, now.cost + c}, best);
    used[j] = 0;
  }
}

TEST(Assignment, FindsTheMostPairsUnderTheGateAndThenTheLeastCost) {
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<std::size_t> size(0, 6);
  std::uniform_real_distribution<double> value(0.0, 1.0);
  Assignment assignment;
  std::size_t gated_somewhere = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const std::size_t rows = size(rng), columns = size(rng);
    std::vector<double> cost(rows * columns);
    for (double& c : cost) c = value(rng);
    if (trial % 7 == 0 && !cost.empty()) cost[0] = std::numeric_limits<double>::infinity();
    const double gate = trial % 3 == 0 ? 2.0 : 0.4;
    std::vector<char> used(columns, 0);
    Best best{0, std::numeric_limits<double>::infinity()};
    if (rows == 0) best.cost = 0.0;
    bruteForce(cost, rows, columns, gate, 0, used, {0, 0.0}, best);
    const std::vector<int>& pairs = assignment.solve(cost, rows, columns, gate);
    ASSERT_EQ(pairs.size(), rows);
    Best found;
    std::vector<char> taken(columns, 0);
    for (std::size_t i = 0; i < rows; ++i) {
      if (pairs[i] < 0) continue;
      const auto j = static_cast<std::size_t>(pairs[i]);
      ASSERT_LT(j, columns);
      ASSERT_EQ(taken[j], 0) << "column " << j << " paired twice";
      taken[j] = 1;
      ASSERT_LT(cost[i * columns + j], gate) << "a pair past the gate";
      ++found.pairs;
      found.cost += cost[i * columns + j];
    }
    if (found.pairs < std::min(rows, columns)) ++gated_somewhere;
    ASSERT_EQ(found.pairs, best.pairs) << "trial " << trial << ": " << rows << " x " << columns;
    if (best.pairs > 0) {
      ASSERT_NEAR(found.cost, best.cost, 1e-9) << "trial " << trial;
    }
  }
  EXPECT_GT(gated_somewhere, 100u) << "the gate was never what limited the pairs";
}

TEST(Assignment, PrefersTwoPairsToOneCheaperOne) {
  // Row 0 is closest to column 0, but only column 0 is within the gate of row 1: the nearest
  // neighbour pairs one, the assignment two.
  const std::vector<double> cost = {0.1, 0.3,  //
                                    0.2, 0.9};
  Assignment assignment;
  const std::vector<int>& pairs = assignment.solve(cost, 2, 2, 0.5);
  EXPECT_EQ(pairs, (std::vector<int>{1, 0}));
}

TEST(DetectionScore, IsTheClearModMeasureOfAHandWorkedExample) {
  DetectionScorer scorer(0.5);
  // Frame 1: two people; one detection 0.1 m from the first, one 0.3 m from the second, one 2 m
  // from anyone.
  const std::vector<FloorPoint> truth1 = {{0.0, 0.0}, {3.0, 0.0}};
  const std::vector<FloorPoint> found1 = {{0.1, 0.0}, {3.0, 0.3}, {6.0, 0.0}};
  const std::vector<int> pairs = scorer.addFrame(truth1, found1);
  EXPECT_EQ(pairs, (std::vector<int>{0, 1}));
  // Frame 2: one person, nothing found. Frame 3: nobody, one detection.
  scorer.addFrame(std::vector<FloorPoint>{{1.0, 1.0}}, {});
  scorer.addFrame({}, std::vector<FloorPoint>{{1.0, 1.0}});
  const DetectionScore& score = scorer.score();
  EXPECT_EQ(score.frames, 3u);
  EXPECT_EQ(score.people, 3u);
  EXPECT_EQ(score.detections, 4u);
  EXPECT_EQ(score.pairs, 2u);
  EXPECT_EQ(score.misses(), 1u);
  EXPECT_EQ(score.falsePositives(), 2u);
  EXPECT_NEAR(score.moda(), 1.0 - 3.0 / 3.0, 1e-12);
  EXPECT_NEAR(score.modp(), ((1.0 - 0.1 / 0.5) + (1.0 - 0.3 / 0.5)) / 2.0, 1e-12);
  EXPECT_NEAR(score.precision(), 2.0 / 4.0, 1e-12);
  EXPECT_NEAR(score.recall(), 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(score.distance_m, 0.4, 1e-12);
}

TEST(DetectionScore, AtTheGateIsAMiss) {
  DetectionScorer scorer(0.5);
  scorer.addFrame(std::vector<FloorPoint>{{0.0, 0.0}}, std::vector<FloorPoint>{{0.5, 0.0}});
  EXPECT_EQ(scorer.score().pairs, 0u) << "MVDet pairs only distances under the gate";
  EXPECT_THROW(DetectionScorer(0.0), std::invalid_argument);
  EXPECT_THROW(DetectionScorer(std::nan("")), std::invalid_argument);
}

}  // namespace
}  // namespace occmap
