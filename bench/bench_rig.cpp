#include "bench/bench_rig.h"

#include <atomic>
#include <cmath>
#include <numbers>
#include <thread>

#include "core/tsai_camera.h"

namespace occmap::bench {
namespace {

// Runs fn(0) .. fn(count - 1) on all cores.
template <class Fn>
void parallelFor(std::size_t count, Fn fn) {
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t i = next++; i < count; i = next++) fn(i);
  };
  std::vector<std::thread> threads;
  const std::size_t helpers = std::min<std::size_t>(std::thread::hardware_concurrency(), count);
  for (std::size_t t = 1; t < helpers; ++t) threads.emplace_back(work);
  work();
  for (std::thread& thread : threads) thread.join();
}

// A camera of `width` x `height` pixels on a 6.4 mm wide sensor (the paper's 1/2" CCD), at
// `position` looking at `target` (metres).
TsaiParameters lookAt(int width, int height, const Eigen::Vector3d& position,
                      const Eigen::Vector3d& target, double focal_mm, double kappa1) {
  TsaiParameters p;
  p.width = width;
  p.height = height;
  p.ncx = p.nfx = width;
  p.dx = p.dy = p.dpx = p.dpy = 6.4 / width;
  p.focal = focal_mm;
  p.kappa1 = kappa1;
  p.cx = width / 2.0 - 0.5;
  p.cy = height / 2.0 - 0.5;
  p.sx = 1.0;
  p.setPose(poseLookingAt(position * 1000.0, target * 1000.0));
  return p;
}

}  // namespace

BenchConfig paperConfig() {
  BenchConfig config{"paper", {}, 640, 480, MapGeometry{-0.62, -1.87, 0.02, 512, 512}, 1};
  for (const sim::SceneCamera& camera : sim::makeScene("room")->cameras()) {
    config.cameras.push_back(camera.calibration);
  }
  return config;
}

BenchConfig largeConfig() {
  BenchConfig config{"large", {}, 1920, 1080, MapGeometry{-0.62, -1.87, 0.01, 1024, 1024}, 0};
  // On the 2 m shelves like the room's own cameras (room 9 x 6.5 m): the corners with wide
  // lenses, the middle of each wall with narrower ones.
  constexpr double kHeight = 2.3, kIn = 0.4;
  const double x = 9.0, y = 6.5;
  struct Place {
    double px, py, tx, ty, focal, kappa1;
  };
  const Place places[] = {
      {kIn, kIn, 4.6, 3.3, 3.5, 8e-3},         {x - kIn, kIn, 4.4, 3.2, 3.5, 8e-3},
      {x - kIn, y - kIn, 4.4, 3.1, 3.5, 8e-3}, {kIn, y - kIn, 4.6, 3.2, 3.5, 8e-3},
      {x / 2, kIn, x / 2, 3.6, 4.5, 4e-3},     {x - kIn, y / 2, 3.8, y / 2, 4.5, 4e-3},
      {x / 2, y - kIn, x / 2, 2.9, 4.5, 4e-3}, {kIn, y / 2, 5.2, y / 2, 4.5, 4e-3},
  };
  for (const Place& p : places) {
    config.cameras.push_back(lookAt(config.width, config.height, {p.px, p.py, kHeight},
                                    {p.tx, p.ty, 0.0}, p.focal, p.kappa1));
  }
  return config;
}

BenchRig::BenchRig(BenchConfig config)
    : config_(std::move(config)), scene_(sim::makeScene("room")) {
  renderers_.resize(config_.cameras.size());
  parallelFor(renderers_.size(), [&](std::size_t k) {
    renderers_[k] = std::make_unique<sim::Renderer>(
        *scene_,
        Camera(std::make_shared<TsaiCamera>(config_.cameras[k]), LengthUnit::kMillimetre,
               config_.width, config_.height),
        static_cast<int>(k));
  });
}

std::vector<CarveTable> BenchRig::buildTables(double column_height_m) const {
  std::vector<CarveTable> tables(renderers_.size());
  parallelFor(tables.size(), [&](std::size_t k) {
    tables[k] = buildCarveTable(renderers_[k]->camera(), config_.map, column_height_m,
                                renderers_[k]->floorMask().view());
  });
  return tables;
}

std::vector<std::vector<std::int32_t>> BenchRig::paperTables() const {
  std::vector<std::vector<std::int32_t>> tables(renderers_.size());
  parallelFor(tables.size(), [&](std::size_t k) {
    const sim::Renderer& r = *renderers_[k];
    std::vector<std::int32_t>& table = tables[k];
    table.assign(static_cast<std::size_t>(config_.width) * static_cast<std::size_t>(config_.height),
                 -1);
    for (int v = 0; v < config_.height; ++v) {
      for (int u = 0; u < config_.width; ++u) {
        if (r.floorMask().at(u, v) == 0) continue;
        const auto floor = r.camera().streamToPlane(Eigen::Vector2d(u, v), 0.0);
        if (!floor) continue;
        const std::optional<int> cell = config_.map.cellAt(floor->x(), floor->y());
        if (cell) {
          table[static_cast<std::size_t>(v) * static_cast<std::size_t>(config_.width) +
                static_cast<std::size_t>(u)] = *cell;
        }
      }
    }
  });
  return tables;
}

FrameSet BenchRig::render(double t, std::uint64_t frame_number) const {
  std::vector<sim::SceneObject> objects = scene_->objectsAt(t);
  // More people walking an ellipse round the middle of the room where the room's own five objects
  // change fewer than a tenth of the pixels.
  for (int extra = 0; extra < config_.extra_people; ++extra) {
    const double a = 2.0 * std::numbers::pi * (t / 14.0 + extra / 3.0);
    sim::Solid person;
    person.shape = sim::Solid::Shape::kCylinder;
    person.centre = {4.5 + 1.6 * std::cos(a), 3.25 + 0.9 * std::sin(a)};
    person.half_size = {0.25, 0.25};
    person.height = 1.7;
    objects.push_back({sim::ObjectKind::kPerson, person});
  }
  FrameSet frames(renderers_.size());
  parallelFor(frames.size(), [&](std::size_t k) {
    frames[k] = Image(config_.width, config_.height);
    renderers_[k]->render(objects, frame_number, frames[k]);
  });
  return frames;
}

double BenchRig::changedShare(const FrameSet& frames) const {
  std::size_t changed = 0, pixels = 0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const Image& live = frames[k];
    const Image& background = renderers_[k]->background();
    for (int v = 0; v < live.height(); ++v) {
      for (int u = 0; u < live.width(); ++u) {
        changed += std::abs(live.at(u, v) - background.at(u, v)) >= kThreshold ? 1 : 0;
      }
    }
    pixels += static_cast<std::size_t>(live.width()) * static_cast<std::size_t>(live.height());
  }
  return static_cast<double>(changed) / static_cast<double>(pixels);
}

}  // namespace occmap::bench
