// occmap record: every camera's raw frames from any source, as numbered PNGs with their times, and
// a config that replays them through files:// (docs/lighting.md, "Recording a site").
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <thread>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "capture/image_file.h"
#include "capture/source_spec.h"
#include "config/calibration_file.h"
#include "config/config.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "config/rig.h"
#include "tools/commands.h"
#include "tools/progress.h"

namespace occmap::tools {
namespace {

namespace fs = std::filesystem;

struct RecordOptions {
  std::string config;
  std::string out;
  double seconds = 0;
  std::uint64_t frames = 0;
};

// One camera's recording, in its own thread: a live camera keeps its own pace.
struct Recorder {
  std::atomic<std::uint64_t> written{0};
  std::atomic<bool> ended{false};
  std::string error;  // read after the thread is joined
};

void record(RigCamera& camera, const fs::path& folder, std::uint64_t frames,
            const std::atomic<bool>& stop, Recorder& recorder) {
  std::ofstream times(folder / "timestamps.csv");
  times << "frame,sequence,capture_utime\n";
  FrameSource& source = *camera.source;
  while (!stop.load() && (frames == 0 || recorder.written.load() < frames)) {
    Frame frame;
    const FrameSource::Status status = source.read(frame);
    if (status == FrameSource::Status::kEnd) break;  // files and the simulator end; cameras do not
    if (status == FrameSource::Status::kLost) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      source.reopen();
      continue;
    }
    if (status != FrameSource::Status::kFrame) continue;
    const std::uint64_t n = recorder.written.load();
    char name[32];
    std::snprintf(name, sizeof name, "%06llu.png", static_cast<unsigned long long>(n));
    if (!writeGreyPng(folder / name, frame.image, recorder.error)) break;
    times << n << ',' << frame.sequence << ',' << frame.capture_time_us << '\n';
    recorder.written.store(n + 1);
  }
  if (!times) recorder.error = "cannot write " + (folder / "timestamps.csv").string();
  recorder.ended.store(true);
}

// The replay config's entry for one camera: its frames through files://, its geometry and images
// as the daemon used them (the simulator's written beside the frames), its settings as effective.
void emitCamera(YAML::Emitter& yaml, const CameraConfig& entry, const RigCamera& camera,
                const Config& config, const fs::path& folder) {
  yaml << YAML::BeginMap;
  yaml << YAML::Key << "name" << YAML::Value << entry.name;
  yaml << YAML::Key << "source" << YAML::Value << YAML::DoubleQuoted
       << "files://" + entry.name + "/[0-9]*.png";  // the frames, not the images beside them
  const double fps = entry.fps ? *entry.fps : camera.sim != nullptr ? camera.sim->fps() : 30.0;
  yaml << YAML::Key << "fps" << YAML::Value << fps;
  auto written = [&](const std::string& file, const Image& image) {
    std::string error;
    if (!writeGreyPng(folder / file, image, error)) throw std::runtime_error(error);
    return (fs::path(entry.name) / file).string();
  };
  if (entry.calibration) {
    yaml << YAML::Key << "calibration" << YAML::Value;
    if (entry.extrinsics) {
      yaml << YAML::Flow << YAML::BeginMap << YAML::Key << "intrinsics" << YAML::Value
           << entry.calibration->string() << YAML::Key << "extrinsics" << YAML::Value
           << entry.extrinsics->string() << YAML::EndMap;
    } else {
      yaml << entry.calibration->string();
    }
    if (entry.world_frame == WorldFrame::kLeftHanded) {
      yaml << YAML::Key << "world_frame" << YAML::Value << "left-handed";
    }
    if (entry.calibration_units) {
      yaml << YAML::Key << "calibration_units" << YAML::Value
           << std::string(unitName(*entry.calibration_units));
    }
    if (entry.image_region) {
      const ImageRegion& r = *entry.image_region;
      yaml << YAML::Key << "image_region" << YAML::Value << YAML::Flow << YAML::BeginSeq << r.x0
           << r.y0 << r.width << r.height << YAML::EndSeq;
    }
  } else if (camera.sim != nullptr) {
    std::string error;
    const std::optional<SourceSpec> spec =
        parseSource(entry.source, config.file.parent_path(), error);
    for (const auto& scene_camera : camera.sim->scene().cameras()) {
      if (spec && scene_camera.name == spec->camera) {
        std::ofstream xml(folder / "calibration.xml");
        xml << tsaiXmlText(scene_camera.calibration, entry.name);
        yaml << YAML::Key << "calibration" << YAML::Value
             << (fs::path(entry.name) / "calibration.xml").string();
        yaml << YAML::Key << "calibration_units" << YAML::Value << "mm";
      }
    }
  }
  yaml << YAML::Key << "background" << YAML::Value
       << (entry.background ? entry.background->string()
                            : written("background.png", camera.background));
  if (entry.floor_mask) {
    yaml << YAML::Key << "floor_mask" << YAML::Value << entry.floor_mask->string();
  } else if (!camera.floor_mask.empty()) {
    yaml << YAML::Key << "floor_mask" << YAML::Value
         << written("floor_mask.png", camera.floor_mask);
  }
  yaml << YAML::Key << "threshold" << YAML::Value << camera.threshold;
  const LightingSettings& l = camera.lighting;
  yaml << YAML::Key << "lighting" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
       << "adapt" << YAML::Value << l.adapt << YAML::Key << "drift_frames" << YAML::Value
       << l.drift_frames << YAML::Key << "min_agreement" << YAML::Value << l.min_agreement
       << YAML::Key << "min_agreement_in_place" << YAML::Value << l.min_agreement_in_place
       << YAML::Key << "agreement_grey_levels" << YAML::Value << l.agreement_grey_levels
       << YAML::Key << "local" << YAML::Value << l.local << YAML::EndMap;
  yaml << YAML::EndMap;
}

int run(const RecordOptions& o) {
  const fs::path out(o.out);
  if (fs::exists(out) && !(fs::is_directory(out) && fs::is_empty(out))) {
    throw InputError(o.out, 0, "--out", "exists and is not an empty folder; name a new one");
  }
  if (o.seconds <= 0 && o.frames == 0) {
    throw InputError("", 0, "--seconds", "or --frames is needed: how much to record");
  }
  const Config config = loadConfig(o.config);
  Rig rig = Rig::open(config);
  for (const std::string& warning : rig.warnings()) {
    std::fprintf(stderr, "occmap record: %s\n", warning.c_str());
  }
  fs::create_directories(out);
  std::vector<fs::path> folders;
  for (const RigCamera& camera : rig.cameras()) {
    folders.push_back(out / camera.name);
    fs::create_directories(folders.back());
  }

  std::atomic<bool> stop{false};
  std::vector<Recorder> recorders(rig.cameras().size());
  std::vector<std::thread> threads;
  for (std::size_t k = 0; k < rig.cameras().size(); ++k) {
    threads.emplace_back(
        [&, k] { record(rig.cameras()[k], folders[k], o.frames, stop, recorders[k]); });
  }
  const auto started = std::chrono::steady_clock::now();
  const std::uint64_t expected = o.frames * rig.cameras().size();
  Progress progress("recording", expected);
  for (;;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::uint64_t written = 0;
    bool all_ended = true;
    for (const Recorder& r : recorders) {
      written += r.written.load();
      all_ended = all_ended && r.ended.load();
    }
    progress.update(written);
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (all_ended || (o.seconds > 0 && elapsed >= o.seconds)) break;
  }
  stop.store(true);
  for (std::thread& thread : threads) thread.join();
  progress.finish();
  for (std::size_t k = 0; k < recorders.size(); ++k) {
    if (!recorders[k].error.empty()) {
      std::fprintf(stderr, "occmap record: camera %s: %s\n", rig.cameras()[k].name.c_str(),
                   recorders[k].error.c_str());
      return kExitFailure;
    }
  }

  YAML::Emitter yaml;
  // 15 digits: the config's decimal numbers come back as written (0.3, not 0.29999999999999999).
  yaml.SetDoublePrecision(15);
  yaml << YAML::BeginMap;
  yaml << YAML::Key << "map" << YAML::Value << YAML::Flow << YAML::BeginMap;
  yaml << YAML::Key << "origin_m" << YAML::Value << YAML::Flow << YAML::BeginSeq
       << config.map.origin_x_m << config.map.origin_y_m << YAML::EndSeq;
  yaml << YAML::Key << "cell_size_m" << YAML::Value << config.map.cell_size_m;
  yaml << YAML::Key << "width" << YAML::Value << config.map.width;
  yaml << YAML::Key << "height" << YAML::Value << config.map.height << YAML::EndMap;
  yaml << YAML::Key << "fusion" << YAML::Value << YAML::Flow << YAML::BeginMap;
  yaml << YAML::Key << "threshold" << YAML::Value << config.fusion.threshold;
  yaml << YAML::Key << "column_height_m" << YAML::Value << config.fusion.column_height_m;
  yaml << YAML::Key << "max_wait_ms" << YAML::Value << config.fusion.max_wait_ms << YAML::EndMap;
  yaml << YAML::Key << "cameras" << YAML::Value << YAML::BeginSeq;
  for (std::size_t k = 0; k < rig.cameras().size(); ++k) {
    emitCamera(yaml, config.cameras[k], rig.cameras()[k], config, folders[k]);
  }
  yaml << YAML::EndSeq << YAML::EndMap;
  std::ofstream replay(out / "replay.yaml");
  replay << "# Recorded by occmap record from " << fs::absolute(config.file).string()
         << ".\n# Replay: occmap fuse --config " << (out / "replay.yaml").string()
         << " --out maps\n"
         << yaml.c_str() << "\n";
  if (!replay) {
    std::fprintf(stderr, "occmap record: cannot write %s\n", (out / "replay.yaml").c_str());
    return kExitFailure;
  }
  std::uint64_t fewest = UINT64_MAX;
  for (const Recorder& r : recorders) fewest = std::min(fewest, r.written.load());
  std::printf(
      "recorded %llu frames or more from each of %zu cameras into %s; replay with occmap "
      "fuse --config %s\n",
      static_cast<unsigned long long>(fewest), recorders.size(), out.c_str(),
      (out / "replay.yaml").c_str());
  return fewest == 0 ? kExitNoResult : kExitOk;
}

}  // namespace

