// The pipeline under load: occmapd's own Pipeline (capture threads, newest-frame buffers, fusion,
// the publisher thread) fed by simulated cameras whose frames were rendered before the clock
// starts, so that only what the daemon does is measured: copying each frame in and marking its
// changed pixels, fusing, encoding and publishing. K cameras at F fps for S seconds, maps over UDP
// multicast in a private network namespace to a subscriber in another process (`occmap view`). It
// reports the latency from the arrival of a map's newest frame to the return of its publish (p50,
// p99, max), the CPU time per map and the share of one core it took, frames dropped and maps the
// subscriber lost.
//
//   pipeline_load --rig paper --fps 60 --seconds 20      4 x 640x480, 512 x 512 cells
//   pipeline_load --rig large --fps 30 --seconds 20      8 x 1920x1080, 1024 x 1024 cells
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>

#include <CLI/CLI.hpp>

#include "bench/json_line.h"
#include "bench/pipeline_under_load.h"
#include "tests/network_namespace.h"

namespace occmap::bench {
namespace {

struct Options {
  LoadOptions load;
  double seconds = 20;
};

int run(const Options& o) {
  const std::string& no_network = testing::enterPrivateNetwork();
  const bool multicast = no_network.empty();
  if (!multicast) {
    std::fprintf(stderr,
                 "pipeline_load: %s\n  maps go to memq:// instead; no subscriber counts losses\n",
                 no_network.c_str());
  }
  PipelineUnderLoad load(o.load, multicast, "pipeline_load");
  Pipeline& pipeline = load.pipeline();
  const BenchConfig& config = load.config();
  const double cpu_before = cpuSeconds();
  const auto wall_before = std::chrono::steady_clock::now();
  pipeline.start();
  std::this_thread::sleep_for(std::chrono::duration<double>(o.seconds));
  pipeline.stop();
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_before).count();
  const double cpu_s = cpuSeconds() - cpu_before;
  const long long lost = load.stopSubscriber().lost;
  const std::uint64_t maps = pipeline.mapsPublished();
  const TimeHistogram& latency = pipeline.publishLatency();
  const TimeHistogram& fusion = pipeline.fusionTimes();
  const double cpu_ms_per_map = maps > 0 ? cpu_s * 1e3 / static_cast<double>(maps) : 0.0;
  std::printf(
      "%s: %zu x %dx%d at %g fps for %.1f s: %llu maps (%.1f/s), %llu skipped; newest frame "
      "to published p50 %.3f ms, p99 %.3f ms, max %.3f ms; fusion p50 %.3f ms, p99 %.3f "
      "ms; CPU %.3f ms a map, %.1f %% of one core; frames dropped %llu; maps lost by the "
      "subscriber %lld\n",
      config.name.c_str(), load.cameraCount(), config.width, config.height, o.load.fps, wall_s,
      static_cast<unsigned long long>(maps), static_cast<double>(maps) / wall_s,
      static_cast<unsigned long long>(pipeline.mapsSkipped()), latency.percentileMs(0.5),
      latency.percentileMs(0.99), latency.maxMs(), fusion.percentileMs(0.5),
      fusion.percentileMs(0.99), cpu_ms_per_map, 100.0 * cpu_s / wall_s,
      static_cast<unsigned long long>(pipeline.framesDropped()), lost);
  printJsonLine({{"pipeline", config.name},
                 {"cameras", load.cameraCount()},
                 {"fps", o.load.fps},
                 {"seconds", rounded(wall_s, 1)},
                 {"maps", maps},
                 {"latency_p50_ms", rounded(latency.percentileMs(0.5), 3)},
                 {"latency_p99_ms", rounded(latency.percentileMs(0.99), 3)},
                 {"latency_max_ms", rounded(latency.maxMs(), 3)},
                 {"cpu_ms_per_map", rounded(cpu_ms_per_map, 3)},
                 {"cpu_share_of_core", rounded(cpu_s / wall_s, 3)},
                 {"frames_dropped", pipeline.framesDropped()},
                 {"maps_lost", lost}});
  return 0;
}

}  // namespace
}  // namespace occmap::bench

int main(int argc, char** argv) {
  occmap::bench::Options options;
  CLI::App app(
      "pipeline_load: occmapd's pipeline under load, on simulated cameras rendered beforehand.\n"
      "Reports the latency from a map's newest frame arriving to its publish returning (p50, "
      "p99, max), CPU time per map and share of one core, frames dropped, and maps a subscriber "
      "in another process (occmap view) lost. Runs in a private network namespace (root); "
      "without one the maps go to memq:// and losses are not counted.",
      "pipeline_load");
  occmap::bench::addLoadOptions(app, options.load);
  app.add_option("--seconds", options.seconds, "How long to run")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  return occmap::bench::run(options);
}
