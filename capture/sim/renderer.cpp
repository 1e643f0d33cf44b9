#include "capture/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace occmap::sim {
namespace {

std::uint8_t toGrey(double shade) {
  return static_cast<std::uint8_t>(std::clamp(std::lround(shade), 0L, 255L));
}

// splitmix64: a fast, well-mixed generator for the sensor noise.
std::uint64_t splitmix(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

}  // namespace

Renderer::Renderer(const Scene& scene, Camera camera, int camera_index)
    : scene_(scene),
      camera_(std::move(camera)),
      camera_index_(camera_index),
      centre_(camera_.centreMetres()),
      background_(camera_.streamWidth(), camera_.streamHeight()),
      floor_mask_(camera_.streamWidth(), camera_.streamHeight()) {
  const int width = camera_.streamWidth();
  const int height = camera_.streamHeight();
  const std::size_t count = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  directions_.assign(count, Eigen::Vector3f::Zero());
  background_depth_.assign(count, 0.0f);
  // Scene::castStatic for every pixel, in two passes: the room's faces for every ray, then each
  // piece of furniture for only the pixels its projection can cover (as render() does for objects).
  // The same ray tests in the same order give the same nearest hit, with a fraction of them: the
  // empty view was most of the time a simulated rig took to open (seconds under the sanitizers).
  std::vector<Eigen::Vector3d> rays(count, Eigen::Vector3d::Zero());  // zero: the pixel has none
  std::vector<Scene::Hit> hits(count);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v * width + u);
      const std::optional<Ray> ray = camera_.streamToRay(Eigen::Vector2d(u, v));
      if (!ray) continue;  // past the lens model's valid radius: the pixel sees nothing (black)
      rays[i] = ray->direction;
      directions_[i] = ray->direction.cast<float>();
      hits[i] = scene_.castRoom(centre_, ray->direction);
    }
  }
  for (const Solid& solid : scene_.furniture()) {
    const PixelBounds bounds = projectedBounds(solid);
    for (int v = bounds.v0; v <= bounds.v1; ++v) {
      for (int u = bounds.u0; u <= bounds.u1; ++u) {
        const std::size_t i = static_cast<std::size_t>(v * width + u);
        if (rays[i].isZero()) continue;
        const std::optional<Solid::Hit> h = solid.intersect(centre_, rays[i], 1e-9, hits[i].t);
        if (h) hits[i] = Scene::Hit{h->t, h->normal, false};
      }
    }
  }
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v * width + u);
      const Scene::Hit& hit = hits[i];
      if (rays[i].isZero() || !std::isfinite(hit.t)) continue;
      background_depth_[i] = static_cast<float>(hit.t);
      background_.at(u, v) = toGrey(scene_.staticShade(centre_ + hit.t * rays[i], hit.normal));
      floor_mask_.at(u, v) = hit.floor ? 255 : 0;
      // Where light() finds the floor: the point from the depth as stored (a float).
      const Eigen::Vector3d point =
          centre_ + static_cast<double>(background_depth_[i]) * directions_[i].cast<double>();
      if (point.z() <= 1e-3) floor_pixels_.push_back({i, point.head<2>()});
    }
  }
  if (scene_.backgroundSamples() > 1) integrateOverPixels(scene_.backgroundSamples());
}

