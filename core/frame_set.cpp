#include "core/frame_set.h"

#include <algorithm>

namespace occmap {

FrameSetAssembler::FrameSetAssembler(std::size_t cameras, FrameSetPolicy policy)
    : policy_(policy), cameras_(cameras) {}

void FrameSetAssembler::start(std::int64_t now) { last_fused_ns_ = now; }

void FrameSetAssembler::frameArrived(std::size_t k, std::int64_t arrival_ns) {
  cameras_[k].arrival_ns = arrival_ns;
  cameras_[k].held = true;
  cameras_[k].fresh = true;
  // The set opens with its first new frame, and waits from that frame's arrival.
  if (set_deadline_ns_ == 0) set_deadline_ns_ = arrival_ns + policy_.max_wait_ns;
}

bool FrameSetAssembler::shouldFuse(std::int64_t now, std::span<const CameraState> states,
                                   bool last_round) const {
  if (now - last_fused_ns_ >= policy_.heartbeat_ns) return true;
  if (set_deadline_ns_ == 0) return false;  // nothing new
  if (last_round || now >= set_deadline_ns_) return true;
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    if (states[k] != CameraState::kDown && !cameras_[k].fresh) return false;
  }
  return true;
}

std::int64_t FrameSetAssembler::nextDeadline() const {
  const std::int64_t heartbeat = last_fused_ns_ + policy_.heartbeat_ns;
  return set_deadline_ns_ != 0 ? std::min(set_deadline_ns_, heartbeat) : heartbeat;
}

bool FrameSetAssembler::uses(std::size_t k, CameraState state, std::int64_t now,
                             std::int64_t recent_ns) const {
  const Camera& camera = cameras_[k];
  return camera.held && state != CameraState::kDown && now - camera.arrival_ns <= recent_ns;
}

void FrameSetAssembler::fused(std::int64_t now) {
  for (Camera& camera : cameras_) camera.fresh = false;
  set_deadline_ns_ = 0;
  last_fused_ns_ = now;
}

}  // namespace occmap
