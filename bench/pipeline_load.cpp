// The pipeline under load: occmapd's own Pipeline (capture threads, rings, fusion, the LCM thread)
// fed by simulated cameras whose frames were rendered before the clock starts, so that only what
// the daemon does is measured: copying each frame in and marking its changed pixels, fusing,
// encoding and publishing. K cameras at F fps for S seconds, maps over UDP multicast in a private
// network namespace to a subscriber in another process (`occmap view`). It reports the latency
// from the arrival of a map's newest frame to the return of its publish (p50, p99, max), the CPU
// time per map and the share of one core it took, frames dropped and maps the subscriber lost.
//
//   pipeline_load --rig paper --fps 60 --seconds 20      4 x 640x480, 512 x 512 cells
//   pipeline_load --rig large --fps 30 --seconds 20      8 x 1920x1080, 1024 x 1024 cells
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <sys/resource.h>

#include "bench/bench_rig.h"
#include "daemon/pipeline.h"
#include "tests/child_process.h"
#include "tests/network_namespace.h"
#include "tests/temporary_folder.h"

namespace occmap::bench {
namespace {

// A camera that shows frames rendered in advance, in a loop, at the rate the pipeline paces it
// to (it is not live: the capture thread keeps the rate, as for sim:// and files://).
class PrerenderedSource final : public FrameSource {
 public:
  explicit PrerenderedSource(std::vector<Image> frames) : frames_(std::move(frames)) {}
  int width() const override { return frames_.front().width(); }
  int height() const override { return frames_.front().height(); }
  Status read(Frame& frame) override {
    frame.image = frames_[next_ % frames_.size()].view();
    frame.sequence = next_++;
    frame.capture_time_us = hostTimeMicroseconds();
    return Status::kFrame;
  }