void Renderer::integrateOverPixels(int samples) {
  const int width = camera_.streamWidth();
  const int height = camera_.streamHeight();
  // A camera integrates light over its pixels; one ray through a pixel's centre draws every edge as
  // a staircase and corners found from it are off by up to half a pixel. n x n rays spread over the
  // pixel, their shades averaged, draw an edge where a camera would. Only near the floor's markers,
  // the one place where edges are measured to a fraction of a pixel (the rest of the floor would
  // multiply the time this takes by the number of rays); everywhere in a scene without markers.
  const std::vector<FloorMarker>& markers = scene_.floorMarkers();
  const auto near_a_marker = [&](const Eigen::Vector3d& point) {
    if (markers.empty()) return true;
    for (const FloorMarker& marker : markers) {
      // The paper's half-diagonal, and room for the widest pixel's footprint on the floor.
      const double reach = (0.5 + kMarkerPaperMargin) * marker.side_m * std::numbers::sqrt2 + 0.3;
      if ((point.head<2>() - marker.centre_m).norm() < reach) return true;
    }
    return false;
  };
  const double step = 1.0 / samples;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v * width + u);
      if (background_depth_[i] <= 0.0f) continue;
      const Eigen::Vector3d centre_point =
          centre_ + static_cast<double>(background_depth_[i]) * directions_[i].cast<double>();
      if (!near_a_marker(centre_point)) continue;
      double sum = 0.0;
      int count = 0;
      for (int a = 0; a < samples; ++a) {
        for (int b = 0; b < samples; ++b) {
          const Eigen::Vector2d at(u + (b + 0.5) * step - 0.5, v + (a + 0.5) * step - 0.5);
          const std::optional<Ray> ray = camera_.streamToRay(at);
          if (!ray) continue;
          const Scene::Hit hit = scene_.castStatic(centre_, ray->direction);
          if (!std::isfinite(hit.t)) continue;
          sum += scene_.staticShade(centre_ + hit.t * ray->direction, hit.normal);
          ++count;
        }
      }
      if (count > 0) background_.at(u, v) = toGrey(sum / count);
    }
  }
}

Renderer::PixelBounds Renderer::projectedBounds(const Solid& solid) const {
  const int width = camera_.streamWidth();
  const int height = camera_.streamHeight();
  const PixelBounds whole{0, 0, width - 1, height - 1};
  // Sample the edges of the solid's bounding box: with lens distortion, straight edges bow, so the
  // corners alone could miss a bulge.
  const Eigen::Vector3d low(solid.centre.x() - solid.half_size.x(),
                            solid.centre.y() - solid.half_size.y(), 0.0);
  const Eigen::Vector3d size(2 * solid.half_size.x(), 2 * solid.half_size.y(), solid.height);
  double u_min = std::numeric_limits<double>::infinity(), v_min = u_min;
  double u_max = -u_min, v_max = -u_min;
  constexpr int kSamples = 8;
  for (int edge = 0; edge < 12; ++edge) {
    const int axis = edge / 4;  // the axis this edge runs along
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    for (int k = 0; k <= kSamples; ++k) {
      Eigen::Vector3d p = low;
      p[axis] += size[axis] * k / kSamples;
      p[a] += (edge & 1) ? size[a] : 0.0;
      p[b] += (edge & 2) ? size[b] : 0.0;
      const std::optional<Eigen::Vector2d> s = camera_.worldToStream(p);
      if (!s) return whole;  // part of it behind the camera: look everywhere
      u_min = std::min(u_min, s->x());
      u_max = std::max(u_max, s->x());
      v_min = std::min(v_min, s->y());
      v_max = std::max(v_max, s->y());
    }
  }
  constexpr double kMargin = 3.0;
  return {std::max(0, static_cast<int>(std::floor(u_min - kMargin))),
          std::max(0, static_cast<int>(std::floor(v_min - kMargin))),
          std::min(width - 1, static_cast<int>(std::ceil(u_max + kMargin))),
          std::min(height - 1, static_cast<int>(std::ceil(v_max + kMargin)))};
}

void Renderer::render(const std::vector<SceneObject>& objects, std::uint64_t frame_number,
                      Image& out, Image* object_pixels) const {
  std::vector<float> depth;
  render(objects, frame_number, out, depth, object_pixels);
}

