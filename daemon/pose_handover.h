#pragma once
// A camera's new pose after a knock (core/repose.h), handed from its capture thread to a thread
// that must use it from the camera's first frame of that pose on: the footprints thread's boxes
// (daemon/footprints_stage.h) and the fusion thread's zones (daemon/pipeline.h). Whatever the
// taker needs of the pose is made by the giver, off the taker's path; the taker's every map costs
// one atomic load until something waits, and a lock only then.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

namespace occmap {

template <class Pose>
class PoseHandover {
 public:
  explicit PoseHandover(std::size_t cameras) : slots_(cameras) {}

  // Giver: camera k's pose for its frames of `generation` (the fusion kernel's, of the table made
  // for it); replaces one of camera k's still waiting.
  void give(std::size_t k, std::uint32_t generation, Pose pose) {
    const std::lock_guard<std::mutex> lock(lock_);
    slots_.at(k) = {generation, std::move(pose)};
    waiting_.store(true, std::memory_order_release);
  }

  // Taker: camera k's pose if one waits for frames of `generation`, else none (a pose for a later
  // generation keeps waiting).
  std::optional<Pose> take(std::size_t k, std::uint32_t generation) {
    if (!waiting_.load(std::memory_order_acquire)) return std::nullopt;
    const std::lock_guard<std::mutex> lock(lock_);
    std::optional<Pose> pose;
    Slot& slot = slots_[k];
    if (slot.pose && slot.generation == generation) pose.swap(slot.pose);
    bool any = false;
    for (const Slot& s : slots_) any = any || s.pose.has_value();
    waiting_.store(any, std::memory_order_relaxed);
    return pose;
  }

 private:
  struct Slot {
    std::uint32_t generation = 0;
    std::optional<Pose> pose;
  };
  std::mutex lock_;
  std::vector<Slot> slots_;  // per camera, guarded by lock_
  std::atomic<bool> waiting_{false};
};

}  // namespace occmap
