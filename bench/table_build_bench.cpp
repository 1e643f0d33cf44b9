// Carve-table builds for the paper's configuration (examples/sim-room.yaml: four 640x480 cameras,
// a 512 x 512 map of 2 cm cells, floor masks), the way occmapd builds them at start and on a
// reload: Rig::buildTables, every camera, wall time, and with the fusion's own tables built from
// them, all a reload waits for (issue 5: under 0.5 s with 0.3 m columns).
// Beside it, one camera's table by the fast build and by the reference build, on one core, and
// all four by the reference one after another, as Rig::buildTables did before.
//
// Before anything is timed, every camera's fast table is checked equal to the reference table,
// in floor and in column mode; the run stops if one is not.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "config/config.h"
#include "config/rig.h"
#include "core/carve_table.h"
#include "core/fusion_kernel.h"

namespace occmap::bench {
namespace {

constexpr double kColumnHeightM = 0.3;  // the paper configuration's column mode

struct Paper {
  Config config;
  std::optional<Rig> rig;
};

Paper& paper() {
  static Paper p;
  return p;
}

bool sameTable(const CarveTable& a, const CarveTable& b) {
  if (a.rule() != b.rule() || a.entries() != b.entries() || a.imageWidth() != b.imageWidth() ||
      a.imageHeight() != b.imageHeight() || a.map().cellCount() != b.map().cellCount()) {
    return false;
  }
  for (std::size_t cell = 0; cell < a.map().cellCount(); ++cell) {
    const auto pa = a.pixelsOf(cell);
    const auto pb = b.pixelsOf(cell);
    if (!std::equal(pa.begin(), pa.end(), pb.begin(), pb.end())) return false;
  }
  return true;
}

// Every camera's fast table equals its reference table, in both modes.
bool checkTables() {
  Rig& rig = *paper().rig;
  for (const double h : {0.0, kColumnHeightM}) {
    const std::vector<CarveTable> tables = rig.buildTables(h);
    for (std::size_t k = 0; k < tables.size(); ++k) {
      const RigCamera& camera = rig.cameras()[k];
      const CarveTable reference =
          buildCarveTableReference(*camera.camera, paper().config.map, h, camera.floor_mask.view());
      if (!sameTable(tables[k], reference)) {
        std::fprintf(stderr,
                     "table_build_bench: camera %s, column height %g m: the fast table "
                     "differs from the reference\n",
                     camera.name.c_str(), h);
        return false;
      }
      std::fprintf(stderr, "camera %s, column height %g m: %zu entries, equal to the reference\n",
                   camera.name.c_str(), h, reference.entries());
    }
  }
  return true;
}

void rigBuildTables(benchmark::State& state, double h) {
  Rig& rig = *paper().rig;
  for (auto _ : state) {
    std::vector<CarveTable> tables = rig.buildTables(h);
    benchmark::DoNotOptimize(tables.data());
  }
}

// What a reload waits for before the new map can be fused: the carve tables, and the fusion's
// tables turned around from them (FusionKernel's constructor).
void reload(benchmark::State& state, double h) {
  Rig& rig = *paper().rig;
  for (auto _ : state) {
    const std::vector<CarveTable> tables = rig.buildTables(h);
    const FusionKernel kernel(tables);
    benchmark::DoNotOptimize(kernel.tableBytes());
  }
}

// All four by the reference, one after another: Rig::buildTables as it was.
void referenceOneAfterAnother(benchmark::State& state, double h) {
  Rig& rig = *paper().rig;
  for (auto _ : state) {
    for (const RigCamera& camera : rig.cameras()) {
      CarveTable table =
          buildCarveTableReference(*camera.camera, paper().config.map, h, camera.floor_mask.view());
      benchmark::DoNotOptimize(table.entries());
    }
  }
}

template <CarveTable (*kBuild)(const Camera&, const MapGeometry&, double, ImageView)>
void oneCamera(benchmark::State& state, double h) {
  const RigCamera& camera = paper().rig->cameras().front();
  for (auto _ : state) {
    CarveTable table = kBuild(*camera.camera, paper().config.map, h, camera.floor_mask.view());
    benchmark::DoNotOptimize(table.entries());
  }
}

void registerAll() {
  for (const double h : {kColumnHeightM, 0.0}) {
    const std::string mode = h > 0 ? "column" : "floor";
    // Wall time, as a reload waits for it; the CPU time of all threads is reported beside it.
    benchmark::RegisterBenchmark(("paper/" + mode + "/rig_build_tables").c_str(), rigBuildTables, h)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->MeasureProcessCPUTime()
        ->Repetitions(7)
        ->ReportAggregatesOnly();
    benchmark::RegisterBenchmark(("paper/" + mode + "/reload").c_str(), reload, h)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->MeasureProcessCPUTime()
        ->Repetitions(7)
        ->ReportAggregatesOnly();
    benchmark::RegisterBenchmark(("paper/" + mode + "/reference_one_after_another").c_str(),
                                 referenceOneAfterAnother, h)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->Repetitions(3)
        ->ReportAggregatesOnly();
    benchmark::RegisterBenchmark(("paper/" + mode + "/one_camera/fast").c_str(),
                                 oneCamera<buildCarveTable>, h)
        ->Unit(benchmark::kMillisecond)
        ->Repetitions(5)
        ->ReportAggregatesOnly();
    benchmark::RegisterBenchmark(("paper/" + mode + "/one_camera/reference").c_str(),
                                 oneCamera<buildCarveTableReference>, h)
        ->Unit(benchmark::kMillisecond)
        ->Repetitions(3)
        ->ReportAggregatesOnly();
  }
}

}  // namespace
}  // namespace occmap::bench

int main(int argc, char** argv) {
  using namespace occmap;
  using namespace occmap::bench;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 2;
  try {
    paper().config = loadConfig(std::string(OCCMAP_SOURCE_DIR) + "/examples/sim-room.yaml");
    RigOptions options;
    options.open_live_cameras = false;
    paper().rig.emplace(Rig::open(paper().config, options));
  } catch (const std::exception& error) {
    std::fprintf(stderr, "table_build_bench: %s\n", error.what());
    return 1;
  }
  if (!checkTables()) return 1;
  registerAll();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
