// The people on the maps as occmapd finds them (issue 14: "detection, tracking and zones <= 2 ms a
// map on one core for the paper's rig and for Terrace, no allocation per map"): per map, fusion's
// share (the zones' states, the masks and map copied for the footprints thread) and the footprints
// thread's (detection and tracking), run one after the other on one core, on a continuous
// sequence of real maps so that the tracker follows what it would follow live:
//   room         the paper's rig (below) with the room's own two people walking, two chairs
//                pushed about and the robot (sim://room, the demo's scene), 300 maps
//   room-crowd   the paper's rig (four 640 x 480 cameras, 512 x 512 cells of 2 cm, 0.3 m columns)
//                with twelve people crossing, two chairs and the robot (sim://room-crowd), 300 maps
//   terrace      EPFL Terrace's four 360 x 288 cameras on 300 x 440 cells
//   (examples/epfl-terrace.yaml),
//                the 94 moments of the crowd set in ../shared/data, a second apart (skipped when
//                it is absent)
// Each with one zone over the middle of the floor. Counters: footprints and tracks per map, and
// operator new calls per map once every map of the sequence has been through the stage once.
// And room/replace-camera: a camera re-posed after a knock given its new boxes, once; and
// room/zones-replace-camera: the zones' hidden floor given its new pose, once.
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <new>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "config/config.h"
#include "config/prepared_rig.h"
#include "core/changed_pixels.h"
#include "core/fusion_kernel.h"
#include "core/zones.h"
#include "daemon/footprints_stage.h"

namespace {
std::atomic<long> allocations{0};
}  // namespace

