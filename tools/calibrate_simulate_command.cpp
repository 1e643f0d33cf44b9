// occmap calibrate simulate: the pictures a person calibrating a simulated camera would take (the
// board held up in front of it, the floor with its markers), so that the whole calibration
// workflow runs without a camera: in tests and in docs/calibration.md.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <opencv2/calib3d.hpp>

#include "calibrate/board.h"
#include "calibrate/intrinsics.h"
#include "capture/image_file.h"
#include "capture/sim/target_view.h"
#include "capture/sim_source.h"
#include "config/calibration_file.h"
#include "config/config.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "config/rig.h"
#include "core/opencv_camera.h"
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

// The simulated camera as OpenCV's model (the simulator's own lens model is Tsai's, which OpenCV's
// can only approximate): fitted to the exact projections of points spread over the whole picture
// at several distances and tilts, with the camera's true pose. What a calibration with occmap can
// at best find; `rms` says how closely the model follows the lens.
OpenCvParameters asOpenCv(const Camera& camera, double& rms) {
  std::vector<std::vector<cv::Point3f>> board_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  for (const sim::TargetPose& pose : sim::targetPosesFor(camera, 1.0, 0.75, 18, true)) {
    std::vector<cv::Point3f> on_board;
    std::vector<cv::Point2f> in_image;
    for (int row = 0; row <= 15; ++row) {
      for (int column = 0; column <= 20; ++column) {
        const Eigen::Vector2d paper(column * 0.05, row * 0.05);
        const auto pixel = camera.worldToStream(sim::targetPointInWorld(camera, pose, paper));
        if (!pixel || !camera.pixelIndexAt(*pixel)) continue;
        on_board.emplace_back(static_cast<float>(paper.x()), static_cast<float>(paper.y()), 0.0f);
        in_image.emplace_back(static_cast<float>(pixel->x()), static_cast<float>(pixel->y()));
      }
    }
    if (on_board.size() < 20) continue;
    board_points.push_back(std::move(on_board));
    image_points.push_back(std::move(in_image));
  }
  const cv::Size size(camera.streamWidth(), camera.streamHeight());
  cv::Mat k, d;
  std::vector<cv::Mat> rvecs, tvecs;
  const cv::TermCriteria until(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-12);
  rms = cv::calibrateCamera(board_points, image_points, size, k, d, rvecs, tvecs, 0, until);
  OpenCvParameters p = openCvIntrinsics(k, d, size);
  const Pose& pose = camera.model().pose();
  p.rvec = rodriguesFromRotation(pose.rotation);
  p.tvec = pose.translation * camera.metresPerUnit();
  return p;
}

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

  // The board, with a white margin of a square all round, as it should be printed (the detectors
  // need one; with less, cornerSubPix's window takes in what lies behind the board).
  const int margin = squarePixels(*spec, kPixelsPerMetre);
  const cv::Mat texture = boardPicture(*spec, kPixelsPerMetre, margin);
  const double width_m = texture.cols / double{kPixelsPerMetre};
  const double height_m = texture.rows / double{kPixelsPerMetre};
  const auto poses = sim::targetPosesFor(*camera.camera, width_m, height_m, o.count,
                                         spec->kind == BoardKind::kCharuco);
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
  // The camera's true calibration, to compare a calibration made from these pictures with: as the
  // simulator has it, and as OpenCV's model fitted to it.
  if (const auto text = calibrationText(camera.camera->model(), o.camera)) {
    std::ofstream(fs::path(o.out) / ("true-calibration" + text->extension)) << text->text;
  }
  double rms = 0;
  const OpenCvParameters fitted = asOpenCv(*camera.camera, rms);
  std::ofstream(fs::path(o.out) / "true-opencv.yaml") << openCvYamlText(fitted);
  std::printf(
      "wrote %zu board pictures, floor.png%s and the true calibration to %s (as OpenCV's "
      "model in true-opencv.yaml, which follows the simulator's lens to %.3f px RMS)\n",
      poses.size(), scene.floorMarkers().empty() ? "" : ", markers.yaml", o.out.c_str(), rms);
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
