#pragma once
// occmapd's own Pipeline (capture threads, newest-frame buffers, fusion thread, the publisher
// thread) fed by simulated cameras whose frames were rendered before the clock starts, so that only
// what the daemon does costs time: copying each frame in and marking its changed pixels, fusing,
// encoding, publishing. With multicast, `occmap view` in another process subscribes to the maps and
// counts those lost. Shared by bench/pipeline_load (latency, CPU) and bench/soak (memory,
// descriptors, drops).

#include <memory>
#include <string>

#include "bench/bench_rig.h"
#include "daemon/pipeline.h"
#include "tests/child_process.h"
#include "tests/temporary_folder.h"

namespace CLI {
class App;
}

namespace occmap::bench {

struct LoadOptions {
  std::string rig = "paper";  // paper or large (bench_rig.h)
  double fps = 60;
  int frames = 30;  // rendered per camera, shown in a loop
  double column_height_m = 0.3;
  int cameras = 0;  // 0: the rig's own count
  bool footprints = true;  // the daemon's footprints thread (people found and followed)
};

// What the subscriber said when it was stopped; -1 where it said nothing readable.
struct SubscriberSummary {
  long long received = -1;
  long long lost = -1;
};

class PipelineUnderLoad {
 public:
  // Renders the frames, builds the tables, starts the subscriber (multicast only: memq:// cannot
  // leave this process) and makes the pipeline, not started. `program` names the caller in what
  // it prints. The caller has already entered its private network (tests/network_namespace.h).
  PipelineUnderLoad(const LoadOptions& options, bool multicast, const char* program);
  PipelineUnderLoad(const PipelineUnderLoad&) = delete;
  PipelineUnderLoad& operator=(const PipelineUnderLoad&) = delete;

  Pipeline& pipeline() { return *pipeline_; }
  const BenchConfig& config() const { return config_; }
  std::size_t cameraCount() const { return config_.cameras.size(); }
  bool hasSubscriber() const { return subscriber_ != nullptr; }

  // Maps the subscriber has reported lost so far, from its line a second; -1 without one. Reads
  // only what it has not read before, through a fixed buffer: a long run's sampling must not
  // grow this process's memory, which is what bench/soak measures.
  long long lostSoFar();
  // Whether the subscriber is still running (false without one).
  bool subscriberRunning();
  // After pipeline().stop(): lets the last map arrive, ends the subscriber and reads its summary.
  SubscriberSummary stopSubscriber();

 private:
  BenchConfig config_;
  testing::TemporaryFolder folder_;
  std::unique_ptr<testing::ChildProcess> subscriber_;
  std::unique_ptr<Pipeline> pipeline_;
  long long lost_so_far_ = 0;
  long read_offset_ = 0;  // of the subscriber's output: the first line not yet counted
};

// --rig, --fps, --frames, --column-height, --cameras.
void addLoadOptions(CLI::App& app, LoadOptions& options);

// This process's user + system CPU time, in seconds.
double cpuSeconds();

}  // namespace occmap::bench