void Renderer::render(const std::vector<SceneObject>& objects, std::uint64_t frame_number,
                      Image& out, std::vector<float>& depth, Image* object_pixels) const {
  const int width = camera_.streamWidth();
  const int height = camera_.streamHeight();
  if (out.width() != width || out.height() != height) out = Image(width, height);
  std::copy(background_.data(), background_.data() + directions_.size(), out.data());
  if (object_pixels) {
    if (object_pixels->width() != width || object_pixels->height() != height) {
      *object_pixels = Image(width, height, 0);
    } else {
      std::fill_n(object_pixels->data(), directions_.size(), std::uint8_t{0});
    }
  }
  // Nearest object so far, per pixel; reset where this frame's objects may draw.
  if (depth.size() != directions_.size()) depth.resize(directions_.size());
  for (const SceneObject& object : objects) {
    const PixelBounds bounds = projectedBounds(object.solid);
    for (int v = bounds.v0; v <= bounds.v1; ++v) {
      std::fill_n(depth.begin() + v * width + bounds.u0, bounds.u1 - bounds.u0 + 1,
                  std::numeric_limits<float>::max());
    }
  }
  for (const SceneObject& object : objects) {
    const PixelBounds bounds = projectedBounds(object.solid);
    for (int v = bounds.v0; v <= bounds.v1; ++v) {
      for (int u = bounds.u0; u <= bounds.u1; ++u) {
        const std::size_t i = static_cast<std::size_t>(v * width + u);
        if (background_depth_[i] <= 0.0f) continue;
        const Eigen::Vector3d direction = directions_[i].cast<double>();
        const std::optional<Solid::Hit> hit = object.solid.intersect(
            centre_, direction, 1e-9, static_cast<double>(background_depth_[i]));
        if (!hit) continue;
        if (static_cast<float>(hit->t) >= depth[i]) continue;
        depth[i] = static_cast<float>(hit->t);
        out.at(u, v) = toGrey(scene_.objectShade(object, centre_ + hit->t * direction));
        if (object_pixels) object_pixels->at(u, v) = 1;
      }
    }
  }
  // The same noise for the same frame and camera.
  addSensorNoise(frame_number * 0x100000001b3ull + static_cast<std::uint64_t>(camera_index_), out);
}

void addSensorNoise(std::uint64_t seed, Image& image) {
  // The sum of two uniform integers in [-3, 3] (kSensorNoiseAmplitude each way).
  std::uint64_t state = seed;
  std::uint8_t* pixel = image.data();
  const std::size_t count =
      static_cast<std::size_t>(image.width()) * static_cast<std::size_t>(image.height());
  for (std::size_t i = 0; i < count;) {
    std::uint64_t bits = splitmix(state);
    for (int k = 0; k < 4 && i < count; ++k, ++i) {
      const int a = static_cast<int>((bits & 0xff) * 7 >> 8) - 3;
      const int b = static_cast<int>(((bits >> 8) & 0xff) * 7 >> 8) - 3;
      bits >>= 16;
      pixel[i] = static_cast<std::uint8_t>(std::clamp(int{pixel[i]} + a + b, 0, 255));
    }
  }
}

void Renderer::light(const std::vector<LightPatch>& patches, const Image& object_pixels,
                     Image& out) const {
  if (patches.empty()) return;
  std::uint8_t* pixel = out.data();
  const std::uint8_t* object = object_pixels.data();
  // A patch's gain is exactly 1 beyond its reach: only the pixels within it ask the patch (the
  // patches' light was half of a sanitized occmap fuse of sim://room-lamps when every pixel asked
  // every patch).
  for (const FloorPixel& floor : floor_pixels_) {
    if (object[floor.index] != 0) continue;
    double gain = 1.0;
    for (const LightPatch& patch : patches) {
      const Eigen::Vector2d d = (floor.point - patch.centre).cwiseAbs();
      if (d.x() <= patch.reach() && d.y() <= patch.reach()) gain *= patch.at(floor.point);
    }
    if (gain != 1.0) {
      pixel[floor.index] =
          static_cast<std::uint8_t>(std::clamp(std::round(pixel[floor.index] * gain), 0.0, 255.0));
    }
  }
}

bool Renderer::clearViewOfStatic(const Eigen::Vector3d& point) const {
  const std::optional<Eigen::Vector2d> stream = camera_.worldToStream(point);
  if (!stream || !camera_.pixelIndexAt(*stream)) return false;
  const Eigen::Vector3d direction = point - centre_;
  const Scene::Hit hit = scene_.castStatic(centre_, direction);
  // The segment reaches the point (t = 1) on the floor, with nothing static before it.
  return hit.floor && std::abs(hit.t - 1.0) < 1e-9;
}

