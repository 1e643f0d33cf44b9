// The pipeline's fusion kernel equals the reference fusion, cell for cell, on every SIMD target
// this machine has and on the scalar path.
#include "core/fusion_kernel.h"

#include <random>
#include <utility>

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include "capture/sim/renderer.h"
#include "core/fusion_steps.h"
#include "core/reference_fusion.h"
#include "random_cameras.h"

namespace occmap {
namespace {

// Every Highway target compiled into the kernel that this CPU runs (AVX3, AVX2, SSE4, SSSE3 and
// EMU128 on a recent x86; NEON and EMU128 on ARM), each made the one that dynamic dispatch picks
// for the duration of the body, and then the scalar path.
struct Path {
  KernelPath kernel;
  std::int64_t target;  // 0 for the scalar path
  std::string name() const { return target == 0 ? "scalar" : hwy::TargetName(target); }
};

std::vector<Path> everyPath() {
  std::vector<Path> paths;
  for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    paths.push_back({KernelPath::kSimd, target});
  }
  paths.push_back({KernelPath::kScalar, 0});
  return paths;
}

template <class Body>
void onEveryPath(Body body) {
  for (const Path& path : everyPath()) {
    SCOPED_TRACE("path " + path.name());
    hwy::SetSupportedTargetsForTest(path.target);
    if (path.target != 0) {
      ASSERT_EQ(fusionSimdTarget(), path.name()) << "dispatch did not follow the test's target";
    }
    body(path.kernel);
    hwy::SetSupportedTargetsForTest(0);
    if (::testing::Test::HasFatalFailure()) return;
  }
}

std::vector<std::uint8_t> changedMask(ImageView live, ImageView background, int threshold,
                                      KernelPath path = KernelPath::kSimd) {
  std::vector<std::uint8_t> mask(changedMaskBytes(live.width, live.height), 0xA5);
  markChangedPixels(live, background, threshold, mask.data(), path);
  return mask;
}

// Whether the mask marks pixel (u, v) changed: bit (v % 8) * 8 + u % 8 of the pixel's tile.
bool changedAt(const std::vector<std::uint8_t>& mask, int width, int u, int v) {
  const auto tile = static_cast<std::size_t>(v / 8) * static_cast<std::size_t>((width + 7) / 8) +
                    static_cast<std::size_t>(u / 8);
  return ((mask[tile * 8 + static_cast<std::size_t>(v % 8)] >> (u % 8)) & 1) != 0;
}

// A random background, and a live image that differs from it in scattered pixels (about 12 %)
// and in a few solid rectangles, like objects, so that whole tiles change.
void randomImages(std::mt19937_64& rng, Image& background, Image& live) {
  std::uniform_int_distribution<int> grey(0, 255);
  for (int v = 0; v < live.height(); ++v) {
    for (int u = 0; u < live.width(); ++u) {
      background.at(u, v) = static_cast<std::uint8_t>(grey(rng));
      live.at(u, v) = grey(rng) < 30 ? static_cast<std::uint8_t>(grey(rng)) : background.at(u, v);
    }
  }
  for (int blob = 0; blob < 3; ++blob) {
    const int u0 = grey(rng) % live.width(), v0 = grey(rng) % live.height();
    const int w = 1 + grey(rng) % (live.width() / 3 + 1), h = 1 + grey(rng) % (live.height() / 2);
    for (int v = v0; v < std::min(live.height(), v0 + h); ++v) {
      for (int u = u0; u < std::min(live.width(), u0 + w); ++u) {
        live.at(u, v) = static_cast<std::uint8_t>(background.at(u, v) ^ 0x80);
      }
    }
  }
}

TEST(FusionKernel, MarkChangedPixelsIsThePapersDifference) {
  Image live(3, 2), background(3, 2);
  const std::uint8_t a[] = {10, 30, 29, 200, 0, 255};
  const std::uint8_t b[] = {30, 10, 10, 181, 20, 0};
  std::copy(a, a + 6, live.data());
  std::copy(b, b + 6, background.data());
  // |a - b| = 20, 20, 19, 19, 20, 255 against a threshold of 20: changed when >= 20.
  const bool expected[] = {true, true, false, false, true, true};
  onEveryPath([&](KernelPath path) {
    const std::vector<std::uint8_t> mask = changedMask(live.view(), background.view(), 20, path);
    ASSERT_EQ(mask.size(), 8u) << "one tile of 8 x 8 pixels";
    for (int i = 0; i < 6; ++i) EXPECT_EQ(changedAt(mask, 3, i % 3, i / 3), expected[i]) << i;
    // The tile's pixels outside the image read as unchanged.
    EXPECT_EQ(mask[0] & ~0b111, 0);
    EXPECT_EQ(mask[2], 0);
  });
}

TEST(FusionKernel, MarkChangedPixelsIsTheSameOnEveryPathForAnySizeStrideAndThreshold) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<int> size(1, 200);
  for (int trial = 0; trial < 40; ++trial) {
    const int width = trial == 0 ? 640 : size(rng), height = trial == 0 ? 480 : size(rng);
    const int padding = trial % 3 == 0 ? 0 : 1 + trial % 13;  // rows that do not touch
    Image background(width + padding, height), live(width + padding, height);
    randomImages(rng, background, live);
    const ImageView live_view{live.data(), width, height, width + padding};
    const ImageView background_view{background.data(), width, height, width + padding};
    const int threshold = trial == 1 ? 0 : trial == 2 ? 256 : 1 + trial * 37 % 255;
    // The definition, pixel by pixel.
    std::vector<std::uint8_t> expected(changedMaskBytes(width, height), 0);
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const int difference = std::abs(live_view.at(u, v) - background_view.at(u, v));
        if (difference >= threshold) {
          const auto tile =
              static_cast<std::size_t>(v / 8) * static_cast<std::size_t>((width + 7) / 8) +
              static_cast<std::size_t>(u / 8);
          expected[tile * 8 + static_cast<std::size_t>(v % 8)] |=
              static_cast<std::uint8_t>(1 << (u % 8));
        }
      }
    }
    onEveryPath([&](KernelPath path) {
      ASSERT_EQ(changedMask(live_view, background_view, threshold, path), expected)
          << "trial " << trial << ": " << width << "x" << height << " threshold " << threshold;
    });
  }
}

