#include "bench/pipeline_under_load.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <signal.h>
#include <sys/resource.h>

#include "base/clock.h"
#include "transport/lcm_bus.h"

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

long long numberAfter(const std::string& text, const std::string& label) {
  const std::size_t at = text.find(label);
  return at == std::string::npos ? -1 : std::atoll(text.c_str() + at + label.size());
}

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

}  // namespace

PipelineUnderLoad::PipelineUnderLoad(const LoadOptions& o, bool multicast, const char* program)
    : config_(o.rig == "large" ? largeConfig() : paperConfig()) {
  if (o.cameras > 0 && static_cast<std::size_t>(o.cameras) < config_.cameras.size()) {
    config_.cameras.resize(static_cast<std::size_t>(o.cameras));
  }
  std::fprintf(stderr,
               "%s: %s rig, %zu cameras of %dx%d, %dx%d cells, %.2f m columns; rendering %d "
               "frames a camera and building tables...\n",
               program, config_.name.c_str(), config_.cameras.size(), config_.width, config_.height,
               config_.map.width, config_.map.height, o.column_height_m, o.frames);
  const BenchRig bench(config_);
  std::vector<CarveTable> tables = bench.buildTables(o.column_height_m);
  std::vector<std::vector<Image>> shown(bench.cameraCount());
  for (int n = 0; n < o.frames; ++n) {
    FrameSet set = bench.render(static_cast<double>(n) / o.fps, static_cast<std::uint64_t>(n));
    for (std::size_t k = 0; k < set.size(); ++k) shown[k].push_back(std::move(set[k]));
  }

  Config daemon_config;
  daemon_config.file = program;
  daemon_config.map = config_.map;
  daemon_config.fusion.threshold = kThreshold;
  daemon_config.fusion.column_height_m = o.column_height_m;
  daemon_config.footprints.enabled = o.footprints;
  const std::string url = multicast ? kUrl : "memq://";
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

  if (multicast) {
    subscriber_ = std::make_unique<testing::ChildProcess>(
        std::vector<std::string>{OCCMAP_BINARY_DIR "/tools/occmap", "view", "--lcm-url", url,
                                 "--timeout", "30"},
        folder_ / "view");
    // It says so once subscribed: from then on it sees map 0, so that every map it misses is a
    // map lost (a fixed pause was too short for it to start on a busy machine).
    if (!subscriber_->waitForOutput("listening for maps", std::chrono::seconds(10))) {
      std::fprintf(stderr, "%s: occmap view did not subscribe within 10 s; it said:\n%s%s", program,
                   subscriber_->out().c_str(), subscriber_->err().c_str());
    }
  }
  pipeline_ = std::make_unique<Pipeline>(
      PreparedRig{Rig::assemble(std::move(daemon_config), std::move(cameras)), std::move(tables),
                  o.column_height_m},
      LcmBus::open(url));
}

long long PipelineUnderLoad::lostSoFar() {
  if (!subscriber_) return -1;
  // `occmap view` flushes each line ("... lost N" for the second that ended); only whole lines
  // are counted, and the next call starts at the first line not yet complete.
  std::FILE* out = std::fopen((folder_ / "view.out").c_str(), "r");
  if (out == nullptr) return lost_so_far_;
  if (std::fseek(out, read_offset_, SEEK_SET) == 0) {
    char line[512];
    while (std::fgets(line, sizeof line, out) != nullptr) {
      const std::size_t length = std::strlen(line);
      if (length == 0 || line[length - 1] != '\n') break;  // not yet whole (or overlong)
      read_offset_ += static_cast<long>(length);
      if (const char* at = std::strstr(line, "  lost ")) lost_so_far_ += std::atoll(at + 7);
    }
  }
  std::fclose(out);
  return lost_so_far_;
}

bool PipelineUnderLoad::subscriberRunning() { return subscriber_ && subscriber_->running(); }

SubscriberSummary PipelineUnderLoad::stopSubscriber() {
  SubscriberSummary summary;
  if (!subscriber_) return summary;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the last map's way over
  subscriber_->signal(SIGINT);
  subscriber_->waitExit(std::chrono::seconds(5));
  const std::string out = subscriber_->out();
  summary.lost = numberAfter(out, ", lost ");
  summary.received = numberAfter(out, "summary: received ");
  if (summary.received < 0) {
    std::fprintf(stderr, "occmap view said:\n%s%s", out.c_str(), subscriber_->err().c_str());
  }
  return summary;
}

void addLoadOptions(CLI::App& app, LoadOptions& options) {
  app.add_option("--rig", options.rig,
                 "paper (4 x 640x480 -> 512x512) or large (8 x 1920x1080 -> 1024x1024)")
      ->check(CLI::IsMember({"paper", "large"}))
      ->capture_default_str();
  app.add_option("--fps", options.fps, "Every camera's frame rate")->capture_default_str();
  app.add_option("--frames", options.frames, "Frames rendered per camera, shown in a loop")
      ->check(CLI::Range(1, 600))
      ->capture_default_str();
  app.add_option("--column-height", options.column_height_m, "column_height_m (0: floor mode)")
      ->capture_default_str();
  app.add_option("--cameras", options.cameras, "Use only the first K cameras of the rig");
  app.add_flag("!--no-footprints", options.footprints,
               "Without the footprints thread (people found and followed beside the maps), to "
               "see what it costs");
}

double cpuSeconds() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) / 1e6;
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

}  // namespace occmap::bench
