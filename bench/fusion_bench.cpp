// The fusion kernels against the paper's loop, the memory bound and the kernel they replaced, at
// the paper's configuration and a large one, each warm (one frame set, over and over) and cold (a
// rotation through more frame sets than the last-level cache holds, as live frames arrive). Every
// kernel's map is checked equal to the reference fusion before it is timed; the run stops if one
// is not. docs/performance.md describes the cases and shows a run.
//
// The last lines printed are one JSON object per configuration and mode, cold figures, for
// scripts/bench. Rates are maps per second of CPU time on one core (the machine may be shared).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <benchmark/benchmark.h>
#include <hwy/targets.h>
#include <unistd.h>

#include "bench/baselines.h"
#include "bench/bench_rig.h"
#include "bench/json_line.h"
#include "bench/previous_kernel.h"
#include "core/changed_pixels.h"
#include "core/footprints.h"
#include "core/fusion_kernel.h"
#include "core/reference_fusion.h"

namespace occmap::bench {
namespace {

// The last-level cache's size: sysconf, else the highest cache level sysfs lists for cpu0.
std::size_t lastLevelCacheBytes() {
  const long l3 = ::sysconf(_SC_LEVEL3_CACHE_SIZE);
  if (l3 > 0) return static_cast<std::size_t>(l3);
  std::size_t best = 0;
  int best_level = 0;
  for (int index = 0; index < 8; ++index) {
    const std::string dir = "/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(index);
    std::ifstream level_file(dir + "/level"), size_file(dir + "/size");
    int level = 0;
    std::string size;
    if (!(level_file >> level) || !(size_file >> size)) continue;
    std::size_t bytes = std::stoul(size);
    if (size.back() == 'K') bytes <<= 10;
    if (size.back() == 'M') bytes <<= 20;
    if (level >= best_level) best_level = level, best = bytes;
  }
  return best > 0 ? best : std::size_t{64} << 20;
}

std::vector<ImageView> views(const FrameSet& frames) {
  std::vector<ImageView> v;
  for (const Image& image : frames) v.push_back(image.view());
  return v;
}

// Enough copies of `distinct` things of `bytes` each that a rotation through them streams twice
// the last-level cache.
std::size_t coldCopies(std::size_t bytes, std::size_t distinct) {
  return std::max(distinct, 2 * lastLevelCacheBytes() / bytes + 1);
}

struct Mode {
  std::string name;
  double column_height_m = 0;
  std::unique_ptr<FusionKernel> kernel;
  std::unique_ptr<PreviousKernel> previous;  // the "before"
  std::size_t table_bytes = 0;
};

// One configuration's rig, frame sets, masks and kernels, built on first use; the other
// configuration's are let go first (each holds a few GB).
struct ConfigData {
  std::unique_ptr<BenchRig> rig;
  std::vector<FrameSet> distinct;  // distinct moments of the scene
  std::vector<FrameSet> rotation;  // copies of them, more than the LLC holds
  std::vector<std::vector<ImageView>> rotation_views;
  // The same rotation in a dimmer light (x 0.8: a cloud, the camera's exposure), made on first
  // use: in constant light the model's correction is skipped (a gain within 0.2 % of 1 changes no
  // grey level), while in a building's light it runs at nearly every frame.
  std::vector<FrameSet> dim_rotation;
  std::vector<std::vector<ImageView>> dim_rotation_views;
  std::vector<ImageView> backgrounds;
  std::size_t mask_bytes = 0;                            // one camera's changed mask
  std::vector<std::vector<std::uint8_t>> mask_rotation;  // each: every camera's mask, in a row
  std::vector<std::vector<std::int32_t>> paper_tables;
  std::map<std::string, Mode> modes;
  double changed_share = 0;
};

std::unique_ptr<ConfigData> current;
std::string current_name;

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "fusion_bench: %s\n", what.c_str());
  std::exit(2);
}