TEST(FusionKernel, EqualsTheReferenceOnRandomCamerasAndImages) {
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 60; ++trial) {
    // Not a structured binding: the lambda below captures the map. The first trials are as wide
    // as whole 64-pixel strips, which leaves the SIMD difference no tail to do.
    const testing::RandomRig rig = testing::randomRig(rng, trial < 4 ? 64 * (1 + trial % 2) : 0);
    const Camera& camera = rig.camera;
    const MapGeometry& map = rig.map;
    const double height = trial % 3 == 0 ? 0.0 : (trial % 3 == 1 ? 0.12 : 0.4);
    const CarveTable table = buildCarveTable(camera, map, height);
    Image background(camera.streamWidth(), camera.streamHeight());
    Image live(camera.streamWidth(), camera.streamHeight());
    randomImages(rng, background, live);
    const CameraFrame frame{&table, live.view(), background.view(), 20};
    const std::vector<CellState> expected = fuseReference(map, std::span(&frame, 1)).cells;
    const std::vector<std::uint8_t> full = changedMask(live.view(), background.view(), 20);
    std::vector<std::uint8_t> expected_mask(full.size());
    FusionKernel(std::span(&table, 1), KernelPath::kScalar)
        .markChangedPixels(0, live.view(), background.view(), 20, expected_mask.data());
    for (std::size_t i = 0; i < full.size(); ++i) {
      ASSERT_EQ(expected_mask[i] & ~full[i], 0) << "the kernel's mask marks a pixel unchanged";
    }
    onEveryPath([&](KernelPath path) {
      FusionKernel kernel(std::span(&table, 1), path);
      // The capture threads' mask, which leaves out pixels no cell needs, and the whole one.
      std::vector<std::uint8_t> mask(full.size(), 0x5A);
      kernel.markChangedPixels(0, live.view(), background.view(), 20, mask.data());
      ASSERT_EQ(mask, expected_mask) << "trial " << trial;
      std::vector<CellState> fast(map.cellCount());
      for (const std::uint8_t* changed : {std::as_const(mask).data(), full.data()}) {
        const std::uint8_t* masks[] = {changed};
        kernel.fuse(masks, fast);
        ASSERT_EQ(fast, expected) << "trial " << trial << " column " << height;
      }
      // The camera down: everything unseen.
      const std::uint8_t* none[] = {nullptr};
      kernel.fuse(none, fast);
      for (CellState state : fast) ASSERT_EQ(state, CellState::kUnseen);
    });
  }
}

