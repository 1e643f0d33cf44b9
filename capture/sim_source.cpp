#include "capture/sim_source.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "base/clock.h"

namespace occmap {

SimSource::SimSource(std::shared_ptr<const sim::Scene> scene, Camera camera, int camera_index,
                     double fps, std::optional<SimKnock> knock)
    : scene_(std::move(scene)),
      renderer_(*scene_, std::move(camera), camera_index),
      fps_(fps),
      frame_count_(static_cast<std::uint64_t>(std::floor(scene_->durationS() * fps))) {
  if (knock) {
    knocked_.emplace(*scene_, std::move(knock->camera), camera_index);
    knock_at_s_ = knock->at_s;
  }
}

FrameSource::Status SimSource::read(Frame& frame) {
  if (next_ - first_of_loop_ >= frame_count_) return ended();
  last_time_ = static_cast<double>(next_ - first_of_loop_) / fps_;
  scene_->objectsAt(last_time_, objects_);
  if (current_.width() != width() || current_.height() != height())
    current_ = Image(width(), height());
  scene_->lightPatches(last_time_, patches_);
  const sim::Renderer& renderer = knocked_ && last_time_ >= knock_at_s_ ? *knocked_ : renderer_;
  if (patches_.empty()) {
    renderer.render(objects_, next_, current_, depth_);
  } else {
    renderer.render(objects_, next_, current_, depth_, &object_pixels_);
    renderer.light(patches_, object_pixels_, current_);
  }
  // The light as the sensor records it: every grey level scaled, clipped at 255.
  if (const double gain = scene_->lightGain(last_time_); gain != 1.0) {
    std::array<std::uint8_t, 256> lit;
    for (int v = 0; v < 256; ++v) {
      lit[static_cast<std::size_t>(v)] =
          static_cast<std::uint8_t>(std::min(255.0, std::round(v * gain)));
    }
    std::uint8_t* pixel = current_.data();
    for (std::size_t i = 0,
                     n = static_cast<std::size_t>(width()) * static_cast<std::size_t>(height());
         i < n; ++i) {
      pixel[i] = lit[pixel[i]];
    }
  }
  frame.image = current_.view();
  frame.sequence = next_++;
  frame.capture_time_us = hostTimeMicroseconds();
  return delivered();
}

}  // namespace occmap