// Every operator new of this program is counted (the daemon's stage must make none per map).
void* operator new(std::size_t size) {
  allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
// Not inlined, so that GCC sees new paired with delete and not with free (-Wmismatched-new-delete).
__attribute__((noinline)) void operator delete(void* p) noexcept { std::free(p); }
__attribute__((noinline)) void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace occmap::bench {
namespace {

// A continuous sequence of maps with the masks they were fused from.
struct Sequence {
  Config config;
  std::vector<occmap::Camera> cameras;
  std::vector<std::size_t> mask_bytes;
  std::vector<std::vector<std::vector<std::uint8_t>>> masks;  // [map][camera]
  std::vector<std::vector<CellState>> maps;
  double fps = 30.0;  // maps a second, for the tracker's clock
};

std::string readText(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The config's frames marked and fused as the daemon does, up to `limit` frame sets.
Sequence makeSequence(const std::string& yaml, const std::filesystem::path& file,
                      std::size_t limit) {
  Sequence sequence;
  sequence.config = parseConfig(yaml, file);
  PreparedRig prepared = prepareRig(sequence.config);
  std::vector<RigCamera>& cameras = prepared.rig.cameras();
  FusionKernel kernel(prepared.tables);
  std::vector<ChangedPixels> marking;
  for (const RigCamera& camera : cameras) {
    sequence.cameras.push_back(*camera.camera);
    sequence.mask_bytes.push_back(
        changedMaskBytes(camera.source->width(), camera.source->height()));
    marking.emplace_back(camera.lighting, *camera.camera);
  }
  if (sequence.config.cameras.front().fps) sequence.fps = *sequence.config.cameras.front().fps;
  std::vector<const std::uint8_t*> pointers(cameras.size());
  while (sequence.maps.size() < limit) {
    std::vector<std::vector<std::uint8_t>> masks(cameras.size());
    bool ended = false;
    for (std::size_t k = 0; k < cameras.size() && !ended; ++k) {
      Frame frame;
      if (cameras[k].source->read(frame) != FrameSource::Status::kFrame) {
        ended = true;
        break;
      }
      masks[k].assign(sequence.mask_bytes[k], 0);
      const bool counts =
          marking[k].mark(kernel, k, frame.image, cameras[k].background, cameras[k].threshold,
                          masks[k].data(), frame.capture_time_us);
      pointers[k] = counts ? masks[k].data() : nullptr;
      if (!counts) masks[k].clear();
    }
    if (ended) break;
    std::vector<CellState> map(sequence.config.map.cellCount());
    kernel.fuse(pointers, map);
    sequence.masks.push_back(std::move(masks));
    sequence.maps.push_back(std::move(map));
  }
  return sequence;
}

// strips: the boxes' bands (FootprintSettings::box_strips), 0 for the config's; 1 is the
// rectangle bounding each board (before 2026-12-07), to compare with in the same run.
void stageCase(benchmark::State& state, const Sequence* sequence, int strips) {
  const Config& config = sequence->config;
  FootprintSettings settings = config.footprints;
  if (strips > 0) settings.box_strips = strips;
  FootprintsStage stage(config.map, sequence->cameras, settings, sequence->mask_bytes);
  // One zone over the middle half of the map.
  const MapGeometry& map = config.map;
  const double x0 = map.origin_x_m + 0.25 * map.width * map.cell_size_m;
  const double x1 = map.origin_x_m + 0.75 * map.width * map.cell_size_m;
  const double y0 = map.origin_y_m + 0.25 * map.height * map.cell_size_m;
  const double y1 = map.origin_y_m + 0.75 * map.height * map.cell_size_m;
  const std::vector<ZoneSpec> specs = {{"middle", {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}}};
  // As occmapd has them: the floor hidden behind the people found on the map before counts as
  // unseen (core/hidden_floor.h).
  Zones zones(map, specs, sequence->cameras, settings, config.fusion.column_height_m);
  std::vector<ZoneStatus> zone_out(specs.size());
  std::vector<const std::uint8_t*> pointers(sequence->cameras.size());
  std::size_t i = 0, footprints = 0, tracks = 0;
  std::uint64_t fused = 0;
  long allocations_at_loop = -1;
  std::int64_t loop_maps = 0;
  std::chrono::steady_clock::duration zones_time{};  // the zones' share, on the fusion thread
  for (auto _ : state) {
    const auto& masks = sequence->masks[i];
    for (std::size_t k = 0; k < pointers.size(); ++k) {
      pointers[k] = masks[k].empty() ? nullptr : masks[k].data();
    }
    const double time_s = static_cast<double>(fused) / sequence->fps;
    const auto zones_began = std::chrono::steady_clock::now();
    const std::vector<ZoneStatus>& now =
        zones.update(sequence->maps[i], time_s, stage.foundFor(time_s, 0.1));
    zones_time += std::chrono::steady_clock::now() - zones_began;
    std::copy(now.begin(), now.end(), zone_out.begin());
    stage.offer(fused, 0, time_s, pointers, sequence->maps[i]);
    stage.findNewest();
    const FootprintsFound* found = stage.takeLatest();
    footprints += found->footprints.size();
    tracks += found->tracks.size();
    ++fused;
    if (++i == sequence->maps.size()) {
      i = 0;
      // From the second pass on: the crowd has been as large before.
      if (allocations_at_loop < 0) allocations_at_loop = allocations.load();
    }
    if (allocations_at_loop >= 0) ++loop_maps;
  }
  const long allocations_in_loop = allocations.load() - allocations_at_loop;  // before the counters
  const double maps = static_cast<double>(std::max<std::int64_t>(1, state.iterations()));
  state.counters["footprints_per_map"] = static_cast<double>(footprints) / maps;
  state.counters["tracks_per_map"] = static_cast<double>(tracks) / maps;
  state.counters["zones_us_per_map"] =
      std::chrono::duration<double, std::micro>(zones_time).count() / maps;
  state.counters["maps_in_sequence"] = static_cast<double>(sequence->maps.size());
  if (allocations_at_loop >= 0 && loop_maps > 0) {
    state.counters["allocations_per_map"] =
        static_cast<double>(allocations_in_loop) / static_cast<double>(loop_maps);
  }
}

// What a camera re-posed after a knock costs the footprints thread, once (FootprintDetector::
// replaceCamera: every candidate's board projected anew for the camera's new pose).
void replaceCameraCase(benchmark::State& state, const Sequence* sequence) {
  FootprintDetector detector(sequence->config.map, sequence->cameras, sequence->config.footprints);
  const Camera turned = sequence->cameras[1].turned({0.0, 0.0175, 0.0});  // a degree
  const long allocations_before = allocations.load();
  for (auto _ : state) detector.replaceCamera(1, turned);
  state.counters["allocations"] = static_cast<double>(allocations.load() - allocations_before);
}

// What a camera re-posed after a knock costs the zones that judge the hidden floor (the config's
// zones): its zone cells' columns in the new image, made on its capture thread (Zones::sightsOf,
// the time per iteration), then copied in on the fusion thread (replaceCamera: fusion_thread_us).
void zonesReplaceCameraCase(benchmark::State& state, const Sequence* sequence) {
  const Config& config = sequence->config;
  Zones zones(config.map, config.zones, sequence->cameras, config.footprints,
              config.fusion.column_height_m);
  const Camera turned = sequence->cameras[1].turned({0.0, 0.0175, 0.0});  // a degree
  std::chrono::steady_clock::duration fusion_time{};
  std::size_t cells = 0;
  for (auto _ : state) {
    const std::vector<HiddenFloor::Rectangle> sights = zones.sightsOf(turned);
    state.PauseTiming();
    Camera pose = turned;
    const auto began = std::chrono::steady_clock::now();
    zones.replaceCamera(1, std::move(pose), sights);
    fusion_time += std::chrono::steady_clock::now() - began;
    cells = sights.size();
    state.ResumeTiming();
  }
  state.counters["cells"] = static_cast<double>(cells);
  state.counters["fusion_thread_us"] =
      std::chrono::duration<double, std::micro>(fusion_time).count() /
      static_cast<double>(std::max<std::int64_t>(1, state.iterations()));
}

}  // namespace
}  // namespace occmap::bench

int main(int argc, char** argv) {
  using namespace occmap;
  using namespace occmap::bench;
  benchmark::Initialize(&argc, argv);
  const std::filesystem::path source = OCCMAP_SOURCE_DIR;
  std::vector<std::unique_ptr<Sequence>> sequences;
  {
    const std::filesystem::path file = source / "examples/sim-room.yaml";
    std::fprintf(stderr, "footprints_bench: rendering 300 maps of sim://room ...\n");
    sequences.push_back(std::make_unique<Sequence>(makeSequence(readText(file), file, 300)));
    benchmark::RegisterBenchmark("room/stage", stageCase, sequences.back().get(), 0);
    benchmark::RegisterBenchmark("room/stage-rectangles", stageCase, sequences.back().get(), 1);
    benchmark::RegisterBenchmark("room/replace-camera", replaceCameraCase, sequences.back().get());
    benchmark::RegisterBenchmark("room/zones-replace-camera", zonesReplaceCameraCase,
                                 sequences.back().get());
  }
  {
    const std::filesystem::path file = source / "examples/sim-room.yaml";
    const std::string yaml =
        std::regex_replace(readText(file), std::regex("sim://room/"), "sim://room-crowd/");
    std::fprintf(stderr, "footprints_bench: rendering 300 maps of sim://room-crowd ...\n");
    sequences.push_back(std::make_unique<Sequence>(makeSequence(yaml, file, 300)));
    benchmark::RegisterBenchmark("room-crowd/stage", stageCase, sequences.back().get(), 0);
    benchmark::RegisterBenchmark("room-crowd/stage-rectangles", stageCase, sequences.back().get(),
                                 1);
  }
  const std::filesystem::path terrace = source / "examples/epfl-terrace.yaml";
  const std::filesystem::path crowd = source / "../shared/data/epfl-terrace-crowd/masks";
  if (std::filesystem::exists(crowd)) {
    const std::string yaml = std::regex_replace(readText(terrace), std::regex("epfl-terrace/masks"),
                                                "epfl-terrace-crowd/masks");
    sequences.push_back(std::make_unique<Sequence>(makeSequence(yaml, terrace, 1000)));
    sequences.back()->fps = 1.0;  // the crowd set's moments are a second apart
    benchmark::RegisterBenchmark("terrace/stage", stageCase, sequences.back().get(), 0);
    benchmark::RegisterBenchmark("terrace/stage-rectangles", stageCase, sequences.back().get(), 1);
  } else {
    std::fprintf(stderr, "footprints_bench: SKIPPED terrace: %s is absent\n", crowd.c_str());
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