 private:
  std::vector<Image> frames_;
  std::uint64_t next_ = 0;
};

double cpuSeconds() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) / 1e6;
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

long long numberAfter(const std::string& text, const std::string& label) {
  const std::size_t at = text.find(label);
  return at == std::string::npos ? -1 : std::atoll(text.c_str() + at + label.size());
}

struct Options {
  std::string rig = "paper";
  double fps = 60;
  double seconds = 20;
  int frames = 30;
  double column_height_m = 0.3;
  int cameras = 0;  // 0: the rig's own count
};

int run(const Options& o) {
  const std::string& no_network = testing::enterPrivateNetwork();
  const bool multicast = no_network.empty();
  if (!multicast) {
    std::fprintf(stderr,
                 "pipeline_load: %s\n  maps go to memq:// instead; no subscriber counts losses\n",
                 no_network.c_str());
  }
  BenchConfig config = o.rig == "large" ? largeConfig() : paperConfig();
  if (o.cameras > 0 && static_cast<std::size_t>(o.cameras) < config.cameras.size()) {
    config.cameras.resize(static_cast<std::size_t>(o.cameras));
  }
  std::fprintf(stderr,
               "pipeline_load: %s rig, %zu cameras of %dx%d, %dx%d cells, %.2f m columns; "
               "rendering %d frames a camera and building tables...\n",
               config.name.c_str(), config.cameras.size(), config.width, config.height,
               config.map.width, config.map.height, o.column_height_m, o.frames);
  const BenchRig bench(config);
  std::vector<CarveTable> tables = bench.buildTables(o.column_height_m);
  std::vector<std::vector<Image>> shown(bench.cameraCount());
  for (int n = 0; n < o.frames; ++n) {
    FrameSet set = bench.render(static_cast<double>(n) / o.fps, static_cast<std::uint64_t>(n));
    for (std::size_t k = 0; k < set.size(); ++k) shown[k].push_back(std::move(set[k]));
  }

  Config daemon_config;
  daemon_config.file = "pipeline_load";
  daemon_config.map = config.map;
  daemon_config.fusion.threshold = kThreshold;
  daemon_config.fusion.column_height_m = o.column_height_m;
  const std::string url = multicast ? "udpm://239.255.76.67:7667?ttl=0" : "memq://";
  daemon_config.transport.lcm_url = url;
  std::vector<RigCamera> cameras;
  for (std::size_t k = 0; k < bench.cameraCount(); ++k) {
    CameraConfig entry;
    entry.name = "c" + std::to_string(k);
    entry.source = "prerendered://" + entry.name;
    entry.fps = o.fps;
    daemon_config.cameras.push_back(entry);
    RigCamera camera;
    camera.name = entry.name;
    camera.camera = std::make_unique<Camera>(bench.renderer(k).camera());
    camera.background = bench.background(k);
    camera.floor_mask = bench.renderer(k).floorMask();
    camera.threshold = kThreshold;
    camera.source = std::make_unique<PrerenderedSource>(std::move(shown[k]));
    cameras.push_back(std::move(camera));
  }

  testing::TemporaryFolder folder;
  std::unique_ptr<testing::ChildProcess> subscriber;
  if (multicast) {
    subscriber = std::make_unique<testing::ChildProcess>(
        std::vector<std::string>{OCCMAP_BINARY_DIR "/tools/occmap", "view", "--lcm-url", url,
                                 "--timeout", "30"},
        folder / "view");
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // subscribed before map 0
  }
  Pipeline pipeline(Rig::assemble(std::move(daemon_config), std::move(cameras)), std::move(tables));
  const double cpu_before = cpuSeconds();
  const auto wall_before = std::chrono::steady_clock::now();
  pipeline.start();
  std::this_thread::sleep_for(std::chrono::duration<double>(o.seconds));
  pipeline.stop();
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_before).count();
  const double cpu_s = cpuSeconds() - cpu_before;
  long long lost = -1;
  if (subscriber) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    subscriber->signal(SIGINT);
    subscriber->waitExit(std::chrono::seconds(5));
    lost = numberAfter(subscriber->out(), ", lost ");
    const long long received = numberAfter(subscriber->out(), "summary: received ");
    if (received < 0)
      std::fprintf(stderr, "occmap view said:\n%s%s", subscriber->out().c_str(),
                   subscriber->err().c_str());
  }
  const std::uint64_t maps = pipeline.mapsPublished();
  const TimeHistogram& latency = pipeline.publishLatency();
  const TimeHistogram& fusion = pipeline.fusionTimes();
  const double cpu_ms_per_map = maps > 0 ? cpu_s * 1e3 / static_cast<double>(maps) : 0.0;
  std::printf(
      "%s: %zu x %dx%d at %g fps for %.1f s: %llu maps (%.1f/s), %llu skipped; newest frame "
      "to published p50 %.3f ms, p99 %.3f ms, max %.3f ms; fusion p50 %.3f ms, p99 %.3f "
      "ms; CPU %.3f ms a map, %.1f %% of one core; frames dropped %llu; maps lost by the "
      "subscriber %lld\n",
      config.name.c_str(), bench.cameraCount(), config.width, config.height, o.fps, wall_s,
      static_cast<unsigned long long>(maps), static_cast<double>(maps) / wall_s,
      static_cast<unsigned long long>(pipeline.mapsSkipped()), latency.percentileMs(0.5),
      latency.percentileMs(0.99), latency.maxMs(), fusion.percentileMs(0.5),
      fusion.percentileMs(0.99), cpu_ms_per_map, 100.0 * cpu_s / wall_s,
      static_cast<unsigned long long>(pipeline.framesDropped()), lost);
  std::printf(
      "{\"pipeline\":\"%s\",\"cameras\":%zu,\"fps\":%g,\"seconds\":%.1f,\"maps\":%llu,"
      "\"latency_p50_ms\":%.3f,\"latency_p99_ms\":%.3f,\"latency_max_ms\":%.3f,"
      "\"cpu_ms_per_map\":%.3f,\"cpu_share_of_core\":%.3f,\"frames_dropped\":%llu,"
      "\"maps_lost\":%lld}\n",
      config.name.c_str(), bench.cameraCount(), o.fps, wall_s,
      static_cast<unsigned long long>(maps), latency.percentileMs(0.5), latency.percentileMs(0.99),
      latency.maxMs(), cpu_ms_per_map, cpu_s / wall_s,
      static_cast<unsigned long long>(pipeline.framesDropped()), lost);
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
  app.add_option("--rig", options.rig,
                 "paper (4 x 640x480 -> 512x512) or large (8 x 1920x1080 "
                 "-> 1024x1024)")
      ->check(CLI::IsMember({"paper", "large"}))
      ->capture_default_str();
  app.add_option("--fps", options.fps, "Every camera's frame rate")->capture_default_str();
  app.add_option("--seconds", options.seconds, "How long to run")->capture_default_str();
  app.add_option("--frames", options.frames, "Frames rendered per camera, shown in a loop")
      ->check(CLI::Range(1, 600))
      ->capture_default_str();
  app.add_option("--column-height", options.column_height_m, "column_height_m (0: floor mode)")
      ->capture_default_str();
  app.add_option("--cameras", options.cameras, "Use only the first K cameras of the rig");
  CLI11_PARSE(app, argc, argv);
  return occmap::bench::run(options);
}