bool Renderer::clearView(const Eigen::Vector3d& point,
                         const std::vector<SceneObject>& objects) const {
  if (!clearViewOfStatic(point)) return false;
  const Eigen::Vector3d direction = point - centre_;
  for (const SceneObject& object : objects) {
    if (object.solid.intersect(centre_, direction, 1e-9, 1.0 - 1e-9)) return false;
  }
  return true;
}

TruthMaker::TruthMaker(std::vector<const Renderer*> renderers, const MapGeometry& map)
    : renderers_(std::move(renderers)), map_(map) {
  // Renderer::clearViewOfStatic for every cell, with each ray tested against only the furniture
  // whose shadow can hold the cell (as at() does for objects): the same ray tests decide.
  for (const Renderer* renderer : renderers_) {
    const Camera& camera = renderer->camera();
    const Eigen::Vector3d centre = camera.centreMetres();
    std::vector<std::uint8_t> clear(map_.cellCount(), 0);
    std::vector<int> pixels(map_.cellCount(), -1);
    for (int row = 0; row < map_.height; ++row) {
      for (int column = 0; column < map_.width; ++column) {
        const std::size_t cell = static_cast<std::size_t>(map_.index(row, column));
        const Eigen::Vector2d c = map_.cellCentre(row, column);
        const Eigen::Vector3d point(c.x(), c.y(), 0.0);
        const std::optional<Eigen::Vector2d> stream = camera.worldToStream(point);
        if (stream) pixels[cell] = camera.pixelIndexAt(*stream).value_or(-1);
        if (pixels[cell] < 0) continue;
        // The segment reaches the point (t = 1) on the floor, with no furniture before it.
        const Scene::Hit room = renderer->scene().castRoom(centre, point - centre);
        clear[cell] = room.floor && std::abs(room.t - 1.0) < 1e-9 ? 1 : 0;
      }
    }
    for (const Solid& solid : renderer->scene().furniture()) {
      const CellRange shadow = shadowCells(solid, centre);
      for (int row = shadow.first_row; row <= shadow.last_row; ++row) {
        for (int column = shadow.first_column; column <= shadow.last_column; ++column) {
          const std::size_t cell = static_cast<std::size_t>(map_.index(row, column));
          if (!clear[cell]) continue;
          const Eigen::Vector2d c = map_.cellCentre(row, column);
          const Eigen::Vector3d direction = Eigen::Vector3d(c.x(), c.y(), 0.0) - centre;
          const double floor_t = renderer->scene().castRoom(centre, direction).t;
          if (solid.intersect(centre, direction, 1e-9, floor_t)) clear[cell] = 0;
        }
      }
    }
    static_clear_.push_back(std::move(clear));
    centre_pixel_.push_back(std::move(pixels));
  }
}

int TruthMaker::centrePixel(std::size_t camera, std::size_t cell) const {
  return centre_pixel_[camera][cell];
}

TruthMaker::CellRange TruthMaker::shadowCells(const Solid& solid,
                                              const Eigen::Vector3d& centre) const {
  const CellRange everything{0, map_.height - 1, 0, map_.width - 1};
  // A camera at or below the top sees the solid's shadow reach the horizon.
  if (!(centre.z() > solid.height)) return everything;
  double low_x = std::numeric_limits<double>::infinity();
  double low_y = low_x;
  double high_x = -low_x;
  double high_y = -low_x;
  for (const double z : {0.0, solid.height}) {
    // From the centre through a point at height z onto the floor: the point moved away from the
    // centre by centre.z / (centre.z - z).
    const double stretch = centre.z() / (centre.z() - z);
    for (const double sx : {-1.0, 1.0}) {
      for (const double sy : {-1.0, 1.0}) {
        const double x =
            centre.x() + (solid.centre.x() + sx * solid.half_size.x() - centre.x()) * stretch;
        const double y =
            centre.y() + (solid.centre.y() + sy * solid.half_size.y() - centre.y()) * stretch;
        low_x = std::min(low_x, x);
        high_x = std::max(high_x, x);
        low_y = std::min(low_y, y);
        high_y = std::max(high_y, y);
      }
    }
  }
  // A cell whose centre lies in the shadow is inside these bounds; one cell more on every side
  // covers rounding.
  const double cell = map_.cell_size_m;
  const auto index = [](double v) {
    return static_cast<int>(std::clamp(std::floor(v), -1.0e9, 1.0e9));
  };
  return CellRange{std::max(0, index((low_y - map_.origin_y_m) / cell) - 1),
                   std::min(map_.height - 1, index((high_y - map_.origin_y_m) / cell) + 1),
                   std::max(0, index((low_x - map_.origin_x_m) / cell) - 1),
                   std::min(map_.width - 1, index((high_x - map_.origin_x_m) / cell) + 1)};
}

