#include "daemon/rig.h"

#include <algorithm>

#include "capture/files_source.h"
#include "capture/image_file.h"
#include "capture/source_spec.h"
#include "daemon/calibration_file.h"
#include "daemon/input_error.h"

namespace occmap {
namespace {

std::string sizeText(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

class CameraOpener {
 public:
  CameraOpener(const Config& config, std::size_t index)
      : config_(config), camera_(config.cameras[index]), index_(index) {}

  [[noreturn]] void fail(std::string_view key, const std::string& message) const {
    throw InputError(
        config_.file.string(), camera_.lineOf(key),
        "cameras[" + std::to_string(index_) + "]" + (key.empty() ? "" : ".") + std::string(key),
        message);
  }

  Image readImage(std::string_view key, const std::filesystem::path& file, int width,
                  int height) const {
    std::string error;
    std::optional<Image> image = readGreyImage(file, error);
    if (!image) fail(key, error);
    if (image->width() != width || image->height() != height) {
      fail(key, std::string(key) + " " + file.string() + " is " +
                    sizeText(image->width(), image->height()) + " but camera '" + camera_.name +
                    "' delivers " + sizeText(width, height) +
                    " images; use an image of the "
                    "stream's size");
    }
    return *image;
  }

  // The calibration's region of the stream, checked against the calibration frame.
  ImageRegion region(const CameraModel& model) const {
    if (!camera_.image_region) return {};
    const ImageRegion& r = *camera_.image_region;
    if (r.x0 + r.width > model.width() + 1e-9 || r.y0 + r.height > model.height() + 1e-9) {
      fail("image_region", "image_region reaches beyond the " +
                               sizeText(model.width(), model.height()) +
                               " calibration frame; it is [x0, y0, width, height] in calibration "
                               "pixels");
    }
    return r;
  }

 private:
  const Config& config_;
  const CameraConfig& camera_;
  std::size_t index_;
};

}  // namespace

Rig Rig::open(const Config& config) {
  Rig rig(config);
  for (std::size_t index = 0; index < config.cameras.size(); ++index) {
    const CameraConfig& entry = config.cameras[index];
    const CameraOpener opener(config, index);
    std::string error;
    const std::optional<SourceSpec> spec =
        parseSource(entry.source, config.file.parent_path(), error);
    if (!spec) opener.fail("source", error);
    RigCamera camera;
    camera.name = entry.name;
    camera.threshold = entry.effectiveThreshold(config.fusion);

    std::optional<LoadedCalibration> calibration;
    if (entry.calibration)
      calibration = loadCalibration(*entry.calibration, entry.calibration_units);

    if (spec->kind == SourceSpec::Kind::kSim) {
      std::shared_ptr<const sim::Scene> scene;
      for (const auto& known : rig.scenes_) {
        if (known->name() == spec->scene) scene = known;
      }
      if (!scene) {
        scene = sim::makeScene(spec->scene);
        if (!scene) {
          std::string names;
          for (const std::string& name : sim::sceneNames())
            names += (names.empty() ? "" : ", ") + name;
          opener.fail("source", "no simulated scene '" + spec->scene +
                                    "'; the built-in scenes are: " + names);
        }
        rig.scenes_.push_back(scene);
      }
      std::shared_ptr<const CameraModel> model;
      LengthUnit units = LengthUnit::kMillimetre;
      if (calibration) {
        // The user's own calibration: the simulator renders what such a camera would see.
        model = calibration->model;
        units = calibration->units;
      } else {
        const auto& scene_cameras = scene->cameras();
        const auto found = std::find_if(scene_cameras.begin(), scene_cameras.end(),
                                        [&](const auto& c) { return c.name == spec->camera; });
        if (found == scene_cameras.end()) {
          std::string names;
          for (const auto& c : scene_cameras) names += (names.empty() ? "" : ", ") + c.name;
          opener.fail("source", "scene '" + spec->scene + "' has no camera '" + spec->camera +
                                    "'; its cameras are: " + names);
        }
        model = std::make_shared<TsaiCamera>(found->calibration);
      }
      const ImageRegion region = opener.region(*model);
      const int width = region.width > 0 ? static_cast<int>(region.width) : model->width();
      const int height = region.height > 0 ? static_cast<int>(region.height) : model->height();
      const Camera geometry(model, units, width, height, region);
      if (!scene->roomContains(geometry.centreMetres())) {
        opener.fail(calibration ? "calibration" : "source",
                    "a simulated camera must stand inside the scene's room");
      }
      auto sim = std::make_unique<SimSource>(scene, geometry, static_cast<int>(index),
                                             entry.fps.value_or(30.0));
      camera.sim = sim.get();
      camera.camera = std::make_unique<Camera>(geometry);
      camera.background = entry.background
                              ? opener.readImage("background", *entry.background, width, height)
                              : sim->renderer().background();
      camera.floor_mask = entry.floor_mask
                              ? opener.readImage("floor_mask", *entry.floor_mask, width, height)
                              : sim->renderer().floorMask();
      camera.source = std::move(sim);
    } else if (spec->kind == SourceSpec::Kind::kFiles) {
      std::unique_ptr<FilesSource> files = FilesSource::open(spec->pattern, error);
      if (!files) opener.fail("source", error);
      const int width = files->width();
      const int height = files->height();
      camera.camera = std::make_unique<Camera>(calibration->model, calibration->units, width,
                                               height, opener.region(*calibration->model));
      camera.background = opener.readImage("background", *entry.background, width, height);
      if (entry.floor_mask) {
        camera.floor_mask = opener.readImage("floor_mask", *entry.floor_mask, width, height);
      }
      camera.source = std::move(files);
    } else {
      opener.fail("source",
                  "live camera sources (aravis://, v4l2://) are not in this build yet; "
                  "use files:// or sim://");
    }
    rig.cameras_.push_back(std::move(camera));
  }
  return rig;
}

const sim::Scene* Rig::commonScene() const {
  if (scenes_.size() != 1) return nullptr;
  for (const RigCamera& camera : cameras_) {
    if (!camera.sim) return nullptr;
  }
  return scenes_.front().get();
}

std::vector<CarveTable> Rig::buildTables(double column_height_m,
                                         const std::function<void(std::size_t built)>& built) {
  std::vector<CarveTable> tables;
  for (const RigCamera& camera : cameras_) {
    tables.push_back(
        buildCarveTable(*camera.camera, config_.map, column_height_m, camera.floor_mask.view()));
    if (tables.back().cellsInView() == 0) {
      warnings_.push_back("camera '" + camera.name +
                          "' sees no cell of the map: check its calibration (and "
                          "calibration_units) against the map's origin_m and size");
    }
    if (built) built(tables.size());
  }
  return tables;
}

}  // namespace occmap
