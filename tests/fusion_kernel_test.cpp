// The pipeline's fusion kernel equals the reference fusion, cell for cell.
#include "core/fusion_kernel.h"

#include <random>

#include <gtest/gtest.h>

#include "capture/sim/renderer.h"
#include "core/reference_fusion.h"
#include "random_cameras.h"

namespace occmap {
namespace {

std::vector<std::uint8_t> changedMask(const Image& live, const Image& background, int threshold) {
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(live.width() * live.height()));
  markChangedPixels(live.view(), background.view(), threshold, mask.data());
  return mask;
}

TEST(FusionKernel, MarkChangedPixelsIsThePapersDifference) {
  Image live(3, 2), background(3, 2);
  const std::uint8_t a[] = {10, 30, 29, 200, 0, 255};
  const std::uint8_t b[] = {30, 10, 10, 181, 20, 0};
  std::copy(a, a + 6, live.data());
  std::copy(b, b + 6, background.data());
  // |a - b| = 20, 20, 19, 19, 20, 255 against a threshold of 20: changed when >= 20.
  EXPECT_EQ(changedMask(live, background, 20), (std::vector<std::uint8_t>{1, 1, 0, 0, 1, 1}));
}

TEST(FusionKernel, EqualsTheReferenceOnRandomCamerasAndImages) {
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<int> grey(0, 255);
  for (int trial = 0; trial < 60; ++trial) {
    const auto [camera, map] = testing::randomRig(rng);
    const double height = trial % 3 == 0 ? 0.0 : (trial % 3 == 1 ? 0.12 : 0.4);
    const CarveTable table = buildCarveTable(camera, map, height);
    Image background(camera.streamWidth(), camera.streamHeight());
    Image live(camera.streamWidth(), camera.streamHeight());
    for (int v = 0; v < live.height(); ++v) {
      for (int u = 0; u < live.width(); ++u) {
        background.at(u, v) = static_cast<std::uint8_t>(grey(rng));
        live.at(u, v) = grey(rng) < 30 ? static_cast<std::uint8_t>(grey(rng)) : background.at(u, v);
      }
    }
    FusionKernel kernel(std::span(&table, 1));
    const std::vector<std::uint8_t> mask = changedMask(live, background, 20);
    std::vector<CellState> fast(map.cellCount());
    const std::uint8_t* masks[] = {mask.data()};
    kernel.fuse(masks, fast);
    const CameraFrame frame{&table, live.view(), background.view(), 20};
    ASSERT_EQ(fast, fuseReference(map, std::span(&frame, 1)).cells) << "trial " << trial;
    // The camera down: everything unseen.
    const std::uint8_t* none[] = {nullptr};
    kernel.fuse(none, fast);
    for (CellState state : fast) ASSERT_EQ(state, CellState::kUnseen);
  }
}

TEST(FusionKernel, EqualsTheReferenceOnTheSimulatedRoomWithCamerasDown) {
  const auto scene = sim::makeScene("room");
  const MapGeometry map{-0.62, -1.87, 0.02, 512, 512};
  std::vector<std::unique_ptr<sim::Renderer>> renderers;
  for (std::size_t k = 0; k < scene->cameras().size(); ++k) {
    renderers.push_back(std::make_unique<sim::Renderer>(
        *scene,
        Camera(std::make_shared<TsaiCamera>(scene->cameras()[k].calibration),
               LengthUnit::kMillimetre, 640, 480),
        static_cast<int>(k)));
  }
  for (const double height : {0.0, 0.3}) {
    std::vector<CarveTable> tables;
    for (const auto& r : renderers) {
      tables.push_back(buildCarveTable(r->camera(), map, height, r->floorMask().view()));
    }
    FusionKernel kernel(tables);
    std::vector<CellState> fast(map.cellCount());
    for (int frame = 0; frame < 6; ++frame) {
      const double t = 1.7 * frame;
      std::vector<Image> live(renderers.size());
      std::vector<std::vector<std::uint8_t>> masks;
      std::vector<const std::uint8_t*> changed;
      std::vector<CameraFrame> reference;
      for (std::size_t k = 0; k < renderers.size(); ++k) {
        renderers[k]->render(scene->objectsAt(t), static_cast<std::uint64_t>(frame), live[k]);
        masks.push_back(changedMask(live[k], renderers[k]->background(), 20));
        // Frame by frame a different camera is down (frame 0: all up).
        const bool down = frame > 0 && static_cast<std::size_t>(frame - 1) % 4 == k;
        changed.push_back(down ? nullptr : masks.back().data());
        reference.push_back({&tables[k], down ? ImageView{} : live[k].view(),
                             renderers[k]->background().view(), 20});
      }
      kernel.fuse(changed, fast);
      ASSERT_EQ(fast, fuseReference(map, reference).cells)
          << "column " << height << " frame " << frame;
    }
  }
}

}  // namespace
}  // namespace occmap