// Several cameras on one map, some of them down, for many frames: more than the kernel's 255
// stamps, so that they wrap.
TEST(FusionKernel, EqualsTheReferenceWithManyCamerasOverManyFrames) {
  std::mt19937_64 rng(8);
  for (const double height : {0.0, 0.25}) {
    const auto first = testing::randomRig(rng);
    // Four more random cameras that each see at least a fifth of the first one's map.
    std::vector<Camera> cameras{first.camera};
    std::vector<CarveTable> tables{buildCarveTable(first.camera, first.map, height)};
    for (int attempt = 0; attempt < 5000 && cameras.size() < 5; ++attempt) {
      const Camera camera = testing::randomRig(rng).camera;
      CarveTable table = buildCarveTable(camera, first.map, height);
      if (table.cellsInView() * 5 < first.map.cellCount()) continue;
      cameras.push_back(camera);
      tables.push_back(std::move(table));
    }
    ASSERT_EQ(cameras.size(), 5u) << "too few random cameras see the map";
    std::vector<Image> backgrounds, lives;
    std::vector<std::vector<std::uint8_t>> masks;
    for (const Camera& camera : cameras) {
      backgrounds.emplace_back(camera.streamWidth(), camera.streamHeight());
      lives.emplace_back(camera.streamWidth(), camera.streamHeight());
      randomImages(rng, backgrounds.back(), lives.back());
    }
    onEveryPath([&](KernelPath path) {
      FusionKernel kernel(tables, path);
      std::vector<CellState> fast(first.map.cellCount());
      for (int frame = 0; frame < 130; ++frame) {
        // A new image for one camera per frame, and a different set of cameras down.
        const std::size_t renewed = static_cast<std::size_t>(frame) % cameras.size();
        randomImages(rng, backgrounds[renewed], lives[renewed]);
        masks.clear();
        std::vector<const std::uint8_t*> changed;
        std::vector<CameraFrame> reference;
        for (std::size_t k = 0; k < cameras.size(); ++k) {
          const bool down = (frame >> k) % 3 == 2;
          masks.push_back(changedMask(lives[k].view(), backgrounds[k].view(), 20, path));
          changed.push_back(down ? nullptr : masks.back().data());
          reference.push_back(
              {&tables[k], down ? ImageView{} : lives[k].view(), backgrounds[k].view(), 20});
        }
        kernel.fuse(changed, fast);
        ASSERT_EQ(fast, fuseReference(first.map, reference).cells)
            << "column " << height << " frame " << frame;
      }
    });
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
    for (int frame = 0; frame < 4; ++frame) {
      const double t = 1.7 * frame;
      std::vector<Image> live(renderers.size());
      std::vector<CameraFrame> reference;
      std::vector<bool> down;
      for (std::size_t k = 0; k < renderers.size(); ++k) {
        renderers[k]->render(scene->objectsAt(t), static_cast<std::uint64_t>(frame), live[k]);
        // Frame by frame a different camera is down (frame 0: all up).
        down.push_back(frame > 0 && static_cast<std::size_t>(frame - 1) % 4 == k);
        reference.push_back({&tables[k], down.back() ? ImageView{} : live[k].view(),
                             renderers[k]->background().view(), 20});
      }
      const std::vector<CellState> expected = fuseReference(map, reference).cells;
      onEveryPath([&](KernelPath path) {
        FusionKernel kernel(tables, path);
        std::vector<std::vector<std::uint8_t>> masks;
        std::vector<const std::uint8_t*> changed;
        for (std::size_t k = 0; k < renderers.size(); ++k) {
          masks.push_back(changedMask(live[k].view(), renderers[k]->background().view(), 20, path));
          changed.push_back(down[k] ? nullptr : masks.back().data());
        }
        std::vector<CellState> fast(map.cellCount());
        kernel.fuse(changed, fast);
        ASSERT_EQ(fast, expected) << "column " << height << " frame " << frame;
      });
    }
  }
}

