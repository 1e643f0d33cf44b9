#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "capture/frame_source.h"
#include "capture/sim/renderer.h"

namespace occmap {

// A simulated camera knocked during the scene (sim::Knock): from `at_s` on, frames show what
// `camera` sees, while the calibration the rig uses is still the old one.
struct SimKnock {
  double at_s = 0;
  Camera camera;
};

// sim://<scene>/<camera>: what a simulated camera sees. Frame n shows the scene at t = n / fps; an
// off-line source ends with the scene's scripted motion.
class SimSource final : public FrameSource {
 public:
  SimSource(std::shared_ptr<const sim::Scene> scene, Camera camera, int camera_index, double fps,
            std::optional<SimKnock> knock = std::nullopt);

  int width() const override { return renderer_.camera().streamWidth(); }
  int height() const override { return renderer_.camera().streamHeight(); }
  std::uint64_t frameCount() const override { return frame_count_; }
  Status read(Frame& frame) override;
  // Starts the scripted motion over; frame numbers (and the noise they seed) keep counting.
  bool rewind() override {
    first_of_loop_ = next_;
    started();
    return true;
  }

  const sim::Renderer& renderer() const { return renderer_; }
  const sim::Scene& scene() const { return *scene_; }
  double fps() const { return fps_; }
  // The scene time of the frame read last.
  double lastTime() const { return last_time_; }

 private:
  std::shared_ptr<const sim::Scene> scene_;
  sim::Renderer renderer_;
  std::optional<sim::Renderer> knocked_;  // the view after the knock, if any
  double knock_at_s_ = 0;
  double fps_;
  std::uint64_t frame_count_;
  std::uint64_t next_ = 0;
  std::uint64_t first_of_loop_ = 0;
  double last_time_ = 0;
  Image current_;
  std::vector<sim::SceneObject> objects_;  // reused frame to frame
  std::vector<float> depth_;
  std::vector<sim::LightPatch> patches_;  // the scene's light on the floor, reused frame to frame
  Image object_pixels_;                   // where objects are seen, for the patches' light
};

}  // namespace occmap
