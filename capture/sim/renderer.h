#pragma once

#include <cstdint>
#include <vector>

#include "capture/sim/scene.h"
#include "core/camera.h"
#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap::sim {

// Renders what one camera sees of a scene: one ray through each pixel centre (the stream's pixels,
// through the camera's lens model), the nearest surface's grey level, plus sensor noise. The static
// room is rendered once; a frame composites the moving objects over it, ray-casting only the pixels
// inside each object's projected bounds, which keeps four 640x480 cameras at video rate on one
// core.
class Renderer {
 public:
  // `camera_index` tells this camera's noise apart from the others'.
  Renderer(const Scene& scene, Camera camera, int camera_index);

  const Camera& camera() const { return camera_; }
  const Scene& scene() const { return scene_; }
  // The empty scene without noise: the background image the paper acquires during set-up.
  const Image& background() const { return background_; }
  // 255 where the empty scene shows the floor, 0 elsewhere (the paper's floorspace mask).
  const Image& floorMask() const { return floor_mask_; }

  // The camera's image at time t with the objects `objects`; `frame_number` seeds the noise. If
  // `object_pixels` is given it receives 1 where an object is seen and 0 elsewhere.
  void render(const std::vector<SceneObject>& objects, std::uint64_t frame_number, Image& out,
              Image* object_pixels = nullptr) const;
  // The same with the caller's depth buffer, kept between frames so that a live source allocates
  // nothing per frame (`out` too must already have the stream's size).
  void render(const std::vector<SceneObject>& objects, std::uint64_t frame_number, Image& out,
              std::vector<float>& depth, Image* object_pixels = nullptr) const;

  // Scales the floor's pixels in `out` by the patches' light, except where `object_pixels` (from
  // render()) shows an object.
  void light(const std::vector<LightPatch>& patches, const Image& object_pixels, Image& out) const;

  // Whether the camera has a clear view of the floor point: it projects into the stream's bounds,
  // and neither the room nor any object stands between it and the camera.
  bool clearView(const Eigen::Vector3d& floor_point, const std::vector<SceneObject>& objects) const;
  bool clearViewOfStatic(const Eigen::Vector3d& floor_point) const;

 private:
  struct PixelBounds {
    int u0, v0, u1, v1;  // inclusive
  };
  PixelBounds projectedBounds(const Solid& solid) const;
  // The background averaged over `samples` x `samples` rays a pixel (Scene::backgroundSamples).
  void integrateOverPixels(int samples);

  const Scene& scene_;
  Camera camera_;
  int camera_index_;
  Eigen::Vector3d centre_;
  std::vector<Eigen::Vector3f> directions_;  // per pixel; zero where the lens model has no ray
  std::vector<float> background_depth_;      // ray parameter of the static hit
  // The pixels that see the floor (where light() puts the patches' light), with the floor point.
  struct FloorPixel {
    std::size_t index;
    Eigen::Vector2d point;
  };
  std::vector<FloorPixel> floor_pixels_;
  Image background_;
  Image floor_mask_;
};

// Adds the sensor noise every simulated camera has (kSensorNoiseAmplitude each way) to `image`,
// the same for the same seed.
void addSensorNoise(std::uint64_t seed, Image& image);

// The scene's truth on a map at one moment, for tests and for the demo's comparison.
struct GroundTruth {
  enum Footprint : std::uint8_t { kClear = 0, kEdge = 1, kInside = 2 };
  // Per cell: kInside when the cell lies wholly inside an object's footprint, kEdge when an
  // object's outline cuts it, kClear otherwise.
  std::vector<std::uint8_t> footprint;
  // Per cell: bit k set when camera k has a clear view of the cell's centre on the floor.
  std::vector<std::uint32_t> clear_view;
  // Per object: the cells wholly inside its footprint.
  std::vector<std::vector<int>> object_cells;
};

// Computes GroundTruth quickly for many frames: what does not move is worked out once.
class TruthMaker {
 public:
  TruthMaker(std::vector<const Renderer*> renderers, const MapGeometry& map);
  GroundTruth at(const std::vector<SceneObject>& objects) const;
  // The stream pixel of camera k that contains cell's centre, or -1 when it is outside the stream.
  int centrePixel(std::size_t camera, std::size_t cell) const;

 private:
  struct CellRange {
    int first_row, last_row, first_column, last_column;
  };
  // The cells where `solid` may hide the floor from a camera at `centre`.
  CellRange shadowCells(const Solid& solid, const Eigen::Vector3d& centre) const;

  std::vector<const Renderer*> renderers_;
  MapGeometry map_;
  std::vector<std::vector<std::uint8_t>> static_clear_;  // per camera, per cell
  std::vector<std::vector<int>> centre_pixel_;           // per camera, per cell
};

}  // namespace occmap::sim
