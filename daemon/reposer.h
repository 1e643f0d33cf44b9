#pragma once
// A knocked camera's re-pose (core/repose.h) built off its capture thread: its carve table takes as
// long as at start-up (seconds for column tables of large maps) and turning it around for the
// kernel tens of milliseconds, and a capture thread that stopped reading for that long would drop
// frames or be taken for a camera that went down. One job at a time, on a thread
// of its own that lives for that job; the capture thread starts it and collects the result.

#include <atomic>
#include <optional>
#include <string>
#include <thread>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/fusion_kernel.h"
#include "core/image.h"
#include "core/map_geometry.h"
#include "core/repose.h"

namespace occmap {

class Reposer {
 public:
  struct Result {
    ReposedCamera camera;
    FusionKernel::Replacement table;  // camera.table turned around for the kernel
  };

  Reposer() = default;
  ~Reposer() { wait(); }
  Reposer(const Reposer&) = delete;
  Reposer& operator=(const Reposer&) = delete;

  // Capture thread: whether a job was started and not yet taken.
  bool busy() const { return thread_.joinable(); }
  // Capture thread, when not busy: starts re-posing `camera` by `turn` from copies of what it
  // differenced against and voted with.
  void start(Camera camera, const Eigen::Vector3d& turn, Image background, Image floor_mask,
             const MapGeometry& map, double column_height_m);
  // Capture thread, while busy: the re-posed camera once built; or nothing, with `error` set when
  // the job failed (left empty while it runs).
  std::optional<Result> take(std::string& error);
  // Waits for a job under way (the pipeline's stop).
  void wait() {
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::thread thread_;
  std::atomic<bool> done_{false};  // release by the job, acquire by take()
  std::optional<Result> result_;
  std::string error_;
};

}  // namespace occmap