Command addRecordCommand(CLI::App& app) {
  auto options = std::make_shared<RecordOptions>();
  CLI::App* command = app.add_subcommand(
      "record",
      "Record every camera's raw frames from any source, to replay them later.\n"
      "Each camera's frames go to DIR/<camera>/000000.png, ... with DIR/<camera>/timestamps.csv "
      "(frame,sequence,capture_utime), and DIR/replay.yaml is a config that plays them back "
      "through files:// as they were: the same map, fusion and cameras (the simulator's "
      "calibration, background and floor mask written beside its frames). Hours of a real site "
      "can so be replayed through `occmap fuse`. Stop occmapd first: a GigE Vision camera has one "
      "controller at a time.\n\n"
      "Example:\n"
      "  occmap record --config /etc/occmap/occmapd.yaml --out site-2026-12-03 --seconds 600\n"
      "  occmap fuse --config site-2026-12-03/replay.yaml --out maps");
  command->add_option("--config", options->config, "Config file (YAML; see README)")->required();
  command->add_option("--out", options->out, "Folder to write (new, or empty)")->required();
  auto* seconds =
      command->add_option("--seconds", options->seconds, "Record for this long (wall clock)")
          ->check(CLI::PositiveNumber);
  auto* frames =
      command->add_option("--frames", options->frames, "Record this many frames a camera")
          ->check(CLI::Range(1, 100000000));
  seconds->excludes(frames);
  return [options] { return run(*options); };
}

}  // namespace occmap::tools