GroundTruth TruthMaker::at(const std::vector<SceneObject>& objects) const {
  GroundTruth truth;
  truth.footprint.assign(map_.cellCount(), GroundTruth::kClear);
  truth.clear_view.assign(map_.cellCount(), 0);
  truth.object_cells.resize(objects.size());
  const double cell_size = map_.cell_size_m;
  for (std::size_t k = 0; k < objects.size(); ++k) {
    const Solid& solid = objects[k].solid;
    // Only the cells under the solid's bounding square can be touched by its footprint.
    const auto first_column = static_cast<int>(
        std::floor((solid.centre.x() - solid.half_size.x() - map_.origin_x_m) / cell_size));
    const auto last_column = static_cast<int>(
        std::floor((solid.centre.x() + solid.half_size.x() - map_.origin_x_m) / cell_size));
    const auto first_row = static_cast<int>(
        std::floor((solid.centre.y() - solid.half_size.y() - map_.origin_y_m) / cell_size));
    const auto last_row = static_cast<int>(
        std::floor((solid.centre.y() + solid.half_size.y() - map_.origin_y_m) / cell_size));
    for (int row = std::max(0, first_row); row <= std::min(map_.height - 1, last_row); ++row) {
      for (int column = std::max(0, first_column); column <= std::min(map_.width - 1, last_column);
           ++column) {
        const Eigen::Vector2d low(map_.origin_x_m + column * cell_size,
                                  map_.origin_y_m + row * cell_size);
        const Eigen::Vector2d high = low + Eigen::Vector2d(cell_size, cell_size);
        const int cell = map_.index(row, column);
        std::uint8_t& footprint = truth.footprint[static_cast<std::size_t>(cell)];
        if (solid.footprintCovers(low, high)) {
          footprint = GroundTruth::kInside;
          truth.object_cells[k].push_back(cell);
        } else if (solid.footprintOverlaps(low, high) && footprint != GroundTruth::kInside) {
          footprint = GroundTruth::kEdge;
        }
      }
    }
  }
  // Each camera's clear view: every statically clear cell, less those an object hides. An object
  // can hide only the floor inside its shadow cast from the camera's centre, which lies within the
  // bounding rectangle of its bounding box's corners projected onto the floor; only cells there are
  // tested, exactly as before (the ray cast decides), so the truth is the same, found in a fraction
  // of the time (five people among 262144 cells).
  for (std::size_t camera = 0; camera < renderers_.size(); ++camera) {
    const Renderer& renderer = *renderers_[camera];
    const Eigen::Vector3d centre = renderer.camera().centreMetres();
    const std::uint32_t bit = 1u << camera;
    const std::vector<std::uint8_t>& static_clear = static_clear_[camera];
    for (std::size_t cell = 0; cell < static_clear.size(); ++cell) {
      if (static_clear[cell]) truth.clear_view[cell] |= bit;
    }
    for (const SceneObject& object : objects) {
      const CellRange shadow = shadowCells(object.solid, centre);
      for (int row = shadow.first_row; row <= shadow.last_row; ++row) {
        for (int column = shadow.first_column; column <= shadow.last_column; ++column) {
          const std::size_t cell = static_cast<std::size_t>(map_.index(row, column));
          if (!(truth.clear_view[cell] & bit)) continue;
          const Eigen::Vector2d c = map_.cellCentre(row, column);
          const Eigen::Vector3d direction = Eigen::Vector3d(c.x(), c.y(), 0.0) - centre;
          if (object.solid.intersect(centre, direction, 1e-9, 1.0 - 1e-9)) {
            truth.clear_view[cell] &= ~bit;
          }
        }
      }
    }
  }
  return truth;
}

}  // namespace occmap::sim
