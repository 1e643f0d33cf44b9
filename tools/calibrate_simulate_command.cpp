// occmap calibrate simulate: the pictures a person calibrating a simulated camera would take (the
// board held up in front of it, the floor with its markers), so that the whole calibration
// workflow runs without a camera: in tests and in docs/calibration.md.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "calibrate/board.h"
#include "capture/image_file.h"
#include "capture/sim/target_view.h"
#include "capture/sim_source.h"
#include "config/calibration_file.h"
#include "config/config.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "config/rig.h"
#include "tools/commands.h"

namespace occmap::tools {
namespace {

namespace fs = std::filesystem;

// The board printed at 10 pixels a millimetre: far finer than any camera sees it.
constexpr int kPixelsPerMetre = 10000;

struct SimulateOptions {
  std::string config;
  std::string camera;
  std::string board;
  std::string out;
  int count = 15;
};

void writePng(const fs::path& file, const Image& image) {
  std::string error;
  if (!writeGreyPng(file, image, error)) throw std::runtime_error(error);
}

int runSimulate(const SimulateOptions& o) {
  std::string error;
  const std::optional<BoardSpec> spec = parseBoardSpec(o.board, error);
  if (!spec) throw InputError("", 0, "--board", error);
  const Config config = loadConfig(o.config);
  RigOptions options;
  options.only_camera = o.camera;
  const Rig rig = Rig::open(config, options);
  const RigCamera& camera = rig.cameras().front();
  if (camera.sim == nullptr) {
    throw InputError(o.config, rig.config().cameras.front().line, "source",
                     "camera '" + o.camera +
                         "' is not simulated (sim://); take its pictures with the camera itself");
  }
  const sim::Renderer& renderer = camera.sim->renderer();
  fs::create_directories(o.out);

  // The board, with a white margin of a square all round (the detectors need one).
  const int margin = squarePixels(*spec, kPixelsPerMetre);
  const cv::Mat texture = boardPicture(*spec, kPixelsPerMetre, margin);
  const double width_m = texture.cols / double{kPixelsPerMetre};
  const double height_m = texture.rows / double{kPixelsPerMetre};
  const auto poses = sim::targetPosesFor(*camera.camera, width_m, height_m, o.count);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "board_%02zu.png", k);
    writePng(fs::path(o.out) / name,
             sim::renderTargetView(renderer, texture, width_m, height_m, poses[k], 1000 + k));
    std::fprintf(stderr, "\rboard pictures: %zu of %zu", k + 1, poses.size());
  }
  std::fprintf(stderr, "\n");

  // The floor as the camera sees it, with whatever lies on it, and the markers' places.
  Image floor = renderer.background();
  sim::addSensorNoise(7, floor);
  writePng(fs::path(o.out) / "floor.png", floor);
  const sim::Scene& scene = camera.sim->scene();
  if (!scene.floorMarkers().empty()) {
    std::ofstream(fs::path(o.out) / "markers.yaml") << sim::markersYamlText(scene);
  }
  // The camera's true calibration, to compare a calibration made from these pictures with.
  if (const auto text = calibrationText(camera.camera->model(), o.camera)) {
    std::ofstream(fs::path(o.out) / ("true-calibration" + text->extension)) << text->text;
  }
  std::printf("wrote %zu board pictures, floor.png%s and the true calibration to %s\n",
              poses.size(), scene.floorMarkers().empty() ? "" : ", markers.yaml", o.out.c_str());
  return kExitOk;
}

}  // namespace

Command addCalibrateSimulateCommand(CLI::App& calibrate) {
  auto o = std::make_shared<SimulateOptions>();
  CLI::App* command = calibrate.add_subcommand(
      "simulate",
      "The pictures a person would take to calibrate a simulated camera, for trying the "
      "workflow without a camera: the board held up at --count places in front of it "
      "(DIR/board_00.png, ...), the floor (DIR/floor.png), the places of the markers on it "
      "(DIR/markers.yaml, for a scene with markers such as sim://room-markers) and the camera's "
      "true calibration to compare with.\n\n"
      "Example:\n"
      "  occmap calibrate simulate --config examples/sim-markers.yaml --camera c0 "
      "--board charuco:7x5:0.04:0.03:DICT_4X4_50 --out calibration/c0");
  command->add_option("--config", o->config, "A config with the simulated camera")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--camera", o->camera, "The camera's name in the config")->required();
  command->add_option("--board", o->board, "The board's SPEC (see 'calibrate board')")->required();
  command->add_option("--out", o->out, "Folder to write the pictures to")->required();
  command->add_option("--count", o->count, "Board pictures (default 15)")->check(CLI::Range(1, 99));
  return [o] { return runSimulate(*o); };
}

}  // namespace occmap::tools