// A camera's table replaced while the kernel runs (a camera re-posed after a knock): the kernel
// then fuses as one built with the new table from the start, marks that camera's pixels by its new
// table, and leaves out a mask marked under the old one, as if the camera were down.
TEST(FusionKernel, AReplacedCameraTableFusesAsIfBuiltSoAndLeavesOutMasksOfTheOldOne) {
  const auto scene = sim::makeScene("room");
  const MapGeometry map{-0.62, -1.87, 0.04, 256, 256};
  std::vector<Camera> cameras;
  for (const auto& c : scene->cameras()) {
    cameras.emplace_back(std::make_shared<TsaiCamera>(c.calibration), LengthUnit::kMillimetre, 640,
                         480);
  }
  const Camera turned = cameras[1].turned(Eigen::Vector3d(0.2, 1.0, 0.1).normalized() * 0.02);
  for (const double height : {0.0, 0.3}) {
    std::vector<CarveTable> tables, turned_tables;
    for (std::size_t k = 0; k < cameras.size(); ++k) {
      tables.push_back(buildCarveTable(cameras[k], map, height));
      turned_tables.push_back(k == 1 ? buildCarveTable(turned, map, height) : tables.back());
    }
    ASSERT_NE(tables[1].entries(), turned_tables[1].entries()) << "the turn changed nothing";
    std::mt19937_64 rng(11);
    std::vector<Image> backgrounds, lives;
    for (std::size_t k = 0; k < cameras.size(); ++k) {
      backgrounds.emplace_back(640, 480);
      lives.emplace_back(640, 480);
      randomImages(rng, backgrounds.back(), lives.back());
    }
    onEveryPath([&](KernelPath path) {
      FusionKernel kernel(tables, path);
      const FusionKernel built_so(turned_tables, path);
      EXPECT_EQ(kernel.generation(1), 0u);
      kernel.replaceCamera(1, turned_tables[1]);
      EXPECT_EQ(kernel.generation(1), 1u);
      EXPECT_EQ(kernel.generation(0), 0u);
      EXPECT_EQ(kernel.tableBytes(), built_so.tableBytes());
      std::vector<std::vector<std::uint8_t>> masks(cameras.size());
      std::vector<std::vector<std::uint8_t>> expected_masks(cameras.size());
      std::vector<const std::uint8_t*> changed;
      std::vector<std::uint32_t> generations;
      for (std::size_t k = 0; k < cameras.size(); ++k) {
        masks[k].assign(changedMaskBytes(640, 480), 0x5A);
        expected_masks[k].assign(changedMaskBytes(640, 480), 0x5A);
        generations.push_back(kernel.markChangedPixels(k, lives[k].view(), backgrounds[k].view(),
                                                       20, masks[k].data()));
        built_so.markChangedPixels(k, lives[k].view(), backgrounds[k].view(), 20,
                                   expected_masks[k].data());
        ASSERT_EQ(masks[k], expected_masks[k]) << "camera " << k;
        changed.push_back(masks[k].data());
      }
      EXPECT_EQ(generations, (std::vector<std::uint32_t>{0, 1, 0, 0}));
      std::vector<CellState> fast(map.cellCount()), expected(map.cellCount());
      EXPECT_EQ(kernel.fuse(changed, fast, generations), 0b1111u);
      FusionKernel(turned_tables, path).fuse(changed, expected);
      ASSERT_EQ(fast, expected) << "column " << height;
      // Camera 1's mask marked under its old table: left out, as if it were down, and said so.
      generations[1] = 0;
      EXPECT_EQ(kernel.fuse(changed, fast, generations), 0b1101u);
      changed[1] = nullptr;
      FusionKernel(turned_tables, path).fuse(changed, expected);
      ASSERT_EQ(fast, expected) << "column " << height;
    });
  }
}

// The vector steps on their own, against their scalar versions, at sizes that leave partial
// words.
TEST(FusionKernel, StreamingStepsAreTheSameOnEveryTarget) {
  std::mt19937_64 rng(3);
  for (const std::size_t cells : {std::size_t{1}, std::size_t{63}, std::size_t{64},
                                  std::size_t{1000}, std::size_t{4096 + 17}}) {
    const std::size_t words = (cells + 63) / 64;
    std::vector<std::uint64_t> seen(words), free(words), seen_by_any(words);
    std::vector<std::uint8_t> stamps(words * 64);
    for (auto& w : seen) w = rng() & rng();
    for (std::size_t w = 0; w < words; ++w) free[w] = seen[w] & rng() & rng();
    if (cells % 64 != 0) {  // no cell past the end is seen
      seen.back() &= (std::uint64_t{1} << (cells % 64)) - 1;
      free.back() &= seen.back();
    }
    for (auto& s : stamps) s = static_cast<std::uint8_t>(rng() % 4);
    std::vector<std::uint64_t> free_expected = free, any_expected(words, 0);
    fusion_steps::clearUnblockedScalar(stamps.data(), 2, seen.data(), free_expected.data(),
                                       any_expected.data(), 0, words);
    std::vector<std::uint8_t> states_expected(cells);
    fusion_steps::writeCellStatesScalar(seen.data(), free_expected.data(), cells,
                                        states_expected.data());
    onEveryPath([&](KernelPath) {
      std::vector<std::uint64_t> f = free, any(words, 0);
      fusion_steps::clearUnblocked(stamps.data(), 2, seen.data(), f.data(), any.data(), 0, words);
      ASSERT_EQ(f, free_expected) << cells << " cells";
      ASSERT_EQ(any, any_expected) << cells << " cells";
      std::vector<std::uint8_t> states(cells, 0xFF);
      fusion_steps::writeCellStates(seen.data(), f.data(), cells, states.data());
      ASSERT_EQ(states, states_expected) << cells << " cells";
    });
  }
}

}  // namespace
}  // namespace occmap
