// occmap project: one calibration's geometry by hand, world to pixel and pixel to world.
#include <cmath>
#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include "config/calibration_file.h"
#include "config/exit_codes.h"
#include "config/number_text.h"
#include "tools/commands.h"

namespace occmap::tools {
namespace {

struct ProjectOptions {
  std::string calibration;
  std::string intrinsics;
  std::string extrinsics;
  std::vector<int> image_size;
  std::string world_frame = "right-handed";
  std::string units;  // empty: the calibration kind's default
  std::vector<double> world;
  std::vector<double> pixel;
  double z = 0.0;
  bool json = false;
};

int noResult(const std::string& why) {
  std::fprintf(stderr, "occmap project: no result: %s\n", why.c_str());
  return kExitNoResult;
}

// One object on one line, keys in the order given. nlohmann writes each double in the fewest
// digits that read back as the same double: full precision, and null for a value that is not
// finite (which printf's "nan" would not be).
void printJson(const nlohmann::ordered_json& object) { std::printf("%s\n", object.dump().c_str()); }

int run(const ProjectOptions& o) {
  const WorldFrame frame =
      o.world_frame == "left-handed" ? WorldFrame::kLeftHanded : WorldFrame::kRightHanded;
  const CalibrationFiles files = o.calibration.empty()
                                     ? CalibrationFiles{o.intrinsics, o.extrinsics}
                                     : CalibrationFiles{o.calibration, std::nullopt};
  const LoadedCalibration calibration =
      loadCalibration(files, o.units.empty() ? std::nullopt : parseLengthUnit(o.units), frame);
  const std::shared_ptr<const CameraModel> sized =
      o.image_size.empty() ? calibration.model
                           : calibration.modelFor(o.image_size[0], o.image_size[1]);
  const CameraModel& model = *sized;
  const std::string unit(unitName(calibration.units));
  if (!o.world.empty()) {
    const Eigen::Vector3d world(o.world[0], o.world[1], o.world[2]);
    const std::optional<ImagePoint> image = model.worldToImage(world);
    if (!image) {
      const Eigen::Vector3d camera = model.pose().rotation * world + model.pose().translation;
      if (!(camera.z() > 0)) {
        char depth[64];
        std::snprintf(depth, sizeof depth, "%.6g", camera.z());
        // In front of a mirrored camera: most likely extrinsics made in a left-handed world.
        const bool mirrored_in_front =
            calibration.kind == "opencv" && frame == WorldFrame::kRightHanded && camera.z() < 0;
        return noResult(
            "the point is behind the camera (depth " + std::string(depth) + " " + unit + ")" +
            (mirrored_in_front ? "; if the extrinsics were made in a left-handed world frame "
                                 "(Unity's, MultiviewX's), where cv::projectPoints still gives "
                                 "such a point a pixel, add --world-frame left-handed"
                               : ""));
      }
      return noResult(
          "the point lies past the lens model's valid radius (where its distortion "
          "folds back), so it has no image");
    }
    if (o.json) {
      printJson({{"u", image->pixel.x()}, {"v", image->pixel.y()}, {"depth", image->depth}});
    } else if (model.width() == 0) {
      std::printf(
          "u %.6f  v %.6f  depth %.6f %s  (the calibration gives no image size: "
          "--image-size W H to know whether it is inside)\n",
          image->pixel.x(), image->pixel.y(), image->depth, unit.c_str());
    } else {
      const bool inside = image->pixel.x() >= -0.5 && image->pixel.y() >= -0.5 &&
                          image->pixel.x() < model.width() - 0.5 &&
                          image->pixel.y() < model.height() - 0.5;
      std::printf("u %.6f  v %.6f  depth %.6f %s  (%s the %dx%d calibration frame)\n",
                  image->pixel.x(), image->pixel.y(), image->depth, unit.c_str(),
                  inside ? "inside" : "outside", model.width(), model.height());
    }
    return kExitOk;
  }
  const Eigen::Vector2d pixel(o.pixel[0], o.pixel[1]);
  if (!model.imageToRay(pixel)) {
    return noResult(
        "the pixel lies past the lens model's valid radius (where its distortion folds "
        "back), so no ray belongs to it");
  }
  const std::optional<PlanePoint> point = model.imageToPlane(pixel, o.z);
  if (!point) {
    char plane[64];
    std::snprintf(plane, sizeof plane, "%.6g", o.z);
    return noResult("the pixel's ray never meets the plane z = " + std::string(plane) + " " + unit +
                    " in front of the camera (for the floor: the pixel looks above the horizon)");
  }
  if (o.json) {
    printJson({{"x", point->world.x()},
               {"y", point->world.y()},
               {"z", point->world.z()},
               {"depth", point->depth}});
  } else {
    std::printf("x %.6f  y %.6f  z %.6f  depth %.6f %s\n", point->world.x(), point->world.y(),
                point->world.z(), point->depth, unit.c_str());
  }
  return kExitOk;
}

}  // namespace

Command addProjectCommand(CLI::App& app) {
  auto options = std::make_shared<ProjectOptions>();
  CLI::App* command = app.add_subcommand(
      "project",
      "Where a world point appears in a camera, or where a pixel looks on a plane.\n"
      "Input and output are in the calibration file's own units (mm for Tsai XML, the tvec's for "
      "OpenCV); pixels are in the calibration frame, u = column, v = row, integers at pixel "
      "centres. A point outside the image still gets its pixel. Depth is the distance along the "
      "camera's axis.\n"
      "No result (a point behind the camera or past the lens model's valid radius, a ray that "
      "never meets the plane): a message on stderr and exit 3.\n\n"
      "Examples:\n"
      "  occmap project --calibration calib/c0.xml --world 1000 2500 0\n"
      "  occmap project --calibration calib/c0.xml --pixel 320 400 --z 0 --json\n"
      "  occmap project --intrinsics intr_C1.xml --extrinsics extr_C1.xml --image-size 1920 1080 "
      "--world-frame left-handed --world 5 3 0");
  CLI::Option* calibration = command->add_option(
      "--calibration", options->calibration,
      "Tsai (ETISEO/PETS XML) or OpenCV (cv::FileStorage YAML or XML) calibration file");
  CLI::Option* intrinsics = command->add_option(
      "--intrinsics", options->intrinsics,
      "OpenCV intrinsics file (camera_matrix, distortion_coefficients), with --extrinsics");
  CLI::Option* extrinsics = command->add_option(
      "--extrinsics", options->extrinsics,
      "OpenCV extrinsics file (rvec, tvec), with --intrinsics: WILDTRACK's and MultiviewX's "
      "layout");
  intrinsics->needs(extrinsics);
  extrinsics->needs(intrinsics);
  calibration->excludes(intrinsics)->excludes(extrinsics);
  command
      ->add_option("--image-size", options->image_size,
                   "Image width and height in pixels, for a calibration that leaves them out")
      ->expected(2)
      ->check(CLI::Range(1, kMaxImageSide));
  command
      ->add_option("--world-frame", options->world_frame,
                   "right-handed (OpenCV's, the default) or left-handed (Unity's, MultiviewX's: "
                   "floor points at negative depth that cv::projectPoints still projects)")
      ->check(CLI::IsMember({"right-handed", "left-handed"}));
  command
      ->add_option("--units", options->units,
                   "The calibration's length unit, as calibration_units in a config (mm, cm or "
                   "m; cm for WILDTRACK): it names the unit of what is printed, which is the "
                   "file's own (default: mm for Tsai XML, m for OpenCV)")
      ->check(CLI::IsMember({"mm", "cm", "m"}));
  CLI::Option* world =
      command->add_option("--world", options->world, "World point X Y Z to project to a pixel")
          ->expected(3);
  CLI::Option* pixel = command
                           ->add_option("--pixel", options->pixel,
                                        "Pixel U V whose ray to intersect with the plane z = Z")
                           ->expected(2);
  command->add_option("--z", options->z, "Height of the plane for --pixel (default 0, the floor)")
      ->needs(pixel);
  command->add_flag(
      "--json", options->json,
      "Print one JSON object, {\"u\",\"v\",\"depth\"} or {\"x\",\"y\",\"z\",\"depth\"}, "
      "in full double precision");
  world->excludes(pixel);
  return [options, world, pixel, calibration, intrinsics] {
    if (calibration->count() == 0 && intrinsics->count() == 0) {
      std::fprintf(stderr,
                   "occmap project: give --calibration FILE, or --intrinsics F --extrinsics F\n");
      return kExitInvalidInput;
    }
    if (world->count() == 0 && pixel->count() == 0) {
      std::fprintf(stderr, "occmap project: give --world X Y Z or --pixel U V\n");
      return kExitInvalidInput;
    }
    return run(*options);
  };
}

}  // namespace occmap::tools
