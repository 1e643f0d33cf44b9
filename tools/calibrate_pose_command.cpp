// occmap calibrate pose / check: a camera's pose from markers on the floor (or points measured by
// hand), and a picture to check a calibration by eye.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calibrate/aruco_dictionary.h"
#include "calibrate/check_overlay.h"
#include "calibrate/floor_pose.h"
#include "capture/image_file.h"
#include "config/calibration_file.h"
#include "config/config.h"
#include "config/exit_codes.h"
#include "config/floor_survey_file.h"
#include "config/input_error.h"
#include "config/rig.h"
#include "tools/commands.h"

namespace occmap::tools {
namespace {

struct PoseOptions {
  std::string intrinsics;
  std::string image;
  std::string markers;
  std::string points;
  std::string out;
};

cv::Mat readGrey(const std::string& file) {
  std::string error;
  std::optional<Image> image = readGreyImage(file, error);
  if (!image) throw InputError(file, 0, "", error);
  return cv::Mat(image->height(), image->width(), CV_8UC1, image->data()).clone();
}

// The intrinsics for this image: its size must be theirs, or they leave the size to the stream.
OpenCvParameters intrinsicsFor(const std::string& file, const std::string& image_file,
                               cv::Size image) {
  OpenCvParameters p = loadOpenCvIntrinsics(file);
  if (p.width == 0) {
    p.width = image.width;
    p.height = image.height;
  } else if (p.width != image.width || p.height != image.height) {
    throw InputError(image_file, 0, "",
                     "is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                         " but the intrinsics in " + file + " are for " + std::to_string(p.width) +
                         "x" + std::to_string(p.height) +
                         " pictures; take the floor's picture at the calibrated size");
  }
  return p;
}

void writeText(const std::string& file, const std::string& text) {
  const std::filesystem::path path(file);
  const std::filesystem::path aside = path.string() + ".part";
  {
    std::ofstream out(aside, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out.flush()) throw std::runtime_error("cannot write " + aside.string());
  }
  std::filesystem::rename(aside, path);  // never a half-written calibration under its name
}

void printFit(const PoseFit& fit) {
  if (!fit.markers.empty()) {
    std::printf("marker  reprojection px  floor error cm\n");
    for (const MarkerFit& m : fit.markers) {
      if (m.used) {
        std::printf("%6d  %15.3f  %14.2f\n", m.id, m.reprojection_px, m.floor_error_cm);
      } else {
        std::printf("%6d  left out\n", m.id);
      }
    }
  }
  cv::Matx33d r;
  cv::Rodrigues(cv::Vec3d(fit.rvec.x(), fit.rvec.y(), fit.rvec.z()), r);
  const cv::Vec3d centre = -(r.t() * cv::Vec3d(fit.tvec.x(), fit.tvec.y(), fit.tvec.z()));
  std::printf("reprojection RMS %.3f px over %d points\n", fit.rms_px, fit.points);
  std::printf("camera at x %.3f  y %.3f  z %.3f m (height above the floor)\n", centre[0], centre[1],
              centre[2]);
  for (const std::string& warning : fit.warnings) {
    std::fprintf(stderr, "occmap calibrate pose: warning: %s\n", warning.c_str());
  }
}

int runPose(const PoseOptions& o) {
  const cv::Mat grey = readGrey(o.image);
  OpenCvParameters p = intrinsicsFor(o.intrinsics, o.image, grey.size());
  std::string error;
  std::optional<PoseFit> fit;
  if (!o.markers.empty()) {
    const FloorMarkers listed = loadFloorMarkers(o.markers);
    const std::optional<int> dictionary = arucoDictionary(listed.dictionary);
    if (!dictionary) {
      throw InputError(o.markers, 0, "dictionary",
                       "\"" + listed.dictionary + "\" is no OpenCV dictionary; use one of " +
                           arucoDictionaryNames());
    }
    const std::vector<MarkerSighting> seen = findMarkers(grey, *dictionary);
    if (seen.empty()) {
      throw InputError(o.image, 0, "",
                       "shows no ArUco marker of " + listed.dictionary +
                           "; check that the markers are in view, lit, flat, printed from that "
                           "dictionary and at least 20 pixels across");
    }
    std::string ids;
    for (const MarkerSighting& s : seen) ids += (ids.empty() ? "" : " ") + std::to_string(s.id);
    std::printf("markers seen: %s\n", ids.c_str());
    fit = poseFromMarkers(p, listed.markers, seen, grey.size(), error);
    if (!fit) {
      throw InputError(o.markers, 0, "",
                       error + " (seen: " + ids + "); list each marker on the floor with its id");
    }
  } else {
    const std::vector<PointPair> pairs = loadPointPairs(o.points);
    std::vector<cv::Point3d> world;
    std::vector<cv::Point2d> pixels;
    for (const PointPair& pair : pairs) {
      world.emplace_back(pair.world_m.x(), pair.world_m.y(), pair.world_m.z());
      pixels.emplace_back(pair.pixel.x(), pair.pixel.y());
    }
    fit = poseFromPoints(p, world, pixels, grey.size(), error);
    if (!fit) throw InputError(o.points, 0, "", error);
  }
  printFit(*fit);
  p.rvec = fit->rvec;
  p.tvec = fit->tvec;
  writeText(o.out, openCvYamlText(p));
  std::printf("wrote %s\n", o.out.c_str());
  return kExitOk;
}

struct CheckOptions {
  std::string config;
  std::string camera;
  std::string image;
  std::string markers;
  std::string out;
};

int runCheck(const CheckOptions& o) {
  const Config config = loadConfig(o.config);
  RigOptions options;
  options.only_camera = o.camera;
  options.read_backgrounds = false;
  options.open_live_cameras = false;
  const Rig rig = Rig::open(config, options);
  const RigCamera& rig_camera = rig.cameras().front();
  const cv::Mat grey = readGrey(o.image);
  // The camera's geometry for this picture: the rig's when it knows the stream's size, else
  // (a live camera without a background yet) its calibration at the picture's size.
  std::unique_ptr<Camera> camera;
  const CameraConfig& entry = rig.config().cameras.front();
  if (rig_camera.camera && rig_camera.camera->streamWidth() == grey.cols &&
      rig_camera.camera->streamHeight() == grey.rows) {
    camera = std::make_unique<Camera>(*rig_camera.camera);
  } else if (entry.calibration) {
    const LoadedCalibration calibration =
        loadCalibration(CalibrationFiles{*entry.calibration, entry.extrinsics},
                        entry.calibration_units, entry.world_frame);
    camera =
        std::make_unique<Camera>(calibration.modelFor(grey.cols, grey.rows), calibration.units,
                                 grey.cols, grey.rows, entry.image_region.value_or(ImageRegion{}));
  } else {
    throw InputError(o.image, 0, "",
                     "is " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) +
                         " but camera '" + o.camera + "' delivers " +
                         std::to_string(rig_camera.camera->streamWidth()) + "x" +
                         std::to_string(rig_camera.camera->streamHeight()) +
                         " pictures; check with a picture from the camera itself");
  }
  std::vector<FloorMarker> markers;
  if (!o.markers.empty()) markers = loadFloorMarkers(o.markers).markers;
  const Image* mask =
      rig_camera.floor_mask.width() == grey.cols && rig_camera.floor_mask.height() == grey.rows
          ? &rig_camera.floor_mask
          : nullptr;
  const CheckOverlay overlay = drawCheckOverlay(grey, *camera, config.map, markers, mask);
  if (!cv::imwrite(o.out, overlay.picture)) {
    std::fprintf(stderr, "occmap calibrate check: cannot write %s\n", o.out.c_str());
    return kExitFailure;
  }
  std::printf("wrote %s: %d grid lines and %d of %zu markers in view%s\n", o.out.c_str(),
              overlay.grid_lines, overlay.markers_drawn, markers.size(),
              mask != nullptr ? ", the floor mask's edge" : "");
  if (overlay.grid_lines == 0) {
    std::fprintf(stderr,
                 "occmap calibrate check: warning: no grid line of the map is in view: the "
                 "calibration, its units or the map's origin_m are wrong\n");
  }
  return kExitOk;
}

}  // namespace

