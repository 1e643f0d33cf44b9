// occmapd: the occupancy-map daemon. Reads every camera, fuses each frame set into a map and
// broadcasts it over LCM; answers status requests; runs as a systemd Type=notify service.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>

#include <CLI/CLI.hpp>
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include "base/log.h"
#include "config/config.h"
#include "config/control_key_file.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "config/prepared_rig.h"
#include "config/rig.h"
#include "daemon/liveness.h"
#include "daemon/merge_daemon.h"
#include "daemon/pipeline.h"
#include "daemon/service_notifier.h"
#include "transport/lcm_bus.h"

namespace occmap {
namespace {

constexpr const char* kDefaultConfig = "/etc/occmap/occmapd.yaml";

struct Options {
  std::string config = kDefaultConfig;
  bool check = false;
};

RigOptions rigOptions(bool open_live_cameras) {
  RigOptions options;
  options.open_live_cameras = open_live_cameras;
  options.notice = [](const std::string& message) {
    logLine(LogLevel::kNotice, "%s", message.c_str());
  };
  return options;
}

// The control key is read here, before any work, so that a key file others can read stops the
// start (exit 2) and a reload with one is refused while the old config runs on; the pipeline reads
// it again when it starts.
void checkControlKey(const Config& config) {
  if (!config.control.enabled) return;
  (void)loadControlKey(config.control.key_file,
                       {config.file.string(), config.control.key_file_line, "control.key_file"});
}

// Everything a config makes before it can run: its rig and carve tables. On reload the old
// pipeline keeps running meanwhile, and the live cameras are left closed (`open_live_cameras`)
// until it has stopped and let go of them.
PreparedRig prepare(const Config& config, bool open_live_cameras) {
  checkControlKey(config);
  PreparedRig prepared = prepareRig(config, rigOptions(open_live_cameras));
  for (const std::string& warning : prepared.rig.warnings())
    logLine(LogLevel::kWarning, "%s", warning.c_str());
  std::size_t cells = 0;
  for (const CarveTable& table : prepared.tables) cells += table.entries();
  logLine(LogLevel::kInfo,
          "%s: %zu cameras, map %dx%d of %.3g m cells, column %.3g m, %zu table entries",
          config.file.c_str(), prepared.rig.cameras().size(), config.map.width, config.map.height,
          config.map.cell_size_m, prepared.column_height_m, cells);
  return prepared;
}

// The pipeline of a prepared config, on its bus (a daemon that can publish nothing must not say
// it is ready: LcmBus::open throws), started.
std::unique_ptr<Pipeline> startPipeline(PreparedRig prepared, const PipelineOptions& options) {
  std::unique_ptr<Bus> bus = LcmBus::open(prepared.rig.config().transport.lcm_url);
  auto pipeline = std::make_unique<Pipeline>(std::move(prepared), std::move(bus), options);
  pipeline->start();
  return pipeline;
}

// SIGHUP: the new config replaces the running one only once it is wholly valid. Its cameras are
// checked and its tables built while the old pipeline runs; then the old one stops, hands over
// every camera connection the new config leaves unchanged, and the new one starts. A camera that
// refuses the new settings puts the old config back (and the error goes on to the caller). Only
// when even the old config cannot be restored does `pipeline` end up empty.
void reload(std::unique_ptr<Pipeline>& pipeline, const std::string& file,
            const PipelineOptions& options) {
  PreparedRig next = prepare(loadConfig(file), false);  // InputError: the old one runs on
  pipeline->stop();
  PreparedRig old = pipeline->takePrepared();
  pipeline.reset();
  try {
    next.rig.openLiveCameras(&old.rig);
    std::unique_ptr<Bus> bus = LcmBus::open(next.rig.config().transport.lcm_url);
    pipeline = std::make_unique<Pipeline>(std::move(next), std::move(bus), options);
    pipeline->start();
  } catch (const std::exception&) {
    if (pipeline) next = pipeline->takePrepared();  // it never started: its cameras go back
    pipeline.reset();
    old.rig.openLiveCameras(&next.rig);  // takes back what went over, reopens the rest
    pipeline = startPipeline(std::move(old), options);
    throw;
  }
  logLine(LogLevel::kNotice, "reloaded %s", file.c_str());
}

PipelineOptions optionsFromEnvironment(std::chrono::steady_clock::time_point start) {
  PipelineOptions options;
  options.daemon_start = start;
  // systemd's StateDirectory= (/var/lib/occmap): where a recaptured background is saved. It may
  // list several folders, separated by ':'; the first is ours.
  if (const char* state = std::getenv("STATE_DIRECTORY"); state != nullptr && *state != '\0') {
    const std::string folders = state;
    options.state_directory = folders.substr(0, folders.find(':'));
  }
  return options;
}

int run(const Options& options) {
  const auto start = std::chrono::steady_clock::now();
  const Config first = loadConfig(options.config);
  if (first.merge && options.check) {
    std::printf("%s is valid: a merge node of %zu inputs, map %dx%d\n", options.config.c_str(),
                first.merge->inputs.size(), first.map.width, first.map.height);
    return kExitOk;
  }
  if (options.check) {
    // Live cameras are not opened: a running daemon holds them. Their settings are checked when
    // occmapd opens them (a refused one is the same exit code 2 then).
    const Config& config = first;
    checkControlKey(config);
    const Rig rig = Rig::open(config, rigOptions(false));
    const auto live = std::count_if(rig.cameras().begin(), rig.cameras().end(),
                                    [](const RigCamera& camera) { return camera.live; });
    std::printf("%s is valid: %zu cameras, map %dx%d%s\n", options.config.c_str(),
                config.cameras.size(), config.map.width, config.map.height,
                live > 0 ? "; the cameras' own settings are checked when occmapd opens them" : "");
    return kExitOk;
  }
  // The signals this daemon acts on arrive through a signalfd in this thread; every other thread
  // inherits the blocked mask, so none is interrupted by them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
  const int signal_fd = ::signalfd(-1, &signals, SFD_CLOEXEC);

  if (first.merge) return runMergeDaemon(first, signal_fd);

  ServiceNotifier notifier;
  const PipelineOptions pipeline_options = optionsFromEnvironment(start);
  PreparedRig prepared = prepare(loadConfig(options.config), true);
  std::unique_ptr<Pipeline> pipeline = startPipeline(std::move(prepared), pipeline_options);
  logLine(LogLevel::kNotice, "started with %s", options.config.c_str());

  // The main loop: signals, readiness, the watchdog (only while fusion makes progress), STATUS=.
  const auto watchdog = notifier.watchdogInterval();
  const auto tick = watchdog
                        ? std::min<std::chrono::milliseconds>(
                              std::chrono::duration_cast<std::chrono::milliseconds>(*watchdog / 4),
                              std::chrono::milliseconds(500))
                        : std::chrono::milliseconds(500);
  bool ready = false;
  Liveness liveness;
  auto last_status = std::chrono::steady_clock::now() - std::chrono::seconds(10);
  for (;;) {
    pollfd fd{signal_fd, POLLIN, 0};
    ::poll(&fd, 1, static_cast<int>(tick.count()));
    if (fd.revents & POLLIN) {
      signalfd_siginfo info{};
      if (::read(signal_fd, &info, sizeof info) == sizeof info) {
        if (info.ssi_signo == SIGHUP) {
          logLine(LogLevel::kNotice, "SIGHUP: reloading %s", options.config.c_str());
          notifier.reloading();
          pipeline->setState(DaemonState::kReloading);
          try {
            reload(pipeline, options.config, pipeline_options);
            ready = false;
          } catch (const InputError& error) {
            logLine(LogLevel::kError, "reload refused, the running config stays: %s", error.what());
            if (!pipeline) throw;  // not even the old config could be put back
            pipeline->setState(DaemonState::kRunning);
            notifier.ready();
          } catch (const std::exception& error) {
            logLine(LogLevel::kError, "reload failed, the running config stays: %s", error.what());
            if (!pipeline) throw;
            pipeline->setState(DaemonState::kRunning);
            notifier.ready();
          }
        } else {
          logLine(LogLevel::kNotice, "%s: stopping",
                  info.ssi_signo == SIGTERM ? "SIGTERM" : "SIGINT");
          notifier.stopping();
          pipeline->setState(DaemonState::kStopping);
          pipeline->stop();
          const TimeHistogram& latency = pipeline->publishLatency();
          const TimeHistogram& fusion = pipeline->fusionTimes();
          logLine(LogLevel::kNotice,
                  "stopped after %llu maps (%llu skipped, %llu frames overtaken by newer ones); "
                  "newest frame to published: p50 %.2f "
                  "ms, p99 %.2f ms, max %.2f ms; fusion p50 %.2f ms, p99 %.2f ms",
                  static_cast<unsigned long long>(pipeline->mapsPublished()),
                  static_cast<unsigned long long>(pipeline->mapsSkipped()),
                  static_cast<unsigned long long>(pipeline->framesOvertaken()),
                  latency.percentileMs(0.5), latency.percentileMs(0.99), latency.maxMs(),
                  fusion.percentileMs(0.5), fusion.percentileMs(0.99));
          return kExitOk;
        }
      }
    }
    if (!ready && pipeline->camerasReportedIn()) {
      ready = true;
      pipeline->setState(DaemonState::kRunning);
      notifier.ready();
      logLine(LogLevel::kNotice, "ready: %s", pipeline->summary().c_str());
    }
    if (liveness.alive(pipeline->mapsFused(), pipeline->publisherRounds())) notifier.watchdog();
    if (pipeline->failed()) {
      // A fusion or publisher thread ended on an error (logged): no more maps will come. Exit for
      // systemd to restart the service (Restart=on-failure) rather than run on without maps.
      notifier.stopping();
      pipeline->stop();
      return kExitFailure;
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - last_status >= std::chrono::seconds(2)) {
      notifier.status(pipeline->summary());
      last_status = now;
    }
  }
}

}  // namespace
}  // namespace occmap

