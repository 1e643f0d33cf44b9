#include "config/rig.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <filesystem>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "capture/image_file.h"
#include "capture/live_source.h"
#include "capture/open_source.h"
#include "capture/source_spec.h"
#include "config/calibration_file.h"
#include "config/input_error.h"
#include "core/opencv_camera.h"

namespace occmap {
namespace {

std::string sizeText(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

LoadedCalibration loadCameraCalibration(const CameraConfig& camera) {
  return loadCalibration(CalibrationFiles{*camera.calibration, camera.extrinsics},
                         camera.calibration_units, camera.world_frame);
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

  Image readAnyImage(std::string_view key, const std::filesystem::path& file) const {
    std::string error;
    std::optional<Image> image = readGreyImage(file, error);
    if (!image) fail(key, error);
    return std::move(*image);
  }

  Image readImage(std::string_view key, const std::filesystem::path& file, int width,
                  int height) const {
    Image image = readAnyImage(key, file);
    if (image.width() != width || image.height() != height) {
      fail(key, std::string(key) + " " + file.string() + " is " +
                    sizeText(image.width(), image.height()) + " but camera '" + camera_.name +
                    "' delivers " + sizeText(width, height) +
                    " images; use an image of the stream's size");
    }
    return image;
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

Rig Rig::open(const Config& full_config, const RigOptions& options) {
  if (full_config.cameras.empty()) {
    throw InputError(full_config.file.string(), 0, "merge",
                     "is a merge node's config: it merges other daemons' maps and has no cameras "
                     "to open; run it with occmapd, or merge recorded maps with occmap merge");
  }
  Config config = full_config;
  if (options.only_camera) {
    std::string names;
    std::erase_if(config.cameras, [&](const CameraConfig& camera) {
      names += (names.empty() ? "" : ", ") + camera.name;
      return camera.name != *options.only_camera;
    });
    if (config.cameras.empty()) {
      throw InputError(config.file.string(), 0, "cameras",
                       "no camera named '" + *options.only_camera + "'; the cameras are: " + names);
    }
  }
  Rig rig(config);
  rig.notice_ = options.notice;
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
    camera.lighting = entry.effectiveLighting(config.fusion);

    std::optional<LoadedCalibration> calibration;
    if (entry.calibration) calibration = loadCameraCalibration(entry);

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
      const auto& scene_cameras = scene->cameras();
      const auto found = std::find_if(scene_cameras.begin(), scene_cameras.end(),
                                      [&](const auto& c) { return c.name == spec->camera; });
      if (found == scene_cameras.end() && (!calibration || calibration->sizeFromStream())) {
        std::string names;
        for (const auto& c : scene_cameras) names += (names.empty() ? "" : ", ") + c.name;
        opener.fail("source", "scene '" + spec->scene + "' has no camera '" + spec->camera +
                                  "'; its cameras are: " + names);
      }
      if (calibration) {
        // The user's own calibration: the simulator renders what such a camera would see, at the
        // scene camera's size if the file leaves the size to the stream.
        model = calibration->modelFor(found != scene_cameras.end() ? found->calibration.width : 0,
                                      found != scene_cameras.end() ? found->calibration.height : 0);
        units = calibration->units;
      } else {
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
      // A scene's knock turns its own camera; a camera of the user's calibration is never knocked.
      std::optional<SimKnock> knock;
      if (const auto knocked = scene->knock(spec->camera); knocked && !calibration) {
        const auto& tsai = static_cast<const TsaiCamera&>(*model).parameters();
        knock = SimKnock{
            knocked->at_s,
            Camera(std::make_shared<TsaiCamera>(sim::turnedOnItsMount(tsai, knocked->turn)), units,
                   width, height, region)};
      }
      auto sim = std::make_unique<SimSource>(scene, geometry, static_cast<int>(index),
                                             entry.fps.value_or(30.0), std::move(knock));
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
      std::unique_ptr<FrameSource> files = openSource(*spec, {}, error);
      if (!files) opener.fail("source", error);
      const int width = files->width();
      const int height = files->height();
      const std::shared_ptr<const CameraModel> model = calibration->modelFor(width, height);
      camera.camera =
          std::make_unique<Camera>(model, calibration->units, width, height, opener.region(*model));
      if (options.read_backgrounds) {
        camera.background = opener.readImage("background", *entry.background, width, height);
      }
      if (entry.floor_mask) {
        camera.floor_mask = opener.readImage("floor_mask", *entry.floor_mask, width, height);
      }
      camera.source = std::move(files);
    } else {
      // A live camera. Its background (the empty scene, taken with this camera) fixes the stream
      // size the backend must deliver, so the geometry is known before the camera is opened.
      camera.live = true;
      // Making a background (read_backgrounds false) takes the size of the one the config names
      // if it exists already, so that the new one fits the config; else the camera's own size.
      if (options.read_backgrounds ||
          (entry.background && std::filesystem::exists(*entry.background))) {
        camera.background = opener.readAnyImage("background", *entry.background);
        const std::shared_ptr<const CameraModel> model =
            calibration->modelFor(camera.background.width(), camera.background.height());
        camera.camera =
            std::make_unique<Camera>(model, calibration->units, camera.background.width(),
                                     camera.background.height(), opener.region(*model));
        if (entry.floor_mask) {
          camera.floor_mask =
              opener.readImage("floor_mask", *entry.floor_mask, camera.background.width(),
                               camera.background.height());
        }
      }
      rig.cameras_.push_back(std::move(camera));
      if (options.open_live_cameras) rig.openLiveCamera(index, *spec);
      continue;
    }
    rig.cameras_.push_back(std::move(camera));
  }
  return rig;
}

Rig Rig::assemble(Config config, std::vector<RigCamera> cameras) {
  if (config.cameras.size() != cameras.size()) {
    throw std::invalid_argument("Rig::assemble: the config names " +
                                std::to_string(config.cameras.size()) + " cameras, " +
                                std::to_string(cameras.size()) + " were given");
  }
  Rig rig(std::move(config));
  rig.cameras_ = std::move(cameras);
  return rig;
}

void Rig::openLiveCamera(std::size_t index, const SourceSpec& spec) {
  const CameraConfig& entry = config_.cameras[index];
  const CameraOpener opener(config_, index);
  RigCamera& camera = cameras_[index];
  LiveSourceOptions live;
  live.name = entry.name;
  live.fps = entry.fps.value_or(0.0);
  live.settings = entry.settings;
  live.width = camera.background.width();  // 0 without a background: the camera's own size
  live.height = camera.background.height();
  live.notice = notice_;
  std::string error;
  std::unique_ptr<FrameSource> source = openSource(spec, live, error);
  if (!source) opener.fail(entry.settings.empty() ? "source" : "settings", error);
  const int width = source->width();
  const int height = source->height();
  if (!camera.background.empty() &&
      (camera.background.width() != width || camera.background.height() != height)) {
    opener.fail("background", "background " + entry.background->string() + " is " +
                                  sizeText(camera.background.width(), camera.background.height()) +
                                  " but the camera delivers " + sizeText(width, height));
  }
  if (!camera.camera) {
    // Opened without its background (to make one): the geometry follows the camera.
    const LoadedCalibration calibration = loadCameraCalibration(entry);
    const std::shared_ptr<const CameraModel> model = calibration.modelFor(width, height);
    camera.camera =
        std::make_unique<Camera>(model, calibration.units, width, height, opener.region(*model));
    if (entry.floor_mask) {
      camera.floor_mask = opener.readImage("floor_mask", *entry.floor_mask, width, height);
    }
  }
  camera.source = std::move(source);
}

namespace {

// Two live cameras of two configs are the same connection when nothing the backend applies has
// changed: source, settings, rate and size.
bool sameConnection(const CameraConfig& a, const RigCamera& camera_a, const CameraConfig& b,
                    const RigCamera& camera_b) {
  return a.source == b.source && a.settings == b.settings && a.fps == b.fps &&
         camera_a.background.width() == camera_b.background.width() &&
         camera_a.background.height() == camera_b.background.height();
}

// Whether some pixel of a 9 x 9 grid over the image looks down at the floor in front of the camera.
bool seesTheFloor(const Camera& camera) {
  constexpr int kSteps = 8;
  for (int i = 0; i <= kSteps; ++i) {
    for (int j = 0; j <= kSteps; ++j) {
      const Eigen::Vector2d pixel(-0.5 + camera.streamWidth() * i / double{kSteps},
                                  -0.5 + camera.streamHeight() * j / double{kSteps});
      if (camera.streamToPlane(pixel, 0.0)) return true;
    }
  }
  return false;
}

// The camera with its world frame taken as left-handed, or none when it is not an OpenCV camera or
// is left-handed already.
std::optional<Camera> mirroredTwin(const Camera& camera) {
  const auto* opencv = dynamic_cast<const OpenCvCamera*>(&camera.model());
  if (opencv == nullptr || opencv->parameters().world_frame == WorldFrame::kLeftHanded) {
    return std::nullopt;
  }
  OpenCvParameters mirrored = opencv->parameters();
  mirrored.world_frame = WorldFrame::kLeftHanded;
  return camera.withModel(std::make_shared<OpenCvCamera>(mirrored));
}

// Whether the camera would see the map with its world frame taken as left-handed: a camera that
// sees none of it, but would mirrored, most likely has a calibration made in Unity's frame
// (MultiviewX), whose points cv::projectPoints still lands in the image. Looked at over a 33 x 33
// grid of the map's cells, so that a camera that also sees past the horizon (whose mirrored rays
// meet the floor far from the map) is named too.
bool seesTheMapMirrored(const Camera& camera, const MapGeometry& map) {
  const std::optional<Camera> mirrored = mirroredTwin(camera);
  if (!mirrored) return false;
  constexpr int kSteps = 32;
  for (int i = 0; i <= kSteps; ++i) {
    for (int j = 0; j <= kSteps; ++j) {
      const Eigen::Vector2d cell =
          map.cellCentre((map.height - 1) * i / kSteps, (map.width - 1) * j / kSteps);
      const std::optional<Eigen::Vector2d> pixel =
          mirrored->worldToStream(Eigen::Vector3d(cell.x(), cell.y(), 0.0));
      if (pixel && mirrored->pixelIndexAt(*pixel)) return true;
    }
  }
  return false;
}

// Whether the camera, seeing no floor, would see it with its world frame taken as left-handed.
bool seesTheFloorMirrored(const Camera& camera) {
  const std::optional<Camera> mirrored = mirroredTwin(camera);
  return mirrored && seesTheFloor(*mirrored);
}

}  // namespace

void Rig::openLiveCameras(Rig* previous) {
  if (previous != nullptr) {
    // Take over the unchanged connections, then close the rest of the previous rig's cameras
    // before opening anything, so that a camera whose settings changed is free to reopen.
    for (std::size_t k = 0; k < cameras_.size(); ++k) {
      if (!cameras_[k].live || cameras_[k].source) continue;
      for (std::size_t j = 0; j < previous->cameras_.size(); ++j) {
        RigCamera& old = previous->cameras_[j];
        if (old.live && old.source &&
            sameConnection(config_.cameras[k], cameras_[k], previous->config_.cameras[j], old)) {
          cameras_[k].source = std::move(old.source);
          if (notice_) notice_("camera " + cameras_[k].name + ": its connection carries over");
          break;
        }
      }
    }
    for (RigCamera& old : previous->cameras_) {
      if (old.live) old.source.reset();
    }
  }
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    if (!cameras_[k].live || cameras_[k].source) continue;
    std::string error;
    const std::optional<SourceSpec> spec =
        parseSource(config_.cameras[k].source, config_.file.parent_path(), error);
    openLiveCamera(k, *spec);  // parsed once already by open()
    if (previous != nullptr && notice_) {
      notice_("camera " + cameras_[k].name +
              ": opened anew (its source, settings, rate or size changed)");
    }
  }
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
  // One camera's table at a time on each core, this thread included (core/ starts no threads;
  // these are joined before returning): a reload's tables are ready that much sooner. `built`
  // hears on this thread only, as tables are done.
  const std::size_t count = cameras_.size();
  std::vector<CarveTable> tables(count);
  std::vector<std::exception_ptr> errors(count);
  std::atomic<std::size_t> next{0};
  std::mutex mutex;
  std::condition_variable finished;
  std::size_t done = 0;  // guarded by mutex
  auto buildSome = [&] {
    for (std::size_t k = next++; k < count; k = next++) {
      try {
        tables[k] = buildCarveTable(*cameras_[k].camera, config_.map, column_height_m,
                                    cameras_[k].floor_mask.view());
      } catch (...) {
        errors[k] = std::current_exception();
      }
      {
        const std::lock_guard lock(mutex);
        ++done;
      }
      finished.notify_one();
    }
  };
  std::size_t reported = 0;
  auto report = [&] {
    std::size_t now = 0;
    {
      const std::lock_guard lock(mutex);
      now = done;
    }
    for (; reported < now; ++reported) {
      if (built) built(reported + 1);
    }
  };
  {
    std::vector<std::jthread> helpers;
    const std::size_t threads =
        std::min<std::size_t>(std::max(1u, std::thread::hardware_concurrency()), count);
    try {
      while (helpers.size() + 1 < threads) helpers.emplace_back(buildSome);
    } catch (const std::system_error&) {
      // No more threads to be had: those there are, and this one, build them all the same.
    }
    buildSome();
    while (reported < count) {
      {
        std::unique_lock lock(mutex);
        finished.wait(lock, [&] { return done > reported; });
      }
      report();
    }
  }
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
  for (std::size_t k = 0; k < count; ++k) {
    if (tables[k].cellsInView() == 0) {
      // Not an error: the camera runs on with an empty table and the others make the map. But
      // the user is told which of the two usual slips it is, so that they know what to fix.
      const Camera& camera = *cameras_[k].camera;
      const bool left_handed = seesTheMapMirrored(camera, config_.map) ||
                               (!seesTheFloor(camera) && seesTheFloorMirrored(camera));
      const std::string why =
          left_handed
              ? "the map's floor lies behind the camera (negative depth), as when the "
                "extrinsics were made in a left-handed world frame (Unity's, MultiviewX's), "
                "where cv::projectPoints still lands them in the image: if so, add "
                "world_frame: left-handed to the camera (if not, its rotation turns it away "
                "from the map)"
          : seesTheFloor(camera)
              ? "check its calibration (and calibration_units) against the map's origin_m and "
                "size"
              : "no ray of its image meets the floor in front of it (the floor is behind the "
                "camera or above its view): check the rotation in its calibration";
      warnings_.push_back("camera '" + cameras_[k].name +
                          "' sees no cell of the map, so it decides none (an empty carve "
                          "table): " +
                          why);
    }
  }
  return tables;
}

}  // namespace occmap
