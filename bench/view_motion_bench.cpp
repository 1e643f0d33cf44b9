// What checking a degraded camera's view costs (core/view_motion.h) and what re-posing a knocked
// one costs (core/repose.h), on the simulated room's camera c1 (640 x 480) turned by 1 degree, on
// examples/sim-room.yaml's map (512 x 512 cells of 2 cm). The check runs on the capture thread,
// once a second while no light explains the view; the re-pose off it, once per knock.
//   build/bench/view_motion_bench [--benchmark_repetitions=5]

#include <memory>
#include <numbers>

#include <benchmark/benchmark.h>

#include "capture/sim/renderer.h"
#include "capture/sim/scene.h"
#include "core/fusion_kernel.h"
#include "core/repose.h"
#include "core/tsai_camera.h"
#include "core/view_motion.h"

namespace occmap {
namespace {

struct Knocked {
  std::unique_ptr<sim::Scene> scene = sim::makeScene("room");
  Camera camera{std::make_shared<TsaiCamera>(scene->cameras()[1].calibration),
                LengthUnit::kMillimetre, 640, 480};
  Eigen::Vector3d turn = Eigen::Vector3d(0.3, 0.9, 0.3).normalized() * std::numbers::pi / 180;
  sim::Renderer renderer{*scene, camera, 1};
  Image live{640, 480};
  Knocked() {
    const sim::Renderer knocked(*scene, camera.turned(turn), 1);
    knocked.render(scene->objectsAt(2.0), 60, live);
  }
};

const Knocked& knocked() {
  static const Knocked data;
  return data;
}

void checkView(benchmark::State& state) {
  const Knocked& data = knocked();
  ViewMotionEstimator estimator(data.renderer.background().view());
  for (auto _ : state) {
    const ViewMotion motion = estimator.estimate(data.live.view());
    benchmark::DoNotOptimize(motion);
    if (!motion.moved) state.SkipWithError("the knocked view was not found moved");
  }
}

void turnOfCamera(benchmark::State& state) {
  const Knocked& data = knocked();
  ViewMotionEstimator estimator(data.renderer.background().view());
  const ViewMotion motion = estimator.estimate(data.live.view());
  for (auto _ : state) benchmark::DoNotOptimize(cameraTurn(data.camera, motion));
}

void repose(benchmark::State& state) {
  const Knocked& data = knocked();
  const MapGeometry map{-0.62, -1.87, 0.02, 512, 512};
  const double column_height_m = static_cast<double>(state.range(0)) / 10;
  for (auto _ : state) {
    ReposedCamera reposed =
        reposeCamera(data.camera, data.turn, data.renderer.background().view(),
                     data.renderer.floorMask().view(), map, column_height_m);
    FusionKernel::Replacement table = FusionKernel::prepareReplacement(reposed.table);
    benchmark::DoNotOptimize(table);
  }
}

BENCHMARK(checkView)->Unit(benchmark::kMillisecond);
BENCHMARK(turnOfCamera)->Unit(benchmark::kMicrosecond);
BENCHMARK(repose)->Arg(0)->Arg(3)->ArgName("column_dm")->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace occmap

BENCHMARK_MAIN();
