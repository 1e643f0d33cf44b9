// Several camera PCs' people made one list (core/footprint_merge.h): one person seen by two PCs is
// one footprint; people one PC told apart stay apart however near; each cluster takes at most one
// footprint of each input, nearest pairs first.
#include "core/footprint_merge.h"

#include <vector>

#include <gtest/gtest.h>

namespace occmap {
namespace {

Detection at(double x, double y, double score = 0.5, double area = 0.2) {
  return {x, y, area, score, 1.75};
}

const std::vector<Detection>& mergeOf(FootprintMerger& merger,
                                      const std::vector<std::vector<Detection>>& found) {
  static std::vector<std::span<const Detection>> spans;
  spans.assign(found.begin(), found.end());
  return merger.merge(spans);
}

TEST(FootprintMerger, OnePersonSeenByTwoPcsIsOneAtTheScoreWeightedMean) {
  FootprintMerger merger(0.35);
  const auto& merged = mergeOf(merger, {{at(1.0, 2.0, 0.75, 0.2)}, {at(1.2, 2.0, 0.25, 0.3)}});
  ASSERT_EQ(merged.size(), 1u);
  EXPECT_NEAR(merged[0].x_m, 1.05, 1e-12);
  EXPECT_NEAR(merged[0].y_m, 2.0, 1e-12);
  EXPECT_DOUBLE_EQ(merged[0].area_m2, 0.3);
  EXPECT_DOUBLE_EQ(merged[0].score, 0.75);
}

TEST(FootprintMerger, PeopleOnePcToldApartStayApartAndFarOnesAreNotJoined) {
  FootprintMerger merger(0.35);
  // One PC's two people 0.2 m apart; another PC's person 1 m away from both.
  const auto& merged = mergeOf(merger, {{at(0.0, 0.0), at(0.2, 0.0)}, {at(0.1, 1.0)}});
  EXPECT_EQ(merged.size(), 3u);
}

TEST(FootprintMerger, NearestPairsFirstAndOneFootprintPerInputInACluster) {
  FootprintMerger merger(0.5);
  // West sees two people 0.4 m apart; east sees both, a little off: each pairs with its nearest,
  // not both with the first.
  const auto& merged =
      mergeOf(merger, {{at(0.0, 0.0), at(0.4, 0.0)}, {at(0.05, 0.0), at(0.42, 0.0)}});
  ASSERT_EQ(merged.size(), 2u);
  EXPECT_NEAR(merged[0].x_m, 0.025, 1e-12);
  EXPECT_NEAR(merged[1].x_m, 0.41, 1e-12);
  // Three PCs see one person: one footprint.
  EXPECT_EQ(mergeOf(merger, {{at(3, 3)}, {at(3.1, 3)}, {at(3, 3.1)}}).size(), 1u);
  // Nothing found: nothing.
  EXPECT_TRUE(mergeOf(merger, {{}, {}}).empty());
}

TEST(FootprintMerger, AFootprintScoredZeroStillHasItsPlace) {
  FootprintMerger merger;
  const auto& merged = mergeOf(merger, {{at(1.0, 0.0, 0.0)}, {at(1.2, 0.0, 0.0)}});
  ASSERT_EQ(merged.size(), 1u);
  EXPECT_NEAR(merged[0].x_m, 1.1, 1e-12);
}

}  // namespace
}  // namespace occmap