ConfigData& configData(const std::string& name) {
  if (current && current_name == name) return *current;
  current.reset();
  current_name = name;
  auto data = std::make_unique<ConfigData>();
  data->rig = std::make_unique<BenchRig>(name == "paper" ? paperConfig() : largeConfig());
  const BenchRig& rig = *data->rig;
  const std::size_t distinct = name == "paper" ? 8 : 4;
  for (std::size_t d = 0; d < distinct; ++d) {
    data->distinct.push_back(rig.render(1.0 + 2.3 * static_cast<double>(d), d));
    data->changed_share += rig.changedShare(data->distinct.back()) / static_cast<double>(distinct);
  }
  for (std::size_t k = 0; k < rig.cameraCount(); ++k) {
    data->backgrounds.push_back(rig.background(k).view());
  }
  const std::size_t set_bytes =
      rig.cameraCount() * static_cast<std::size_t>(rig.config().width * rig.config().height);
  const std::size_t copies = coldCopies(set_bytes, distinct);
  data->rotation.reserve(copies);
  for (std::size_t i = 0; i < copies; ++i) data->rotation.push_back(data->distinct[i % distinct]);
  for (const FrameSet& frames : data->rotation) data->rotation_views.push_back(views(frames));
  // Masks for the fusion alone, as the capture threads leave them.
  data->mask_bytes = changedMaskBytes(rig.config().width, rig.config().height);
  std::vector<std::vector<std::uint8_t>> distinct_masks;
  for (const FrameSet& frames : data->distinct) {
    std::vector<std::uint8_t> masks(data->mask_bytes * rig.cameraCount());
    for (std::size_t k = 0; k < rig.cameraCount(); ++k) {
      markChangedPixels(frames[k].view(), data->backgrounds[k], kThreshold,
                        masks.data() + k * data->mask_bytes);
    }
    distinct_masks.push_back(std::move(masks));
  }
  const std::size_t mask_copies = coldCopies(data->mask_bytes * rig.cameraCount(), distinct);
  for (std::size_t i = 0; i < mask_copies; ++i) {
    data->mask_rotation.push_back(distinct_masks[i % distinct]);
  }
  data->paper_tables = rig.paperTables();
  std::fprintf(stderr,
               "%s: %zu x %dx%d -> %dx%d cells of %.0f mm; %.1f %% of pixels changed; cold: %zu "
               "frame sets of %.1f MB, %zu mask sets (LLC %.0f MiB); SIMD target %s\n",
               name.c_str(), rig.cameraCount(), rig.config().width, rig.config().height,
               rig.config().map.width, rig.config().map.height, rig.config().map.cell_size_m * 1e3,
               100.0 * data->changed_share, copies, static_cast<double>(set_bytes) / 1e6,
               mask_copies, static_cast<double>(lastLevelCacheBytes()) / 1048576.0,
               fusionSimdTarget().c_str());
  current = std::move(data);
  return *current;
}

// The kernel of a mode, checked against the reference fusion on every distinct frame set.
Mode& mode(ConfigData& data, const std::string& name) {
  auto found = data.modes.find(name);
  if (found != data.modes.end()) return found->second;
  Mode m{name, name == "floor" ? 0.0 : 0.3, nullptr, nullptr, 0};
  const std::vector<CarveTable> tables = data.rig->buildTables(m.column_height_m);
  m.kernel = std::make_unique<FusionKernel>(tables);
  m.previous = std::make_unique<PreviousKernel>(tables);
  m.table_bytes = m.kernel->tableBytes();
  const MapGeometry& map = data.rig->config().map;
  std::vector<CellState> fast(map.cellCount());
  for (std::size_t d = 0; d < data.distinct.size(); ++d) {
    std::vector<CameraFrame> frames;
    std::vector<std::vector<std::uint8_t>> masks;
    std::vector<const std::uint8_t*> changed;
    for (std::size_t k = 0; k < tables.size(); ++k) {
      frames.push_back({&tables[k], data.distinct[d][k].view(), data.backgrounds[k], kThreshold});
      masks.emplace_back(data.mask_bytes);
      markChangedPixels(data.distinct[d][k].view(), data.backgrounds[k], kThreshold,
                        masks.back().data());
      changed.push_back(masks.back().data());
    }
    const std::vector<CellState> expected = fuseReference(map, frames).cells;
    m.kernel->fuse(changed, fast);
    if (fast != expected) {
      fail(current_name + "/" + name + ": the kernel's map differs from the reference fusion's " +
           "on frame set " + std::to_string(d) + "; not timing it");
    }
    for (std::size_t k = 0; k < tables.size(); ++k) {
      masks[k].resize(static_cast<std::size_t>(tables[k].imageWidth()) *
                      static_cast<std::size_t>(tables[k].imageHeight()));
      PreviousKernel::markChangedPixels(data.distinct[d][k].view(), data.backgrounds[k], kThreshold,
                                        masks[k].data());
      changed[k] = masks[k].data();
    }
    m.previous->fuse(changed, fast);
    if (fast != expected) {
      fail(current_name + "/" + name + ": the previous kernel's map differs from the reference " +
           "fusion's on frame set " + std::to_string(d) + "; not timing it");
    }
  }
  std::fprintf(stderr,
               "%s/%s: both kernels equal the reference on %zu frame sets; tables %.1f MB\n",
               current_name.c_str(), name.c_str(), data.distinct.size(),
               static_cast<double>(m.table_bytes) / 1e6);
  return data.modes.emplace(name, std::move(m)).first->second;
}

