// The soak: occmapd's own Pipeline for a long run (default 10 minutes) at the paper's rig, 4 x
// 640x480 at 60 fps, on pre-rendered simulated cameras, its maps going over UDP multicast in a
// private network namespace to `occmap view` in another process, which counts the maps it lost
// (bench/pipeline_under_load.h). Every few seconds it reads this process's resident memory,
// open file descriptors and threads from /proc, and the pipeline's counters; at the end it
// prints a summary, one JSON line, and PASS or FAIL against the targets of issue 6: no frame
// dropped, no map lost, resident memory grown by less than 1 MiB and as many file descriptors
// (and threads) as after the warm-up. Exit 0 PASS, 1 FAIL, 2 bad command line, 77 skipped.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <dirent.h>
#include <unistd.h>

#include "bench/json_line.h"
#include "bench/pipeline_under_load.h"
#include "tests/network_namespace.h"

namespace occmap::bench {
namespace {

constexpr int kExitPass = 0;
constexpr int kExitFail = 1;
constexpr int kExitInvalidInput = 2;
constexpr int kExitSkipped = 77;  // CTest's SKIP_RETURN_CODE, as in tests/

struct Options {
  LoadOptions load;
  double seconds = 600;
  // Memory, descriptors and threads are compared from here on. Before it, the pipeline's
  // threads start (with their sockets and eventfds), each thread's first allocations make its
  // own malloc arena, ring slots and map buffers are faulted in as the first frames and maps land
  // in them, and code and data of the shared libraries (LCM, zstd, glib) are paged in as their
  // paths first run. Here all of that is over within the first tenth of a second (docs/soak.md).
  // 30 s also covers what comes later than the first frames (the status message every second),
  // leaves room for a busy machine on which threads start late, and is 5 % of the 10 minutes.
  double warmup = 30;
  double sample_every = 5;
  double progress_every = 0;  // 0: automatic (below)
  double max_rss_growth_kib = 1024;
  double min_rate_share = 0.95;  // of --fps, in maps/s after the warm-up
};

// What /proc says of this process at one moment.
struct ProcessSample {
  long rss_kib = -1;   // VmRSS: everything resident (anonymous, file-backed, shared memory)
  long anon_kib = -1;  // RssAnon: heap, stacks, anonymous mappings: where a leak would show
  int threads = -1;
  int fds = -1;
};

// Reads /proc through fixed buffers: the sampling must not itself grow what it measures.
ProcessSample sampleProcess() {
  ProcessSample s;
  if (std::FILE* status = std::fopen("/proc/self/status", "r")) {
    char line[256];
    auto valueAfter = [&line](const char* label, long& value) {
      const std::size_t length = std::strlen(label);
      if (std::strncmp(line, label, length) == 0) value = std::strtol(line + length, nullptr, 10);
    };
    long threads = -1;
    while (std::fgets(line, sizeof line, status) != nullptr) {
      valueAfter("VmRSS:", s.rss_kib);
      valueAfter("RssAnon:", s.anon_kib);
      valueAfter("Threads:", threads);
    }
    std::fclose(status);
    s.threads = static_cast<int>(threads);
  }
  if (DIR* dir = ::opendir("/proc/self/fd")) {
    int entries = 0;
    while (const dirent* entry = ::readdir(dir)) {
      if (entry->d_name[0] != '.') ++entries;
    }
    ::closedir(dir);
    s.fds = entries - 1;  // less the one opendir holds while it reads
  }
  return s;
}

double loadAverage() {
  double one_minute = -1;
  if (std::FILE* file = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(file, "%lf", &one_minute) != 1) one_minute = -1;
    std::fclose(file);
  }
  return one_minute;
}

// Microseconds in which some task of the machine waited for a CPU (Linux's pressure stall
// information, /proc/pressure/cpu, "some ... total="), -1 where the kernel has none. The load
// average trails by a minute; this says what a sample period was like, to tell a drop that a
// busy machine caused from one of the pipeline's own.
long long cpuPressureMicroseconds() {
  long long total = -1;
  if (std::FILE* file = std::fopen("/proc/pressure/cpu", "r")) {
    if (std::fscanf(file, "some avg10=%*f avg60=%*f avg300=%*f total=%lld", &total) != 1) {
      total = -1;
    }
    std::fclose(file);
  }
  return total;
}

// Milliseconds the hypervisor ran something else while this machine's CPUs had work (steal
// time, /proc/stat), summed over the CPUs; -1 where it cannot be read. On a virtual machine a
// stall of the whole guest shows here and nowhere else.
long long stolenMilliseconds() {
  unsigned long long fields[8] = {};
  long long stolen = -1;
  if (std::FILE* file = std::fopen("/proc/stat", "r")) {
    if (std::fscanf(file, "cpu %llu %llu %llu %llu %llu %llu %llu %llu", &fields[0], &fields[1],
                    &fields[2], &fields[3], &fields[4], &fields[5], &fields[6], &fields[7]) == 8) {
      stolen = static_cast<long long>(fields[7] * 1000 /
                                      static_cast<unsigned long long>(::sysconf(_SC_CLK_TCK)));
    }
    std::fclose(file);
  }
  return stolen;
}

struct Sample {
  double t_s = 0;
  ProcessSample process;
  std::uint64_t maps = 0;
  std::uint64_t dropped = 0;
  long long lost = 0;
  double load_average = -1;  // of the machine, over the last minute
  long long cpu_pressure_us = -1;
  long long stolen_ms = -1;
};

// Every --sample-every seconds, and exactly at the end of the warm-up and of the run.
std::vector<double> sampleTimes(const Options& o) {
  std::vector<double> times{o.warmup, o.seconds};
  for (double t = o.sample_every; t < o.seconds; t += o.sample_every) times.push_back(t);
  std::sort(times.begin(), times.end());
  times.erase(std::unique(times.begin(), times.end()), times.end());
  return times;
}

double mib(long kib) { return static_cast<double>(kib) / 1024.0; }

void printProgress(const Sample& s, const Sample* warm, double fps_window_s,
                   std::uint64_t maps_window) {
  char growth[64] = "warming up";
  if (warm != nullptr) {
    std::snprintf(growth, sizeof growth, "%+ld KiB since warm-up",
                  s.process.rss_kib - warm->process.rss_kib);
  }
  std::fprintf(stderr,
               "soak: %6.1f s  maps %7llu (%.1f/s)  dropped %llu  lost %lld  RSS %.1f MiB (%s)  "
               "fds %d  threads %d\n",
               s.t_s, static_cast<unsigned long long>(s.maps),
               fps_window_s > 0 ? static_cast<double>(maps_window) / fps_window_s : 0.0,
               static_cast<unsigned long long>(s.dropped), s.lost, mib(s.process.rss_kib), growth,
               s.process.fds, s.process.threads);
}

// Least-squares slope of resident memory over the samples from the warm-up on, KiB a minute:
// growth that the two end points could hide (a leak freed in bursts) or exaggerate (one burst).
double rssSlopeKibPerMinute(const std::vector<Sample>& samples, std::size_t from) {
  const double n = static_cast<double>(samples.size() - from);
  if (n < 2) return 0.0;
  double st = 0, sr = 0, stt = 0, str = 0;
  for (std::size_t i = from; i < samples.size(); ++i) {
    const double t = samples[i].t_s / 60.0;
    const auto r = static_cast<double>(samples[i].process.rss_kib);
    st += t;
    sr += r;
    stt += t * t;
    str += t * r;
  }
  const double denominator = n * stt - st * st;
  return denominator > 0 ? (n * str - st * sr) / denominator : 0.0;
}

int run(const Options& o) {
  const std::string& no_network = testing::enterPrivateNetwork();
  if (!no_network.empty()) {
    std::fprintf(stderr,
                 "soak: SKIPPED: %s\n  the soak counts lost maps in a subscriber in another "
                 "process, over UDP multicast in a private network namespace\n",
                 no_network.c_str());
    return kExitSkipped;
  }
  const double load_before = loadAverage();
  PipelineUnderLoad load(o.load, /*multicast=*/true, "soak");
  Pipeline& pipeline = load.pipeline();
  const BenchConfig& config = load.config();
  const std::vector<double> times = sampleTimes(o);
  std::vector<Sample> samples;
  samples.reserve(times.size());  // nothing grows while the pipeline runs but the pipeline
  // A tenth of the run, at most a minute, in whole sample periods (lines come with samples).
  const double progress_every =
      o.progress_every > 0
          ? o.progress_every
          : o.sample_every * std::ceil(std::min(o.seconds / 10, 60.0) / o.sample_every);
  std::fprintf(stderr,
               "soak: %.0f s at %zu x %dx%d, %g fps; memory and descriptors compared from %.0f s "
               "on; a line every %.0f s\n",
               o.seconds, load.cameraCount(), config.width, config.height, o.load.fps, o.warmup,
               progress_every);

  const ProcessSample at_start = sampleProcess();
  const long long pressure_at_start = cpuPressureMicroseconds();
  const long long stolen_at_start = stolenMilliseconds();
  const double cpu_before = cpuSeconds();
  const auto start = std::chrono::steady_clock::now();
  pipeline.start();
  std::size_t warm = 0;
  bool warmed = false;
  bool subscriber_gone = false;
  double next_progress = progress_every;
  for (const double t : times) {
    std::this_thread::sleep_until(start +
                                  std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(t)));
    Sample s;
    s.t_s = t;
    s.maps = pipeline.mapsPublished();
    s.dropped = pipeline.framesDropped();
    s.lost = load.lostSoFar();  // before the descriptors: it opens a file for a moment
    s.process = sampleProcess();
    s.load_average = loadAverage();
    s.cpu_pressure_us = cpuPressureMicroseconds();
    s.stolen_ms = stolenMilliseconds();
    samples.push_back(s);
    if (!subscriber_gone && !load.subscriberRunning()) {
      subscriber_gone = true;
      std::fprintf(stderr, "soak: the subscriber (occmap view) ended at %.0f s\n", t);
    }
    const Sample* baseline = warmed ? &samples[warm] : nullptr;
    if (t == o.warmup) {
      warmed = true;
      warm = samples.size() - 1;
      std::fprintf(stderr,
                   "soak: warm-up over at %.0f s: RSS %.1f MiB (%.1f MiB before start), fds %d, "
                   "threads %d\n",
                   t, mib(s.process.rss_kib), mib(at_start.rss_kib), s.process.fds,
                   s.process.threads);
    } else if (t >= next_progress || t == o.seconds) {
      const Sample previous = samples.size() > 1 ? samples[samples.size() - 2] : Sample{};
      printProgress(s, baseline, t - previous.t_s, s.maps - previous.maps);
    }
    while (next_progress <= t) next_progress += progress_every;
  }
  pipeline.stop();
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu_s = cpuSeconds() - cpu_before;
  const SubscriberSummary subscriber = load.stopSubscriber();
  const double load_after = loadAverage();