Command addCalibratePoseCommand(CLI::App& calibrate) {
  auto o = std::make_shared<PoseOptions>();
  CLI::App* command = calibrate.add_subcommand(
      "pose",
      "A camera's pose on the floor, from ArUco markers laid flat at measured places (or from "
      "points measured by hand), and its intrinsics.\n"
      "markers.yaml names the dictionary and each marker: its id, centre_m [x, y] on the floor, "
      "side_m (the black square, border included) and yaw_deg (the printed left-to-right "
      "direction is (cos yaw, sin yaw) on the floor, the printed up (-sin yaw, cos yaw)):\n"
      "  dictionary: DICT_4X4_50\n"
      "  markers:\n"
      "    - {id: 3, centre_m: [1.5, 2.0], side_m: 0.3, yaw_deg: 0}\n"
      "The pose is solved with OpenCV's IPPE over every corner seen, then refined; the command "
      "prints each marker's reprojection error (pixels) and floor error (cm), the RMS, where the "
      "camera stands, and warns when the markers fix the pose poorly (few, in a line, small in the "
      "view). A marker not where the file puts it is left out, and said so.\n"
      "--points takes a CSV instead: header x_m,y_m,z_m,u,v, then a world point and its pixel a "
      "line.\n"
      "The output is the one-file OpenCV YAML occmap reads (intrinsics, rvec, tvec in metres).\n\n"
      "Example:\n"
      "  occmap calibrate pose --intrinsics c0-intrinsics.yaml --image c0-floor.png "
      "--markers markers.yaml --out c0.yaml");
  command->add_option("--intrinsics", o->intrinsics, "OpenCV intrinsics (YAML or XML)")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--image", o->image, "The camera's picture of the floor with the markers")
      ->required()
      ->check(CLI::ExistingFile);
  CLI::Option* markers =
      command->add_option("--markers", o->markers, "markers.yaml: the markers' places");
  CLI::Option* points =
      command->add_option("--points", o->points, "CSV x_m,y_m,z_m,u,v of measured points");
  markers->excludes(points);
  command->add_option("--out", o->out, "Calibration to write (OpenCV YAML)")->required();
  return [o, markers, points] {
    if (markers->count() == 0 && points->count() == 0) {
      std::fprintf(stderr, "occmap calibrate pose: give --markers FILE or --points FILE\n");
      return kExitInvalidInput;
    }
    return runPose(*o);
  };
}

Command addCalibrateCheckCommand(CLI::App& calibrate) {
  auto o = std::make_shared<CheckOptions>();
  CLI::App* command = calibrate.add_subcommand(
      "check",
      "Draws a camera's calibration into its own picture: the map's outline (yellow), a 1 m grid "
      "on the floor (cyan, x = 0 and y = 0 thicker), the markers with their ids and a dot on each "
      "one's printed top-left corner (magenta, with --markers) and the floor mask's edge (green). "
      "Where the calibration is right the grid lies on the floor's lines and the outlines on the "
      "printed markers.\n\n"
      "Example:\n"
      "  occmap calibrate check --config site.yaml --camera c0 --image c0-now.png "
      "--markers markers.yaml --out c0-check.png");
  command->add_option("--config", o->config, "occmapd's config")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--camera", o->camera, "The camera's name in the config")->required();
  command->add_option("--image", o->image, "A picture from that camera")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--markers", o->markers, "markers.yaml, to draw the markers too")
      ->check(CLI::ExistingFile);
  command->add_option("--out", o->out, "Picture to write (PNG)")->required();
  return [o] { return runCheck(*o); };
}

}  // namespace occmap::tools