void finish(benchmark::State& state) {
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

void paperLoopCase(benchmark::State& state, const std::string& config, bool cold) {
  ConfigData& data = configData(config);
  std::vector<std::uint8_t> map(data.rig->config().map.cellCount());
  std::size_t i = 0;
  for (auto _ : state) {
    paperLoop(data.rotation_views[i], data.backgrounds, data.paper_tables, kThreshold, map);
    benchmark::DoNotOptimize(map.data());
    benchmark::ClobberMemory();
    if (cold && ++i == data.rotation.size()) i = 0;
  }
  finish(state);
}

void memoryBoundCase(benchmark::State& state, const std::string& config, bool cold) {
  ConfigData& data = configData(config);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(memoryBound(data.rotation_views[i], data.backgrounds));
    if (cold && ++i == data.rotation.size()) i = 0;
  }
  finish(state);
}

// The product: every camera's difference (the capture threads' share) and the fusion, on one core.
void kernelCase(benchmark::State& state, const std::string& config, const std::string& mode_name,
                bool cold) {
  ConfigData& data = configData(config);
  FusionKernel& kernel = *mode(data, mode_name).kernel;
  const std::size_t cameras = data.backgrounds.size();
  std::vector<std::vector<std::uint8_t>> masks(cameras, std::vector<std::uint8_t>(data.mask_bytes));
  std::vector<const std::uint8_t*> changed;
  changed.reserve(cameras);
  for (const auto& mask : masks) changed.push_back(mask.data());
  std::vector<CellState> out(data.rig->config().map.cellCount());
  std::size_t i = 0;
  for (auto _ : state) {
    for (std::size_t k = 0; k < cameras; ++k) {
      kernel.markChangedPixels(k, data.rotation_views[i][k], data.backgrounds[k], kThreshold,
                               masks[k].data());
    }
    kernel.fuse(changed, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    if (cold && ++i == data.rotation.size()) i = 0;
  }
  finish(state);
}

// The capture threads' share alone: every camera's difference into its changed mask.
void differenceCase(benchmark::State& state, const std::string& config,
                    const std::string& mode_name, bool cold) {
  ConfigData& data = configData(config);
  const FusionKernel& kernel = *mode(data, mode_name).kernel;
  const std::size_t cameras = data.backgrounds.size();
  std::vector<std::vector<std::uint8_t>> masks(cameras, std::vector<std::uint8_t>(data.mask_bytes));
  std::size_t i = 0;
  for (auto _ : state) {
    for (std::size_t k = 0; k < cameras; ++k) {
      kernel.markChangedPixels(k, data.rotation_views[i][k], data.backgrounds[k], kThreshold,
                               masks[k].data());
    }
    benchmark::DoNotOptimize(masks.back().data());
    benchmark::ClobberMemory();
    if (cold && ++i == data.rotation.size()) i = 0;
  }
  finish(state);
}

// The frame sets of `data`'s rotation in a light of 0.8, made once.
const std::vector<std::vector<ImageView>>& dimRotationViews(ConfigData& data) {
  if (data.dim_rotation_views.empty()) {
    constexpr double kDim = 0.8;
    std::vector<FrameSet> dim_distinct;
    for (const FrameSet& frames : data.distinct) {
      FrameSet dim;
      for (const Image& image : frames) {
        Image out(image.width(), image.height());
        for (int v = 0; v < image.height(); ++v) {
          for (int u = 0; u < image.width(); ++u) {
            out.at(u, v) = static_cast<std::uint8_t>(std::lround(kDim * image.at(u, v)));
          }
        }
        dim.push_back(std::move(out));
      }
      dim_distinct.push_back(std::move(dim));
    }
    data.dim_rotation.reserve(data.rotation.size());
    for (std::size_t i = 0; i < data.rotation.size(); ++i) {
      data.dim_rotation.push_back(dim_distinct[i % dim_distinct.size()]);
    }
    for (const FrameSet& frames : data.dim_rotation)
      data.dim_rotation_views.push_back(views(frames));
  }
  return data.dim_rotation_views;
}

// The capture threads' share with the light's model on (core/changed_pixels.h, as occmapd runs
// it): the gain found, the frame put in the background's light, the difference, the local light,
// the drift. With `fuse` (kernel_lit), the fusion too, on the same core: the product as occmapd
// runs it by default. With `dim`, in a light of 0.8 (dimRotationViews).
void litCase(benchmark::State& state, const std::string& config, const std::string& mode_name,
             bool cold, bool fuse, bool dim) {
  ConfigData& data = configData(config);
  const std::vector<std::vector<ImageView>>& frames =
      dim ? dimRotationViews(data) : data.rotation_views;
  FusionKernel& kernel = *mode(data, mode_name).kernel;
  const std::size_t cameras = data.backgrounds.size();
  std::vector<std::vector<std::uint8_t>> masks(cameras, std::vector<std::uint8_t>(data.mask_bytes));
  std::vector<const std::uint8_t*> changed_masks;
  for (const auto& mask : masks) changed_masks.push_back(mask.data());
  std::vector<Image> backgrounds;
  std::vector<ChangedPixels> changed;
  for (std::size_t k = 0; k < cameras; ++k) {
    const ImageView& view = data.backgrounds[k];
    Image copy(view.width, view.height);
    for (int v = 0; v < view.height; ++v) std::copy_n(view.row(v), view.width, copy.row(v));
    backgrounds.push_back(std::move(copy));
    changed.emplace_back(LightingSettings{}, data.rig->renderer(k).camera());
  }
  std::vector<CellState> out(data.rig->config().map.cellCount());
  std::size_t i = 0;
  for (auto _ : state) {
    for (std::size_t k = 0; k < cameras; ++k) {
      changed[k].mark(kernel, k, frames[i][k], backgrounds[k], kThreshold, masks[k].data(),
                      /*time_us=*/0);
    }
    if (fuse) kernel.fuse(changed_masks, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::DoNotOptimize(masks.back().data());
    benchmark::ClobberMemory();
    if (cold && ++i == data.rotation.size()) i = 0;
  }
  finish(state);
}

// Each frame set of the rotation as the fusion thread gets it: one changed-pixel mask per camera.
std::vector<std::vector<const std::uint8_t*>> maskSets(const ConfigData& data) {
  std::vector<std::vector<const std::uint8_t*>> sets(data.mask_rotation.size());
  for (std::size_t s = 0; s < sets.size(); ++s) {
    for (std::size_t k = 0; k < data.backgrounds.size(); ++k) {
      sets[s].push_back(data.mask_rotation[s].data() + k * data.mask_bytes);
    }
  }
  return sets;
}

// The fusion thread's share alone: masks as the capture threads leave them.
void fuseCase(benchmark::State& state, const std::string& config, const std::string& mode_name,
              bool cold) {
  ConfigData& data = configData(config);
  FusionKernel& kernel = *mode(data, mode_name).kernel;
  const std::vector<std::vector<const std::uint8_t*>> changed = maskSets(data);
  std::vector<CellState> out(data.rig->config().map.cellCount());
  std::size_t i = 0;
  for (auto _ : state) {
    kernel.fuse(changed[i], out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    if (cold && ++i == changed.size()) i = 0;
  }
  finish(state);
}

// The people on each map (core/footprints.h), after the fusion, on the fusion's thread: each
// mask set's map is made once beforehand, and the detection runs on the masks and map in turn.
void footprintsCase(benchmark::State& state, const std::string& config,
                    const std::string& mode_name) {
  ConfigData& data = configData(config);
  FusionKernel& kernel = *mode(data, mode_name).kernel;
  const std::vector<std::vector<const std::uint8_t*>> changed = maskSets(data);
  std::vector<std::vector<CellState>> maps(changed.size());
  for (std::size_t i = 0; i < changed.size(); ++i) {
    maps[i].resize(data.rig->config().map.cellCount());
    kernel.fuse(changed[i], maps[i]);
  }
  std::vector<Camera> cameras;
  for (std::size_t k = 0; k < data.backgrounds.size(); ++k) {
    cameras.push_back(data.rig->renderer(k).camera());
  }
  FootprintDetector detector(data.rig->config().map, cameras);
  std::size_t i = 0, found = 0;
  for (auto _ : state) {
    found += detector.detect(changed[i], maps[i]).size();
    if (++i == changed.size()) i = 0;
  }
  state.counters["detections_per_map"] =
      static_cast<double>(found) /
      static_cast<double>(std::max<std::int64_t>(1, state.iterations()));
  finish(state);
}

// The fusion thread's share as occmapd runs it: a map every 1/60 s and the rest of each period
// idle, so that between two maps the tables may leave the caches (and the core its fast states),
// as they do in the daemon; the cold cases, which run maps back to back, keep the tables in the
// last-level cache. Only the fusion is timed (manual time: the first map after each pause), the
// masks rotate as in the cold case.
// With `in_a_row` > 1 (fuse/after_pause), that many maps follow each pause back to back, each timed
// alone; the counters map1_us ... are each position's median. Were the gap the tables leaving the
// caches, the first map would pay and the second run at the cold speed; a slow approach over
// several maps is the core (its clock, its predictors) warming up again.
void pacedFuseCase(benchmark::State& state, const std::string& config, const std::string& mode_name,
                   int in_a_row) {
  ConfigData& data = configData(config);
  FusionKernel& kernel = *mode(data, mode_name).kernel;
  const std::vector<std::vector<const std::uint8_t*>> changed = maskSets(data);
  std::vector<CellState> out(data.rig->config().map.cellCount());
  constexpr auto kPeriod = std::chrono::nanoseconds(1'000'000'000 / 60);
  std::vector<std::vector<double>> took(static_cast<std::size_t>(in_a_row));
  auto next = std::chrono::steady_clock::now();
  std::size_t i = 0;
  for (auto _ : state) {
    next += kPeriod;
    std::this_thread::sleep_until(next);
    for (auto& times : took) {
      const auto began = std::chrono::steady_clock::now();
      kernel.fuse(changed[i], out);
      benchmark::DoNotOptimize(out.data());
      benchmark::ClobberMemory();
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
      if (&times == &took.front()) state.SetIterationTime(seconds);
      times.push_back(seconds * 1e6);
      if (++i == changed.size()) i = 0;
    }
  }
  if (in_a_row == 1) {
    finish(state);
    return;
  }
  for (std::size_t k = 0; k < took.size(); ++k) {
    auto& times = took[k];
    std::nth_element(times.begin(), times.begin() + static_cast<std::ptrdiff_t>(times.size() / 2),
                     times.end());
    state.counters["map" + std::to_string(k + 1) + "_us"] = times[times.size() / 2];
  }
}

// The same work with the kernel before this one: byte masks, and a pixel -> cells walk.
void previousCase(benchmark::State& state, const std::string& config, const std::string& mode_name,
                  bool cold) {
  ConfigData& data = configData(config);
  PreviousKernel& previous = *mode(data, mode_name).previous;
  const std::size_t cameras = data.backgrounds.size();
  const std::size_t pixels = static_cast<std::size_t>(data.rig->config().width) *
                             static_cast<std::size_t>(data.rig->config().height);
  std::vector<std::vector<std::uint8_t>> masks(cameras, std::vector<std::uint8_t>(pixels));
  std::vector<const std::uint8_t*> changed;
  changed.reserve(cameras);
  for (const auto& mask : masks) changed.push_back(mask.data());
  std::vector<CellState> out(data.rig->config().map.cellCount());
  std::size_t i = 0;
  for (auto _ : state) {
    for (std::size_t k = 0; k < cameras; ++k) {
      PreviousKernel::markChangedPixels(data.rotation_views[i][k], data.backgrounds[k], kThreshold,
                                        masks[k].data());
    }
    previous.fuse(changed, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    if (cold && ++i == data.rotation.size()) i = 0;
  }
  finish(state);
}

// Collects each case's median rate as the console reporter prints it.
class Collector : public benchmark::ConsoleReporter {
 public:
  // Colours only on a terminal (the library's --benchmark_color applies to its own reporter).
  Collector() : ConsoleReporter(::isatty(1) != 0 ? OO_ColorTabular : OO_Tabular) {}
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& run : runs) {
      const bool median = run.run_type == Run::RT_Aggregate && run.aggregate_name == "median";
      const bool single = run.run_type == Run::RT_Iteration && run.repetitions <= 1;
      const auto rate = run.counters.find("items_per_second");
      if ((median || single) && rate != run.counters.end()) {
        rates[run.run_name.function_name] = rate->second.value;
      }
    }
  }
  std::map<std::string, double> rates;
};

void registerAll() {
  for (const std::string config : {"paper", "large"}) {
    for (const bool cold : {false, true}) {
      const std::string temperature = cold ? "cold" : "warm";
      benchmark::RegisterBenchmark((config + "/paper_loop/" + temperature).c_str(), paperLoopCase,
                                   config, cold);
      benchmark::RegisterBenchmark((config + "/memory_bound/" + temperature).c_str(),
                                   memoryBoundCase, config, cold);
    }
    for (const std::string mode_name : {"floor", "column"}) {
      for (const bool cold : {false, true}) {
        const std::string temperature = cold ? "cold" : "warm";
        const std::string prefix = config + "/" + mode_name;
        benchmark::RegisterBenchmark((prefix + "/previous/" + temperature).c_str(), previousCase,
                                     config, mode_name, cold);
        benchmark::RegisterBenchmark((prefix + "/difference/" + temperature).c_str(),
                                     differenceCase, config, mode_name, cold);
        benchmark::RegisterBenchmark((prefix + "/difference_lit/" + temperature).c_str(), litCase,
                                     config, mode_name, cold, false, false);
        benchmark::RegisterBenchmark((config + "/" + mode_name + "/kernel/" + temperature).c_str(),
                                     kernelCase, config, mode_name, cold);
        benchmark::RegisterBenchmark(
            (config + "/" + mode_name + "/kernel_lit/" + temperature).c_str(), litCase, config,
            mode_name, cold, true, false);
        if (config == "paper") {
          benchmark::RegisterBenchmark((prefix + "/kernel_lit_dim/" + temperature).c_str(), litCase,
                                       config, mode_name, cold, true, true);
        }
        benchmark::RegisterBenchmark((config + "/" + mode_name + "/fuse/" + temperature).c_str(),
                                     fuseCase, config, mode_name, cold);
      }
      if (mode_name == "column") {
        benchmark::RegisterBenchmark((config + "/" + mode_name + "/footprints").c_str(),
                                     footprintsCase, config, mode_name);
      }
      // 120 maps at 60 Hz: two seconds a repetition.
      benchmark::RegisterBenchmark((config + "/" + mode_name + "/fuse/paced").c_str(),
                                   pacedFuseCase, config, mode_name, 1)
          ->UseManualTime()
          ->Iterations(120);
      benchmark::RegisterBenchmark((config + "/" + mode_name + "/fuse/after_pause").c_str(),
                                   pacedFuseCase, config, mode_name, 6)
          ->Iterations(120);
    }
  }
}

void printSummary(const std::map<std::string, double>& rates) {
  auto rate = [&](const std::string& name) {
    const auto found = rates.find(name);
    return found == rates.end() ? 0.0 : found->second;
  };
  // Ratios at the same temperature: against the paper's loop and against the memory bound.
  std::printf("\n  %-30s %8s %8s  %13s   %13s\n", "maps/s (median, CPU, 1 core)", "warm", "cold",
              "x paper_loop", "x memory_bound");
  std::printf("  %-30s %8s %8s  %6s %6s   %6s %6s\n", "", "", "", "warm", "cold", "warm", "cold");
  for (const std::string config : {"paper", "large"}) {
    for (const std::string row :
         {"paper_loop", "memory_bound", "floor/previous", "floor/difference",
          "floor/difference_lit", "floor/fuse", "floor/kernel", "floor/kernel_lit",
          "floor/kernel_lit_dim", "column/previous", "column/difference", "column/difference_lit",
          "column/fuse", "column/kernel", "column/kernel_lit", "column/kernel_lit_dim"}) {
      const double warm = rate(config + "/" + row + "/warm");
      const double cold = rate(config + "/" + row + "/cold");
      if (warm == 0 && cold == 0) continue;
      if (const double paced = rate(config + "/" + row + "/paced"); paced > 0) {
        std::printf("  %-30s paced at 60 Hz: %.0f maps/s, %.3f ms a map (%.2f x the cold time)\n",
                    (config + "/" + row).c_str(), paced, 1e3 / paced, cold / paced);
      }
      auto ratio = [&](double value, const std::string& base) {
        const double b = rate(config + "/" + base);
        return b > 0 ? value / b : 0.0;
      };
      std::printf("  %-30s %8.0f %8.0f  %6.2f %6.2f   %6.2f %6.2f\n", (config + "/" + row).c_str(),
                  warm, cold, ratio(warm, "paper_loop/warm"), ratio(cold, "paper_loop/cold"),
                  ratio(warm, "memory_bound/warm"), ratio(cold, "memory_bound/cold"));
    }
  }
  for (const std::string config : {"paper", "large"}) {
    for (const std::string mode_name : {"floor", "column"}) {
      const double maps = rate(config + "/" + mode_name + "/kernel/cold");
      if (maps == 0) continue;
      printJsonLine(
          {{"config", config},
           {"mode", mode_name},
           {"simd_target", fusionSimdTarget()},
           {"maps_per_s", rounded(maps, 1)},
           {"lit_maps_per_s", rounded(rate(config + "/" + mode_name + "/kernel_lit/cold"), 1)},
           // 0 where not run (the large rig has no dimmer case).
           {"lit_dim_maps_per_s",
            rounded(rate(config + "/" + mode_name + "/kernel_lit_dim/cold"), 1)},
           {"paper_loop_maps_per_s", rounded(rate(config + "/paper_loop/cold"), 1)},
           {"memory_bound_maps_per_s", rounded(rate(config + "/memory_bound/cold"), 1)}});
    }
  }
}

}  // namespace
}  // namespace occmap::bench

int main(int argc, char** argv) {
  // Medians of five repetitions unless told otherwise.
  std::vector<char*> args(argv, argv + argc);
  // The SIMD target: the best this CPU has unless --simd_target=NAME names another it runs
  // (scripts/bench runs each); --list_simd_targets prints their names.
  for (auto arg = args.begin() + 1; arg != args.end();) {
    const std::string text = *arg;
    if (text == "--list_simd_targets") {
      for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
        std::printf("%s\n", hwy::TargetName(target));
      }
      return 0;
    }
    if (text.rfind("--simd_target=", 0) != 0) {
      ++arg;
      continue;
    }
    const std::string name = text.substr(std::strlen("--simd_target="));
    std::int64_t chosen = 0;
    for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
      if (name == hwy::TargetName(target)) chosen = target;
    }
    if (chosen == 0) {
      std::fprintf(stderr,
                   "fusion_bench: this CPU does not run SIMD target %s; --list_simd_targets "
                   "says which it does\n",
                   name.c_str());
      return 2;
    }
    // Highway's way to make dynamic dispatch pick one target (named for tests, which use it too).
    hwy::SetSupportedTargetsForTest(chosen);
    arg = args.erase(arg);
  }
  std::string repetitions = "--benchmark_repetitions=5";
  std::string aggregates = "--benchmark_report_aggregates_only=true";
  std::string min_time = "--benchmark_min_time=0.3";
  auto given = [&](const char* flag) {
    return std::any_of(args.begin() + 1, args.end(), [&](const char* a) {
      return std::strncmp(a, flag, std::strlen(flag)) == 0;
    });
  };
  if (!given("--benchmark_repetitions")) args.push_back(repetitions.data());
  if (!given("--benchmark_report_aggregates_only")) args.push_back(aggregates.data());
  if (!given("--benchmark_min_time")) args.push_back(min_time.data());
  int count = static_cast<int>(args.size());
  benchmark::Initialize(&count, args.data());
  if (benchmark::ReportUnrecognizedArguments(count, args.data())) return 1;
  occmap::bench::registerAll();
  occmap::bench::Collector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  benchmark::Shutdown();
  occmap::bench::printSummary(collector.rates);
  return 0;
}