  // The figures, from the warm-up's sample to the last one (taken while the pipeline still ran,
  // so that its sockets, eventfds and threads are there in both).
  const Sample& w = samples[warm];
  const Sample& e = samples.back();
  const std::uint64_t maps = pipeline.mapsPublished();  // the map fused last is published on stop
  const std::uint64_t dropped = pipeline.framesDropped();
  const long rss_growth = e.process.rss_kib - w.process.rss_kib;
  long rss_peak = w.process.rss_kib;
  for (std::size_t i = warm; i < samples.size(); ++i) {
    rss_peak = std::max(rss_peak, samples[i].process.rss_kib);
  }
  const double slope = rssSlopeKibPerMinute(samples, warm);
  const double rate = static_cast<double>(e.maps - w.maps) / (e.t_s - w.t_s);
  const long long not_received =
      subscriber.received >= 0 ? static_cast<long long>(maps) - subscriber.received : -1;
  const TimeHistogram& latency = pipeline.publishLatency();
  const TimeHistogram& fusion = pipeline.fusionTimes();

  std::vector<std::string> failed;  // the targets missed, by name
  auto check = [&failed](bool ok, const char* name) {
    if (!ok) failed.emplace_back(name);
  };
  check(dropped == 0, "frames_dropped");
  check(subscriber.lost == 0 && not_received == 0, "maps_lost");
  check(static_cast<double>(rss_growth) < o.max_rss_growth_kib, "rss_growth");
  check(e.process.fds == w.process.fds, "fds");
  check(e.process.threads == w.process.threads, "threads");
  check(rate >= o.min_rate_share * o.load.fps, "map_rate");
  const bool pass = failed.empty();

