// occmap background: the empty scene for one camera, as the per-pixel median of live frames.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <thread>

#include "capture/image_file.h"
#include "config/config.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "config/rig.h"
#include "core/background_median.h"
#include "tools/commands.h"
#include "tools/progress.h"

namespace occmap::tools {
namespace {

struct BackgroundOptions {
  std::string config;
  std::string camera;
  int frames = 50;
  std::string out;
  bool overwrite = false;
  double timeout_s = 10.0;
};

int run(const BackgroundOptions& o) {
  if (std::filesystem::exists(o.out) && !o.overwrite) {
    throw InputError(o.out, 0, "--out", "exists; pass --overwrite to replace it");
  }
  const Config config = loadConfig(o.config);
  RigOptions rig_options;
  rig_options.read_backgrounds = false;  // it is what we are making
  rig_options.only_camera = o.camera;
  Rig rig = Rig::open(config, rig_options);
  RigCamera& camera = rig.cameras().front();
  FrameSource& source = *camera.source;
  const int width = source.width();
  const int height = source.height();
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  // All frames are kept (N x the image), then each pixel's median is picked out.
  std::vector<std::uint8_t> stack;
  stack.reserve(pixels * static_cast<std::size_t>(o.frames));
  Progress progress("frames of " + camera.name, static_cast<std::uint64_t>(o.frames));
  auto last_frame = std::chrono::steady_clock::now();
  int taken = 0;
  while (taken < o.frames) {
    Frame frame;
    const FrameSource::Status status = source.read(frame);
    if (status == FrameSource::Status::kEnd) {
      if (!source.rewind() || taken == 0) break;
      continue;
    }
    if (status == FrameSource::Status::kLost) {
      // A camera that drops out: wait for it as the daemon would, within the timeout.
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      source.reopen();
    }
    if (status != FrameSource::Status::kFrame || frame.image.width != width ||
        frame.image.height != height) {
      if (std::chrono::steady_clock::now() - last_frame >
          std::chrono::duration<double>(o.timeout_s)) {
        progress.finish();
        std::fprintf(stderr, "occmap background: no frame from camera %s for %g s%s%s\n",
                     camera.name.c_str(), o.timeout_s, source.lastError().empty() ? "" : ": ",
                     source.lastError().c_str());
        return kExitNoResult;
      }
      continue;
    }
    last_frame = std::chrono::steady_clock::now();
    for (int v = 0; v < height; ++v) {
      stack.insert(stack.end(), frame.image.row(v), frame.image.row(v) + width);
    }
    ++taken;
    progress.update(static_cast<std::uint64_t>(taken));
  }
  progress.finish();
  if (taken == 0) {
    std::fprintf(stderr, "occmap background: camera %s gave no frame\n", camera.name.c_str());
    return kExitNoResult;
  }
  const Image median = backgroundMedian(stack, taken, width, height);
  std::string error;
  if (!writeGreyPng(o.out, median, error)) {
    std::fprintf(stderr, "occmap background: %s\n", error.c_str());
    return kExitFailure;
  }
  std::printf("wrote %s: the per-pixel median of %d frames of camera %s (%dx%d)%s\n", o.out.c_str(),
              taken, camera.name.c_str(), width, height,
              taken < o.frames ? " (its source had no more)" : "");
  return kExitOk;
}

}  // namespace

Command addBackgroundCommand(CLI::App& app) {
  auto options = std::make_shared<BackgroundOptions>();
  CLI::App* command = app.add_subcommand(
      "background",
      "Make a camera's background image: the per-pixel median of N live frames.\n"
      "The median keeps what stays and drops what passes by, so people may walk through the "
      "scene while it runs, as long as no pixel is covered in half the frames or more. Take it "
      "with the lighting the cameras will see, and make a new one when the scene changes.\n"
      "A live camera is set to the size of the background image its config names, if that file "
      "exists already; otherwise it keeps its own size (set Width and Height in its settings to "
      "choose one). Stop occmapd first: a GigE Vision camera has one controller at a time.\n\n"
      "Example:\n"
      "  occmap background --config /etc/occmap/occmapd.yaml --camera c0 --frames 100 --out "
      "bg/c0.png");
  command->add_option("--config", options->config, "Config file (YAML; see README)")->required();
  command->add_option("--camera", options->camera, "The camera's name in the config")->required();
  command->add_option("--frames", options->frames, "How many frames to take the median of")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  command->add_option("--out", options->out, "Picture to write (8-bit grey PNG)")->required();
  command->add_flag("--overwrite", options->overwrite, "Replace --out if it exists");
  command
      ->add_option("--timeout", options->timeout_s,
                   "Give up when the camera delivers no frame for this many seconds")
      ->capture_default_str();
  return [options] { return run(*options); };
}

}  // namespace occmap::tools
