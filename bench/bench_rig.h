#pragma once
// The benchmarks' rigs: the simulated room (capture/sim) watched by the cameras of a configuration,
// and frame sets rendered from it with about 10 % of the pixels changed.

#include <memory>
#include <string>
#include <vector>

#include "capture/sim/renderer.h"
#include "core/carve_table.h"
#include "core/map_geometry.h"

namespace occmap::bench {

// `paper`: the paper's rig (section 4), 4 x 640x480 -> 512 x 512 cells of 2 cm, the room's own
// cameras. `large`: 8 x 1920x1080 -> 1024 x 1024 cells of 1 cm, the room's four corner cameras
// and four more at the middle of the walls, all with a 1/2" sensor at 1920 x 1080.
struct BenchConfig {
  std::string name;
  std::vector<TsaiParameters> cameras;
  int width = 0;
  int height = 0;
  MapGeometry map;
  int extra_people = 0;  // walking among the room's objects, for about 10 % changed pixels
};
BenchConfig paperConfig();
BenchConfig largeConfig();

// One live image per camera.
using FrameSet = std::vector<Image>;

class BenchRig {
 public:
  explicit BenchRig(BenchConfig config);

  const BenchConfig& config() const { return config_; }
  std::size_t cameraCount() const { return renderers_.size(); }
  const sim::Renderer& renderer(std::size_t k) const { return *renderers_[k]; }
  const Image& background(std::size_t k) const { return renderers_[k]->background(); }

  // Every camera's table, built on all cores (the table build's speed is not what is measured).
  std::vector<CarveTable> buildTables(double column_height_m) const;
  // The paper's own table (section 3.1, the pseudo-code's F): each floor pixel's centre to the cell
  // its ray meets on the floor, -1 for none. Per camera, stream pixel order.
  std::vector<std::vector<std::int32_t>> paperTables() const;
  // The frame set at scene time t (s): the room's objects and the configuration's extra people.
  FrameSet render(double t, std::uint64_t frame_number) const;
  // The share of pixels changed at threshold 20 in a frame set.
  double changedShare(const FrameSet& frames) const;

 private:
  BenchConfig config_;
  std::unique_ptr<sim::Scene> scene_;
  std::vector<std::unique_ptr<sim::Renderer>> renderers_;
};

inline constexpr int kThreshold = 20;

}  // namespace occmap::bench
