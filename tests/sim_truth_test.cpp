// Fusion against the simulator's ground truth: the whole chain (lens model, stream mapping, carve
// tables, the difference and the fusion) agrees with what is really in the room.
//
// The tolerance, exactly: a camera judges a cell through the one pixel its centre falls in, and
// renders that pixel by the ray through the pixel's centre. Where an outline in the image (of an
// object, a shelf or a wall) passes between the cell centre's image and that pixel's centre, the
// pixel and the cell disagree. Such cells, "cut by an edge" in some camera, are exempt; so are
// cells that an object's footprint covers only in part. Everything else must hold without
// exception, and the exempt share is bounded so that the exemption cannot swallow a real fault.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <optional>

#include <gtest/gtest.h>

#include "capture/sim/renderer.h"
#include "core/carve_table.h"
#include "core/reference_fusion.h"

namespace occmap {
namespace {

struct RoomRig {
  std::unique_ptr<sim::Scene> scene = sim::makeScene("room");
  std::vector<std::unique_ptr<sim::Renderer>> renderers;
  MapGeometry map{-0.62, -1.87, 0.02, 512, 512};  // the room, centred on the default 512 x 512 map

  RoomRig() {
    for (std::size_t k = 0; k < scene->cameras().size(); ++k) {
      auto model = std::make_shared<TsaiCamera>(scene->cameras()[k].calibration);
      renderers.push_back(std::make_unique<sim::Renderer>(
          *scene, Camera(model, LengthUnit::kMillimetre, 640, 480), static_cast<int>(k)));
    }
  }
  std::vector<const sim::Renderer*> views() const {
    std::vector<const sim::Renderer*> out;
    for (const auto& r : renderers) out.push_back(r.get());
    return out;
  }
};

RoomRig& rig() {
  static RoomRig instance;
  return instance;
}

struct Frames {
  std::vector<Image> live, object_pixels;
};

Frames render(double t, std::uint64_t frame_number) {
  Frames frames;
  const auto objects = rig().scene->objectsAt(t);
  for (const auto& renderer : rig().renderers) {
    frames.live.emplace_back();
    frames.object_pixels.emplace_back();
    renderer->render(objects, frame_number, frames.live.back(), &frames.object_pixels.back());
  }
  return frames;
}

OccupancyMap fuse(const std::vector<CarveTable>& tables, const Frames& frames) {
  std::vector<CameraFrame> cameras;
  for (std::size_t k = 0; k < tables.size(); ++k) {
    cameras.push_back(
        {&tables[k], frames.live[k].view(), rig().renderers[k]->background().view(), 20});
  }
  return fuseReference(rig().map, cameras);
}

std::vector<CarveTable> tables(double column_height_m) {
  std::vector<CarveTable> out;
  for (const auto& renderer : rig().renderers) {
    out.push_back(buildCarveTable(renderer->camera(), rig().map, column_height_m,
                                  renderer->floorMask().view()));
  }
  return out;
}

// Whether camera k's pixel p shows the floor with nothing in front of it.
bool pixelClear(const Frames& frames, std::size_t k, int p) {
  const int width = rig().renderers[k]->camera().streamWidth();
  return rig().renderers[k]->floorMask().at(p % width, p / width) != 0 &&
         frames.object_pixels[k].at(p % width, p / width) == 0;
}

double percent(std::size_t part, std::size_t whole) {
  return 100.0 * static_cast<double>(part) / static_cast<double>(whole);
}

// The renderer draws the empty room in passes (the room's faces, then each piece of furniture over
// its projected bounds only); pixel for pixel that must be the nearest static surface along the
// pixel's ray, as Scene::castStatic finds it by testing everything.
TEST(SimulatedRoom, TheEmptyViewIsTheNearestStaticSurfaceOfEveryPixel) {
  const sim::Scene& scene = *rig().scene;
  for (const auto& renderer : rig().renderers) {
    const Camera& camera = renderer->camera();
    const Eigen::Vector3d centre = camera.centreMetres();
    std::size_t furniture_pixels = 0;
    for (int v = 0; v < camera.streamHeight(); ++v) {
      for (int u = 0; u < camera.streamWidth(); ++u) {
        int grey = 0, floor = 0;
        if (const std::optional<Ray> ray = camera.streamToRay(Eigen::Vector2d(u, v))) {
          const sim::Scene::Hit hit = scene.castStatic(centre, ray->direction);
          if (std::isfinite(hit.t)) {
            const double shade = scene.staticShade(centre + hit.t * ray->direction, hit.normal);
            grey = static_cast<int>(std::clamp(std::lround(shade), 0L, 255L));
            floor = hit.floor ? 255 : 0;
            furniture_pixels += scene.castRoom(centre, ray->direction).t > hit.t;
          }
        }
        ASSERT_EQ(renderer->background().at(u, v), grey) << "pixel " << u << "," << v;
        ASSERT_EQ(renderer->floorMask().at(u, v), floor) << "pixel " << u << "," << v;
      }
    }
    // Not a vacuous check: every camera of the room sees shelves.
    EXPECT_GT(furniture_pixels, 1000u);
  }
}

// The light of sim://room-lamps (a sharp patch of sun, a lamp's soft pool, a shade) scales exactly
// the floor pixels that no object hides, each by the product of every patch's gain at the point its
// ray meets the floor, as the test finds it by casting the ray itself; every other pixel keeps its
// grey level. (The renderer asks a patch only within its reach, from floor points it keeps.)
TEST(SimulatedRoom, ThePatchesOfLightScaleTheFloorWhereTheyLieAndNothingElse) {
  std::vector<sim::LightPatch> patches;
  sim::makeScene("room-lamps")->lightPatches(5.0, patches);
  ASSERT_EQ(patches.size(), 3u) << "room-lamps at 5 s: the sun, the lamp and the shade";
  const sim::Scene& scene = *rig().scene;
  const Frames frames = render(5.0, 150);
  for (std::size_t k = 0; k < frames.live.size(); ++k) {
    const sim::Renderer& renderer = *rig().renderers[k];
    const Camera& camera = renderer.camera();
    const Eigen::Vector3d centre = camera.centreMetres();
    Image lit = frames.live[k];
    renderer.light(patches, frames.object_pixels[k], lit);
    std::size_t scaled = 0, at_sharp_edges = 0;
    for (int v = 0; v < camera.streamHeight(); ++v) {
      for (int u = 0; u < camera.streamWidth(); ++u) {
        const int before = frames.live[k].at(u, v);
        int expected = before;
        const std::optional<Ray> ray = camera.streamToRay(Eigen::Vector2d(u, v));
        if (ray && frames.object_pixels[k].at(u, v) == 0) {
          const sim::Scene::Hit hit = scene.castStatic(centre, ray->direction);
          if (hit.floor) {
            const Eigen::Vector2d point = (centre + hit.t * ray->direction).head<2>();
            double gain = 1.0;
            bool sharp_edge = false;
            for (const sim::LightPatch& patch : patches) {
              gain *= patch.at(point);
              // The renderer's floor point is the test's to within a micrometre or so: at a sharp
              // edge that may fall either way.
              const Eigen::Vector2d d = (point - patch.centre).cwiseAbs();
              const double inside =
                  patch.round ? patch.half_size.x() - d.norm()
                              : std::min(patch.half_size.x() - d.x(), patch.half_size.y() - d.y());
              sharp_edge = sharp_edge || (patch.soft_m <= 0.0 && std::abs(inside) < 1e-4);
            }
            expected = static_cast<int>(std::clamp(std::round(before * gain), 0.0, 255.0));
            if (sharp_edge) {
              ++at_sharp_edges;
              continue;
            }
          }
        }
        ASSERT_NEAR(lit.at(u, v), expected, 1) << "camera " << k << " pixel " << u << "," << v;
        scaled += lit.at(u, v) != before;
      }
    }
    EXPECT_LT(at_sharp_edges, 50u) << "camera " << k;
    if (k == 0) {
      EXPECT_GT(scaled, 10000u) << "camera 0 sees the lamp's pool";
    }
  }
}

TEST(SimulatedRoom, NoiseNeverCrossesTheThresholdAndObjectsAlwaysDo) {
  // What the exact tolerance rests on: unchanged pixels differ by less than 20, objects by more.
  const Frames frames = render(6.0, 180);
  for (std::size_t k = 0; k < frames.live.size(); ++k) {
    const Image& background = rig().renderers[k]->background();
    int changed = 0;
    for (int v = 0; v < background.height(); ++v) {
      for (int u = 0; u < background.width(); ++u) {
        const int d = std::abs(frames.live[k].at(u, v) - background.at(u, v));
        if (frames.object_pixels[k].at(u, v)) {
          ASSERT_GE(d, 20) << "camera " << k << " pixel " << u << "," << v;
          ++changed;
        } else {
          ASSERT_LE(d, sim::kSensorNoiseAmplitude) << "camera " << k;
        }
      }
    }
    EXPECT_GT(changed, 1000) << "camera " << k << " should see some object at t = 6 s";
  }
}

// TruthMaker casts rays only inside each object's shadow; its clear views must be exactly every
// camera's own ray cast to every cell centre, objects and all.
TEST(SimulatedRoom, TheTruthsClearViewsAreTheRayCastsToEveryCell) {
  const sim::TruthMaker truth_maker(rig().views(), rig().map);
  std::size_t hidden = 0;
  for (const double t : {3.3, 12.1}) {
    const auto objects = rig().scene->objectsAt(t);
    const sim::GroundTruth truth = truth_maker.at(objects);
    for (int row = 0; row < rig().map.height; ++row) {
      for (int column = 0; column < rig().map.width; ++column) {
        const auto cell = static_cast<std::size_t>(rig().map.index(row, column));
        const Eigen::Vector2d c = rig().map.cellCentre(row, column);
        for (std::size_t k = 0; k < rig().renderers.size(); ++k) {
          const sim::Renderer& renderer = *rig().renderers[k];
          const bool clear = renderer.clearView(Eigen::Vector3d(c.x(), c.y(), 0.0), objects);
          ASSERT_EQ((truth.clear_view[cell] >> k & 1) != 0, clear)
              << "t " << t << " camera " << k << " cell " << cell;
          if (!clear && renderer.clearViewOfStatic(Eigen::Vector3d(c.x(), c.y(), 0.0))) ++hidden;
        }
      }
    }
  }
  EXPECT_GT(hidden, 2000u) << "the objects should hide some of the floor from the cameras";
}

TEST(SimulatedRoom, FloorCarvingAgreesWithTheTruthExceptAtEdges) {
  const std::vector<CarveTable> floor_tables = tables(0.0);
  const sim::TruthMaker truth_maker(rig().views(), rig().map);
  std::size_t clear_cells = 0, clear_exempt = 0, inside_cells = 0, inside_exempt = 0;
  std::size_t edge_cells = 0;
  for (const double t : {0.0, 2.5, 5.2, 7.9, 11.3, 14.6, 18.8}) {
    const auto frame_number = static_cast<std::uint64_t>(t * 30);
    const Frames frames = render(t, frame_number);
    const OccupancyMap map = fuse(floor_tables, frames);
    const sim::GroundTruth truth = truth_maker.at(rig().scene->objectsAt(t));
    for (std::size_t cell = 0; cell < rig().map.cellCount(); ++cell) {
      const CellState state = map.cells[cell];
      if (truth.footprint[cell] == sim::GroundTruth::kEdge) {
        ++edge_cells;
        continue;
      }
      if (truth.clear_view[cell] != 0) {
        // Some camera sees the floor at the centre clearly: FREE, unless every such camera's pixel
        // is cut by an edge.
        ++clear_cells;
        bool judged_clear = false;
        for (std::size_t k = 0; k < rig().renderers.size(); ++k) {
          if ((truth.clear_view[cell] >> k & 1) == 0) continue;
          const int p = truth_maker.centrePixel(k, cell);
          if (p >= 0 && pixelClear(frames, k, p)) judged_clear = true;
        }
        if (!judged_clear) {
          ++clear_exempt;
          continue;
        }
        ASSERT_EQ(state, CellState::kFree)
            << "t " << t << " cell " << cell << ": a camera sees it clearly, the map says not free";
      }
      if (truth.footprint[cell] == sim::GroundTruth::kInside) {
        // Under an object: never FREE, unless a camera's pixel for it shows floor past the outline.
        ++inside_cells;
        bool cut = false;
        for (std::size_t k = 0; k < rig().renderers.size(); ++k) {
          const int p = truth_maker.centrePixel(k, cell);
          if (p >= 0 && pixelClear(frames, k, p)) cut = true;
        }
        if (cut) {
          ++inside_exempt;
          continue;
        }
        ASSERT_NE(state, CellState::kFree)
            << "t " << t << " cell " << cell << ": inside an object, the map says free";
      }
    }
  }
  std::printf(
      "clear-view cells %zu, exempt %zu (%.3f %%); cells inside objects %zu, exempt %zu "
      "(%.3f %%); cells cut by a footprint edge %zu\n",
      clear_cells, clear_exempt, percent(clear_exempt, clear_cells), inside_cells, inside_exempt,
      percent(inside_exempt, inside_cells), edge_cells);
  EXPECT_GT(clear_cells, 7u * 40000u) << "the cameras should see most of the room";
  EXPECT_GT(inside_cells, 7u * 1000u) << "the objects should cover cells";
  EXPECT_LT(clear_exempt, clear_cells / 100) << "over 1 % of clear cells cut by edges";
  EXPECT_LT(inside_exempt, inside_cells / 50) << "over 2 % of object cells cut by edges";
}

TEST(SimulatedRoom, ColumnCarvingFindsEveryObject) {
  // With 0.3 m columns, every object (people, chairs, the 0.35 m robot) keeps a non-free cell, and
  // no cell wholly inside an object is ever cleared.
  const std::vector<CarveTable> column_tables = tables(0.3);
  const sim::TruthMaker truth_maker(rig().views(), rig().map);
  for (const double t : {1.0, 4.4, 9.7, 13.0, 16.6}) {
    const Frames frames = render(t, static_cast<std::uint64_t>(t * 30));
    const OccupancyMap map = fuse(column_tables, frames);
    const auto objects = rig().scene->objectsAt(t);
    const sim::GroundTruth truth = truth_maker.at(objects);
    for (std::size_t i = 0; i < objects.size(); ++i) {
      std::size_t kept = 0;
      for (const int cell : truth.object_cells[i]) {
        if (map.cells[static_cast<std::size_t>(cell)] != CellState::kFree) ++kept;
      }
      EXPECT_EQ(kept, truth.object_cells[i].size())
          << "t " << t << ": " << sim::objectKindName(objects[i].kind) << " " << i << " has "
          << truth.object_cells[i].size() - kept << " cleared cells inside it";
      EXPECT_GT(truth.object_cells[i].size(), 0u);
    }
  }
}

}  // namespace
}  // namespace occmap