  std::printf(
      "soak: %s rig, %zu x %dx%d at %g fps for %.1f s (warm-up %.0f s), load average %.2f -> "
      "%.2f\n",
      config.name.c_str(), load.cameraCount(), config.width, config.height, o.load.fps, wall_s,
      o.warmup, load_before, load_after);
  std::printf(
      "  maps: %llu published (%.2f/s after the warm-up), %llu skipped for a newer one, %lld "
      "received by the subscriber, %lld lost (seq gaps), %lld never received\n",
      static_cast<unsigned long long>(maps), rate,
      static_cast<unsigned long long>(pipeline.mapsSkipped()), subscriber.received, subscriber.lost,
      not_received);
  // When they went (a drop is fusion held up for the ring's 4 frames): which sample periods, and
  // how busy the machine was then, so that a failure can be told from a busy neighbour.
  std::printf("  frames dropped: %llu", static_cast<unsigned long long>(dropped));
  double busiest = 0;
  double most_pressure = -1;  // the largest share of a sample period that some task waited
  auto pressure = [&](std::size_t i) {  // share of sample period i (from the one before)
    const long long before = i > 0 ? samples[i - 1].cpu_pressure_us : pressure_at_start;
    const double period_s = samples[i].t_s - (i > 0 ? samples[i - 1].t_s : 0.0);
    return before < 0 || samples[i].cpu_pressure_us < 0
               ? -1.0
               : static_cast<double>(samples[i].cpu_pressure_us - before) / 1e6 / period_s;
  };
  for (std::size_t i = 0; i < samples.size(); ++i) {
    busiest = std::max(busiest, samples[i].load_average);
    most_pressure = std::max(most_pressure, pressure(i));
    const std::uint64_t before = i > 0 ? samples[i - 1].dropped : 0;
    if (samples[i].dropped > before) {
      const long long stolen_before = i > 0 ? samples[i - 1].stolen_ms : stolen_at_start;
      std::printf(
          "; +%llu in %.0f-%.0f s (load average %.2f, CPU pressure %.0f %%, stolen %lld ms)",
          static_cast<unsigned long long>(samples[i].dropped - before),
          i > 0 ? samples[i - 1].t_s : 0.0, samples[i].t_s, samples[i].load_average,
          100.0 * pressure(i), samples[i].stolen_ms - stolen_before);
    }
  }
  std::vector<double> pressures;  // for the median: what a period without a drop was like
  for (std::size_t i = 0; i < samples.size(); ++i) pressures.push_back(pressure(i));
  std::nth_element(pressures.begin(), pressures.begin() + pressures.size() / 2, pressures.end());
  std::printf(
      "\n  load average (1 min) at most %.2f while it ran; CPU pressure (some task waiting for a "
      "CPU) median %.0f %%, at most %.0f %% of a sample period; stolen by the hypervisor %lld "
      "ms\n",
      busiest, 100.0 * pressures[pressures.size() / 2], 100.0 * most_pressure,
      samples.back().stolen_ms - stolen_at_start);
  std::printf(
      "  resident memory: %.2f MiB before start, %.2f MiB after the warm-up, %.2f MiB at the "
      "end: %+ld KiB (limit %.0f KiB; peak %+ld KiB; trend %+.1f KiB/min); anonymous %+ld KiB\n",
      mib(at_start.rss_kib), mib(w.process.rss_kib), mib(e.process.rss_kib), rss_growth,
      o.max_rss_growth_kib, rss_peak - w.process.rss_kib, slope,
      e.process.anon_kib - w.process.anon_kib);
  std::printf("  file descriptors: %d after the warm-up, %d at the end; threads %d and %d\n",
              w.process.fds, e.process.fds, w.process.threads, e.process.threads);
  std::printf(
      "  newest frame to published: p50 %.3f ms, p99 %.3f ms, max %.3f ms; fusion p50 %.3f ms, "
      "p99 %.3f ms; CPU %.1f %% of one core\n",
      latency.percentileMs(0.5), latency.percentileMs(0.99), latency.maxMs(),
      fusion.percentileMs(0.5), fusion.percentileMs(0.99), 100.0 * cpu_s / wall_s);
  std::string missed;
  for (const std::string& name : failed) missed += (missed.empty() ? "" : ", ") + name;
  std::printf("  %s%s\n", pass ? "PASS" : "FAIL: ", missed.c_str());
  printJsonLine({{"soak", config.name},
                 {"cameras", load.cameraCount()},
                 {"fps", o.load.fps},
                 {"seconds", rounded(wall_s, 1)},
                 {"warmup_s", o.warmup},
                 {"load_before", rounded(load_before, 2)},
                 {"load_after", rounded(load_after, 2)},
                 {"load_max", rounded(busiest, 2)},
                 {"cpu_pressure_max", rounded(most_pressure, 2)},
                 {"stolen_ms", samples.back().stolen_ms - stolen_at_start},
                 {"maps", maps},
                 {"maps_per_s", rounded(rate, 2)},
                 {"maps_skipped", pipeline.mapsSkipped()},
                 {"maps_received", subscriber.received},
                 {"maps_lost", subscriber.lost},
                 {"maps_not_received", not_received},
                 {"frames_dropped", dropped},
                 {"rss_start_kib", at_start.rss_kib},
                 {"rss_warmup_kib", w.process.rss_kib},
                 {"rss_end_kib", e.process.rss_kib},
                 {"rss_growth_kib", rss_growth},
                 {"rss_peak_growth_kib", rss_peak - w.process.rss_kib},
                 {"rss_trend_kib_per_min", rounded(slope, 1)},
                 {"anon_growth_kib", e.process.anon_kib - w.process.anon_kib},
                 {"fds_warmup", w.process.fds},
                 {"fds_end", e.process.fds},
                 {"threads_warmup", w.process.threads},
                 {"threads_end", e.process.threads},
                 {"latency_p50_ms", rounded(latency.percentileMs(0.5), 3)},
                 {"latency_p99_ms", rounded(latency.percentileMs(0.99), 3)},
                 {"latency_max_ms", rounded(latency.maxMs(), 3)},
                 {"cpu_share_of_core", rounded(cpu_s / wall_s, 3)},
                 {"verdict", pass ? "PASS" : "FAIL"},
                 {"failed", failed}});
  return pass ? kExitPass : kExitFail;
}

}  // namespace
}  // namespace occmap::bench