int main(int argc, char** argv) {
  using namespace occmap;
  Options options;
  CLI::App app(
      "occmapd: the occupancy-map daemon (Hoover & Olsen 1999, and past it).\n"
      "Reads every camera of the config in its own thread, fuses each frame set into a map of the "
      "floor (FREE, OCCUPIED, UNSEEN) and broadcasts it over LCM (channel OCCMAP_MAP by default); "
      "publishes its status every second on OCCMAP_STATUS and answers requests on "
      "OCCMAP_STATUS_REQUEST (see `occmap status`, `occmap view`). With the config's `control` "
      "section enabled, it takes authenticated requests to change a camera's threshold or "
      "recapture its background on OCCMAP_STATUS_CONTROL (see `occmap control`, "
      "docs/control.md).\n\n"
      "With `merge:` instead of `cameras:` in the config it is a merge node: it merges the maps "
      "other occmapd (camera PCs) publish on their own channels into one map of the whole floor "
      "(docs/merge.md).\n\n"
      "Signals: SIGTERM/SIGINT stop cleanly (exit 0); SIGHUP reloads the config, and an invalid "
      "new config is reported while the old one keeps running.\n"
      "Under systemd (Type=notify) it reports READY=1 once every camera has delivered a frame or "
      "been marked down, STATUS= lines, WATCHDOG=1 while fusion makes progress, STOPPING=1.\n\n"
      "Exit codes: 0 stopped cleanly or config valid (--check); 1 failed at run time; 2 invalid "
      "config, calibration or image (the message names the file and line or field).",
      "occmapd");
  app.add_option("--config", options.config, "Config file (YAML)")->capture_default_str();
  app.add_flag(
      "--check", options.check,
      "Validate the config (and its calibrations, images and sources) and exit: 0 valid, 2 "
      "invalid");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitInvalidInput;
  }
  try {
    return run(options);
  } catch (const InputError& e) {
    logLine(LogLevel::kError, "%s", e.what());
    return kExitInvalidInput;
  } catch (const std::exception& e) {
    logLine(LogLevel::kError, "failed: %s", e.what());
    return kExitFailure;
  }
}
