// The fusion thread's policies, with time passed in by hand (no sleep): when a frame set is fused
// (max_wait_ms, the heartbeat) and when a camera is starting, streaming or down (core/frame_set.h,
// core/camera_health.h).
#include "core/frame_set.h"

#include <array>
#include <cstdint>

#include <gtest/gtest.h>

#include "core/camera_health.h"
#include "core/pacing.h"

namespace occmap {
namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr CameraState kUp = CameraState::kStreaming;
constexpr CameraState kDown = CameraState::kDown;

FrameSetPolicy policy(std::int64_t max_wait_ms, std::int64_t heartbeat_ms = 1000) {
  return {max_wait_ms * kMs, heartbeat_ms * kMs};
}

TEST(FrameSet, ASetOfEveryLiveCameraIsFusedAtOnce) {
  FrameSetAssembler set(3, policy(50));
  set.start(0);
  const std::array states{kUp, kUp, kUp};
  set.frameArrived(0, 10 * kMs);
  set.frameArrived(1, 11 * kMs);
  EXPECT_FALSE(set.shouldFuse(12 * kMs, states, false)) << "camera 2 is live and not in yet";
  set.frameArrived(2, 13 * kMs);
  EXPECT_TRUE(set.shouldFuse(13 * kMs, states, false));
}

TEST(FrameSet, ASlowCameraIsWaitedForAtMostMaxWaitThenFusedWithout) {
  FrameSetAssembler set(2, policy(50));
  set.start(0);
  const std::array states{kUp, kUp};
  set.frameArrived(0, 100 * kMs);
  // The wait is counted from the set's first frame.
  EXPECT_EQ(set.nextDeadline(), 150 * kMs);
  EXPECT_FALSE(set.shouldFuse(100 * kMs, states, false));
  EXPECT_FALSE(set.shouldFuse(149 * kMs, states, false)) << "fused before max_wait_ms ran out";
  EXPECT_TRUE(set.shouldFuse(150 * kMs, states, false)) << "waited longer than max_wait_ms";
  // The slow camera has no frame at all: it is not in the map; the other is.
  EXPECT_TRUE(set.uses(0, kUp, 150 * kMs, 900 * kMs));
  EXPECT_FALSE(set.uses(1, kUp, 150 * kMs, 900 * kMs));
  set.fused(150 * kMs);
  EXPECT_FALSE(set.shouldFuse(151 * kMs, states, false)) << "nothing new since the map";
}

TEST(FrameSet, ALateCameraCountsWithItsPreviousFrameWhileThatIsRecent) {
  FrameSetAssembler set(2, policy(50));
  set.start(0);
  const std::array states{kUp, kUp};
  set.frameArrived(0, 0);
  set.frameArrived(1, 0);
  ASSERT_TRUE(set.shouldFuse(0, states, false));
  set.fused(0);
  set.frameArrived(0, 30 * kMs);
  ASSERT_TRUE(set.shouldFuse(80 * kMs, states, false));
  EXPECT_TRUE(set.uses(1, kUp, 80 * kMs, 900 * kMs)) << "its frame of 80 ms ago is recent";
  EXPECT_FALSE(set.uses(1, kUp, 80 * kMs, 50 * kMs)) << "older than the recent limit";
  EXPECT_FALSE(set.uses(1, kDown, 80 * kMs, 900 * kMs)) << "a down camera's cells are unseen";
}

TEST(FrameSet, DownCamerasAreNotWaitedFor) {
  FrameSetAssembler set(3, policy(50));
  set.start(0);
  set.frameArrived(0, 5 * kMs);
  EXPECT_TRUE(set.shouldFuse(5 * kMs, std::array{kUp, kDown, kDown}, false));
  EXPECT_FALSE(set.shouldFuse(5 * kMs, std::array{kUp, CameraState::kStarting, kDown}, false))
      << "a starting camera is waited for";
}

TEST(FrameSet, WithNoFrameTheHeartbeatStillMakesAMapEverySecond) {
  FrameSetAssembler set(2, policy(50, 1000));
  set.start(0);
  const std::array states{kDown, kDown};
  EXPECT_EQ(set.nextDeadline(), 1000 * kMs);
  EXPECT_FALSE(set.shouldFuse(999 * kMs, states, false));
  EXPECT_TRUE(set.shouldFuse(1000 * kMs, states, false));
  set.fused(1000 * kMs);
  EXPECT_EQ(set.nextDeadline(), 2000 * kMs);
  EXPECT_FALSE(set.shouldFuse(1999 * kMs, states, false));
  EXPECT_TRUE(set.shouldFuse(2000 * kMs, states, false));
  EXPECT_FALSE(set.uses(0, kDown, 2000 * kMs, 900 * kMs));
}

TEST(FrameSet, AtTheStopWhateverIsNewIsFused) {
  FrameSetAssembler set(2, policy(50));
  set.start(0);
  const std::array states{kUp, kUp};
  EXPECT_FALSE(set.shouldFuse(1 * kMs, states, true)) << "nothing new: no extra map at the stop";
  set.frameArrived(0, 2 * kMs);
  EXPECT_TRUE(set.shouldFuse(2 * kMs, states, true));
}

TEST(CameraHealth, StartsStreamsAndGoesDownAfterSilence) {
  CameraHealth health({900 * kMs, 3000 * kMs}, 30);
  health.opened(0);
  EXPECT_EQ(health.state(0), CameraState::kStarting);
  EXPECT_EQ(health.state(3000 * kMs), CameraState::kStarting);
  EXPECT_EQ(health.state(3001 * kMs), kDown) << "no first frame within the start time-out";
  health.frameArrived(3100 * kMs);
  EXPECT_EQ(health.state(3100 * kMs), kUp);
  EXPECT_EQ(health.state(4000 * kMs), kUp);
  EXPECT_FALSE(health.stalled(4000 * kMs));
  EXPECT_EQ(health.state(4001 * kMs), kDown) << "900 ms without a frame";
  EXPECT_TRUE(health.stalled(4001 * kMs)) << "the same silence makes the thread reopen it";
  EXPECT_EQ(health.silenceNs(4001 * kMs), 901 * kMs);
}

TEST(CameraHealth, ASlowCameraGetsThreeFramePeriods) {
  CameraHealth health({900 * kMs, 3000 * kMs}, 2.0);  // 2 fps: 1.5 s
  EXPECT_EQ(health.downAfterNs(), 1500 * kMs);
  health.opened(0);
  health.frameArrived(10 * kMs);
  EXPECT_EQ(health.state(1500 * kMs), kUp);
  EXPECT_EQ(health.state(1511 * kMs), kDown);
}

TEST(CameraHealth, AFlappingCameraIsDownWhileLostAndUpWithItsFirstNewFrame) {
  CameraHealth health({900 * kMs, 3000 * kMs}, 30);
  health.opened(0);
  std::int64_t now = 0;
  for (int flap = 0; flap < 5; ++flap) {
    for (int frame = 0; frame < 10; ++frame) {
      now += 33 * kMs;
      health.frameArrived(now);
      ASSERT_EQ(health.state(now), kUp) << "flap " << flap;
    }
    health.lost();  // the source says the device is gone
    ASSERT_EQ(health.state(now), kDown) << "flap " << flap << ": the source said so, at once";
    ASSERT_TRUE(health.isLost());
    now += 400 * kMs;
    health.opened(now);  // reopened
    ASSERT_FALSE(health.isLost());
    ASSERT_EQ(health.state(now), kDown)
        << "flap " << flap << ": reopened, but no new frame yet vouches for its cells";
    ASSERT_FALSE(health.stalled(now + 2999 * kMs)) << "the first frame after a reopen may take";
    ASSERT_TRUE(health.stalled(now + 3001 * kMs));
  }
  now += 50 * kMs;
  health.frameArrived(now);
  EXPECT_EQ(health.state(now), kUp);
}

TEST(FramePacer, PacesAtTheRateAndStartsAgainFromNowWhenFarBehind) {
  FramePacer pacer(50.0, 0);  // 20 ms
  EXPECT_EQ(pacer.next(0), 0);
  EXPECT_EQ(pacer.next(1 * kMs), 20 * kMs);
  EXPECT_EQ(pacer.next(21 * kMs), 40 * kMs) << "a little late: the rate holds";
  EXPECT_EQ(pacer.next(55 * kMs), 60 * kMs);
  EXPECT_EQ(pacer.next(500 * kMs), 500 * kMs) << "far behind: no burst to catch up";
  EXPECT_EQ(pacer.next(501 * kMs), 520 * kMs);
}

TEST(ReconnectBackoff, WaitsLongerAfterEachFailedTryUpToASecond) {
  ReconnectBackoff backoff;
  backoff.lost(0);
  EXPECT_FALSE(backoff.due(99 * kMs));
  EXPECT_TRUE(backoff.due(100 * kMs));
  std::int64_t now = 100 * kMs;
  std::int64_t waits[6];
  for (std::int64_t& wait : waits) {
    backoff.failed(now);
    wait = backoff.nextTryNs() - now;
    now = backoff.nextTryNs();
  }
  EXPECT_EQ(waits[0], 200 * kMs);
  EXPECT_EQ(waits[1], 400 * kMs);
  EXPECT_EQ(waits[2], 800 * kMs);
  EXPECT_EQ(waits[3], 1000 * kMs);
  EXPECT_EQ(waits[5], 1000 * kMs);
  backoff.lost(now);  // back, then lost again: the short wait first
  EXPECT_EQ(backoff.nextTryNs() - now, 100 * kMs);
}

}  // namespace
}  // namespace occmap