int main(int argc, char** argv) {
  using occmap::bench::Options;
  Options options;
  CLI::App app(
      "soak: occmapd's pipeline for a long run, checked for leaks and losses.\n"
      "Runs the daemon's own Pipeline (capture threads, rings, fusion, LCM) on simulated "
      "cameras rendered beforehand, by default the paper's rig (4 x 640x480 at 60 fps) for 10 "
      "minutes, its maps going over UDP multicast in a private network namespace to `occmap "
      "view` in another process, which counts lost maps. Every --sample-every seconds it reads "
      "its resident memory (VmRSS), file descriptors (/proc/self/fd) and threads, frames "
      "dropped, maps published and lost; a progress line now and then on stderr. At the end: a "
      "summary and one JSON line on stdout, and PASS when no frame was dropped, no map lost, "
      "resident memory grew by less than --max-rss-growth-kib and the descriptors and threads "
      "at the end are as many as after --warmup seconds (from when memory is compared), and "
      "maps kept --fps.\n"
      "Exit codes: 0 PASS, 1 FAIL, 2 bad command line, 77 skipped (no network namespace: run "
      "as root or with CAP_SYS_ADMIN).\n"
      "  soak                           the 10 minutes of issue 6\n"
      "  soak --seconds 60              a shorter run, same targets\n"
      "  scripts/bench --soak [FLAGS]   builds it in Release and runs it",
      "soak");
  occmap::bench::addLoadOptions(app, options.load);
  app.add_option("--seconds", options.seconds, "How long the pipeline runs, warm-up included")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--warmup", options.warmup,
                 "Seconds after start from which memory, descriptors and threads are compared "
                 "(allocators, buffers and libraries settle before)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--sample-every", options.sample_every, "Seconds between samples")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--progress-every", options.progress_every,
                 "Seconds between progress lines (0: a tenth of the run, at most 60 s)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--max-rss-growth-kib", options.max_rss_growth_kib,
                 "Resident memory may grow by less than this from the warm-up to the end")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return occmap::bench::kExitInvalidInput;
  }
  if (options.warmup >= options.seconds) {
    std::fprintf(stderr, "soak: --warmup (%g s) must end before --seconds (%g s)\n", options.warmup,
                 options.seconds);
    return occmap::bench::kExitInvalidInput;
  }
  try {
    return occmap::bench::run(options);
  } catch (const std::exception& e) {  // LCM could not be opened, a thread could not start
    std::fprintf(stderr, "soak: failed: %s\n", e.what());
    return occmap::bench::kExitFail;
  }
}
