// occmap fuse: off-line fusion of every camera's frames, in lockstep, into one map per frame set.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>
#include <optional>
#include <string_view>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "capture/image_file.h"
#include "config/config.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "config/rig.h"
#include "core/changed_pixels.h"
#include "core/fusion_kernel.h"
#include "core/repose.h"
#include "tools/commands.h"
#include "tools/map_files.h"
#include "tools/offline_footprints.h"
#include "tools/pictures.h"
#include "tools/progress.h"
#include "transport/status_text.h"

namespace occmap::tools {
namespace {

namespace fs = std::filesystem;

struct FuseOptions {
  std::string config;
  std::string out;
  std::uint64_t frames = 0;  // 0: until the first source ends
  bool overwrite = false;
  std::string snapshot;
  std::string detections;  // CSV of the footprints found on each map (occmap detect)
  std::string tracks;      // CSV of the people followed (occmap track)
  std::string truth;       // CSV of the simulated scene's objects (--truth)
  const char* command = "fuse";
};

// Where the cells a camera sees clearly and the map does not free lie: under light in part of the
// room (a lamp, the sun, a shadow: sim::LightPatch), else within kNear of an object's footprint
// (where 0.3 m columns keep the floor next to objects), else elsewhere.
struct NotFreed {
  std::uint64_t in_light = 0, near_objects = 0, elsewhere = 0;
  static constexpr double kNear = 0.3;
  NotFreed& operator+=(const NotFreed& more) {
    in_light += more.in_light;
    near_objects += more.near_objects;
    elsewhere += more.elsewhere;
    return *this;
  }
};

// The maps against the simulator's ground truth, summed over frames; and the same over the maps
// more than a second after every sudden change of the scene (Scene::eventTimes), with the worst
// such map's share of clearly seen cells free and where its cells not freed lie.
struct TruthScore {
  std::uint64_t inside_cells = 0, inside_kept = 0;  // cells wholly inside objects, not free
  std::uint64_t clear_cells = 0, clear_free = 0;    // cells a camera sees clearly, free
  std::uint64_t objects = 0, objects_found = 0;     // objects with a non-free cell inside
  std::uint64_t settled_maps = 0, settled_objects = 0, settled_found = 0;
  double settled_worst_free = 1.0;  // share of the clearly seen cells free
  std::uint64_t settled_worst_map = 0;
  std::uint64_t settled_worst_clear = 0;
  NotFreed not_freed, settled_worst_not_freed;
  std::uint64_t maps = 0;

  void add(const OccupancyMap& map, const sim::GroundTruth& truth,
           const std::vector<sim::SceneObject>& scene_objects,
           const std::vector<sim::LightPatch>& patches, bool settled) {
    std::uint64_t clear = 0, free_clear = 0, found = 0;
    NotFreed here;
    for (std::size_t cell = 0; cell < map.cells.size(); ++cell) {
      const bool free = map.cells[cell] == CellState::kFree;
      if (truth.footprint[cell] == sim::GroundTruth::kInside) {
        ++inside_cells;
        inside_kept += free ? 0 : 1;
      } else if (truth.footprint[cell] == sim::GroundTruth::kClear && truth.clear_view[cell]) {
        ++clear;
        free_clear += free ? 1 : 0;
        if (!free) {
          const Eigen::Vector2d centre = map.geometry.cellCentre(cell);
          const auto lit = [&](const sim::LightPatch& patch) { return patch.at(centre) != 1.0; };
          const auto near = [&](const sim::SceneObject& object) {
            return object.solid.footprintDistance(centre) <= NotFreed::kNear;
          };
          if (std::any_of(patches.begin(), patches.end(), lit)) {
            ++here.in_light;
          } else if (std::any_of(scene_objects.begin(), scene_objects.end(), near)) {
            ++here.near_objects;
          } else {
            ++here.elsewhere;
          }
        }
      }
    }
    not_freed += here;
    for (const std::vector<int>& cells : truth.object_cells) {
      for (const int cell : cells) {
        if (map.cells[static_cast<std::size_t>(cell)] != CellState::kFree) {
          ++found;
          break;
        }
      }
    }
    clear_cells += clear;
    clear_free += free_clear;
    objects += truth.object_cells.size();
    objects_found += found;
    if (settled) {
      ++settled_maps;
      settled_objects += truth.object_cells.size();
      settled_found += found;
      const double share =
          clear == 0 ? 1.0 : static_cast<double>(free_clear) / static_cast<double>(clear);
      if (share < settled_worst_free) {
        settled_worst_free = share;
        settled_worst_map = maps;
        settled_worst_clear = clear;
        settled_worst_not_freed = here;
      }
    }
    ++maps;
  }
};

// What the local light (core/local_light.h) made of the changed tiles of every camera and frame:
// where a lamp or the sun is left changed, and why.
void printLocalLight(const LocalLight::Tally& t) {
  const auto share = [&t](std::uint64_t n) {
    return 100.0 * static_cast<double>(n) / static_cast<double>(t.changed);
  };
  std::printf(
      "the local light: of %llu changed tiles (every camera, every map), %.1f %% cleared as light "
      "(%.1f %% seeds, %.1f %% of them with a gain that changes across the tile; %.1f %% reached "
      "from seeds; %.1f %% as captured); no seed: %.1f %% too flat to tell, %.1f %% no gain fits, "
      "%.1f %% clipped, %.1f %% beyond the gain's bounds, %.1f %% a pixel past the threshold\n",
      static_cast<unsigned long long>(t.changed), share(t.seeds + t.reached + t.as_captured),
      share(t.seeds),
      t.seeds > 0 ? 100.0 * static_cast<double>(t.sloped) / static_cast<double>(t.seeds) : 0.0,
      share(t.reached), share(t.as_captured), share(t.flat), share(t.misfit), share(t.clipped),
      share(t.out_of_range), share(t.pixel));
}

int run(const FuseOptions& o) {
  const Config config = loadConfig(o.config);
  const fs::path out(o.out);
  if (!o.snapshot.empty() && fs::weakly_canonical(fs::absolute(o.snapshot)).parent_path() ==
                                 fs::weakly_canonical(fs::absolute(out))) {
    throw InputError(o.snapshot, 0, "--snapshot",
                     "must not go into the maps' folder, which holds only map_NNNNNN.png files");
  }
  // Everything that can be wrong with the input is found before anything is written: a bad
  // calibration, source or background must not leave an empty or emptied folder behind.
  const bool write_maps = !o.out.empty();
  const std::vector<fs::path> old_maps =
      write_maps ? checkOutput(out, o.overwrite, o.command) : std::vector<fs::path>{};
  PreparedRig prepared = prepareRigWithProgress(config, o.command);
  if (write_maps) makeOutput(out, old_maps);
  Rig& rig = prepared.rig;
  const std::vector<CarveTable>& tables = prepared.tables;
  const double column_height = prepared.column_height_m;
  std::vector<RigCamera>& cameras = rig.cameras();

  std::optional<sim::TruthMaker> truth_maker;
  if (rig.commonScene() != nullptr) {
    std::vector<const sim::Renderer*> renderers;
    renderers.reserve(cameras.size());
    for (const RigCamera& camera : cameras) renderers.push_back(&camera.sim->renderer());
    truth_maker.emplace(renderers, config.map);
  }

  std::uint64_t total = o.frames;
  for (const RigCamera& camera : cameras) {
    const std::uint64_t count = camera.source->frameCount();
    if (count > 0 && (total == 0 || count < total)) total = count;
  }

  // The daemon's kernel, used as daemon/pipeline.cpp uses it (each camera's changed pixels marked
  // as its frame arrives, then the masks fused), so that these maps are the daemon's maps at the
  // daemon's speed. (Its tests hold it to the reference fusion, cell for cell.)
  FusionKernel kernel(tables);
  std::vector<std::vector<std::uint8_t>> changed(cameras.size());
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    changed[k].assign(changedMaskBytes(cameras[k].source->width(), cameras[k].source->height()), 0);
  }
  OfflineFootprints footprints(config, cameras, o.detections, o.tracks, o.truth);
  std::vector<ChangedPixels> changed_pixels;
  for (const RigCamera& camera : cameras)
    changed_pixels.emplace_back(camera.lighting, *camera.camera);
  // Per camera: the frames no light explained (left out), the first map at which its view was
  // found moved, and the maps it was re-posed at (core/repose.h), each with its turn.
  struct ViewReport {
    std::uint64_t left_out = 0;
    std::optional<std::uint64_t> moved_at;
    ViewMotion motion;
    CameraTurn turn;
    std::vector<std::pair<std::uint64_t, double>> reposed;  // map, degrees
  };
  std::vector<ViewReport> views(cameras.size());
  // What each camera differences against and votes with: the config's, until it is re-posed. The
  // re-posed ones are all kept (the light's model knows its background by its address).
  std::vector<const Image*> backgrounds;
  std::vector<const Image*> floor_masks;
  for (const RigCamera& camera : cameras) {
    backgrounds.push_back(&camera.background);
    floor_masks.push_back(&camera.floor_mask);
  }
  std::vector<std::unique_ptr<Image>> reposed_images;
  std::vector<const std::uint8_t*> masks(cameras.size(), nullptr);
  std::vector<ImageView> live(cameras.size());
  OccupancyMap map(config.map);

  Progress progress("fusing", total);
  std::vector<std::pair<std::string, Image>> last_images;
  std::optional<OccupancyMap> last_map;
  std::uint64_t maps = 0;
  std::uint64_t counts[3] = {0, 0, 0};
  TruthScore score;
  std::vector<sim::SceneObject> objects;  // the scene's at each frame set, for the score
  std::vector<sim::LightPatch> patches;
  LocalLight::Tally local_light;  // every camera's, every frame's
  while (o.frames == 0 || maps < o.frames) {
    bool ended = false;
    for (std::size_t k = 0; k < cameras.size() && !ended; ++k) {
      Frame frame;
      const FrameSource::Status status = cameras[k].source->read(frame);
      if (status == FrameSource::Status::kEnd) ended = true;
      if (status == FrameSource::Status::kError) {
        progress.finish();
        throw InputError(config.file.string(), config.cameras[k].lineOf("source"),
                         "cameras[" + std::to_string(k) + "].source",
                         cameras[k].source->lastError() + " (after " + std::to_string(maps) +
                             " maps were written)");
      }
      // Without a frame (a live camera's timeout) the camera is left out of this frame set, as the
      // daemon leaves out a camera that has none: its cells count only if another camera sees them.
      live[k] = status == FrameSource::Status::kFrame ? frame.image : ImageView{};
      masks[k] = nullptr;
      // A frame the light's model does not explain counts as none, as in the daemon. The time of a
      // simulated frame is the scene's (its capture time is when it was rendered, which off-line
      // is as fast as it goes): so a run gives the same maps however fast the machine.
      const std::int64_t time_us =
          cameras[k].sim != nullptr
              ? static_cast<std::int64_t>(
                    std::llround(static_cast<double>(frame.sequence) * 1e6 / cameras[k].sim->fps()))
              : frame.capture_time_us;
      if (status == FrameSource::Status::kFrame &&
          changed_pixels[k].mark(kernel, k, frame.image, *backgrounds[k], cameras[k].threshold,
                                 changed[k].data(), time_us)) {
        masks[k] = changed[k].data();
      }
      if (const LightingModel* model = changed_pixels[k].lighting();
          status == FrameSource::Status::kFrame && model != nullptr && model->local() != nullptr) {
        local_light += model->local()->tally();
      }
      if (status == FrameSource::Status::kFrame && !masks[k]) {
        ++views[k].left_out;
        if (changed_pixels[k].view() == ViewState::kMoved && !views[k].moved_at) {
          views[k].moved_at = maps;
          views[k].motion = changed_pixels[k].motion();
          views[k].turn = changed_pixels[k].turn();
        }
      }
      // A moved camera steady for long enough: re-posed here and now, as occmapd does it on a
      // thread of its own (its next frames are differenced against its new background).
      if (const auto turn = changed_pixels[k].takeReposeTurn()) {
        ReposedCamera reposed =
            reposeCamera(changed_pixels[k].camera(), *turn, backgrounds[k]->view(),
                         floor_masks[k]->view(), config.map, column_height);
        kernel.replaceCamera(k, reposed.table);
        changed_pixels[k].reposed(reposed.camera);
        footprints.reposed(k, reposed.camera);
        reposed_images.push_back(std::make_unique<Image>(std::move(reposed.background)));
        backgrounds[k] = reposed_images.back().get();
        reposed_images.push_back(std::make_unique<Image>(std::move(reposed.floor_mask)));
        floor_masks[k] = reposed_images.back().get();
        views[k].reposed.emplace_back(maps, turn->norm() * 180 / std::numbers::pi);
      }
    }
    if (ended) break;
    kernel.fuse(masks, map.cells);
    char name[32];
    std::snprintf(name, sizeof name, "map_%06llu.png", static_cast<unsigned long long>(maps));
    std::string error;
    if (write_maps && !writeGreyPng(out / name, mapImage(map), error)) {
      progress.finish();
      std::fprintf(stderr, "occmap fuse: %s\n", error.c_str());
      return kExitFailure;
    }
    for (const CellState state : map.cells) ++counts[static_cast<int>(state)];
    if (truth_maker) {
      const double t = cameras.front().sim->lastTime();
      const std::vector<double> events = cameras.front().sim->scene().eventTimes();
      const bool settled = std::none_of(events.begin(), events.end(), [t](double event) {
        return t >= event && t < event + 1.0;
      });
      const sim::Scene& scene = cameras.front().sim->scene();
      scene.objectsAt(t, objects);
      scene.lightPatches(t, patches);
      score.add(map, truth_maker->at(objects), objects, patches, settled);
    }
    footprints.add(maps, masks, map.cells, truth_maker ? &objects : nullptr);
    if (!o.snapshot.empty()) {
      last_images.clear();
      for (std::size_t k = 0; k < cameras.size(); ++k) {
        Image copy(live[k].width, live[k].height);
        for (int v = 0; v < copy.height(); ++v) {
          std::copy_n(live[k].row(v), copy.width(), copy.row(v));
        }
        last_images.emplace_back(cameras[k].name, std::move(copy));
      }
      last_map = map;
    }
    ++maps;
    progress.update(maps);
  }
  const double seconds = progress.elapsedSeconds();
  progress.finish();
  if (maps == 0) {
    std::fprintf(stderr, "occmap fuse: no map written: a source had no frames\n");
    return kExitNoResult;
  }
  if (last_map && !cv::imwrite(o.snapshot, snapshot(last_images, *last_map))) {
    std::fprintf(stderr, "occmap fuse: cannot write the snapshot %s\n", o.snapshot.c_str());
    return kExitFailure;
  }
  const std::uint64_t cells = maps * config.map.cellCount();
  if (!footprints.finishFiles(o.command, maps, seconds)) return kExitFailure;
  if (write_maps)
    std::printf(
        "wrote %llu maps (%dx%d cells of %.3g m, column height %.3g m) to %s in %.1f s "
        "(%.1f maps/s); cells free %.1f %%, occupied %.1f %%, unseen %.1f %%\n",
        static_cast<unsigned long long>(maps), config.map.width, config.map.height,
        config.map.cell_size_m, column_height, out.string().c_str(), seconds,
        static_cast<double>(maps) / seconds, percent(counts[0], cells), percent(counts[1], cells),
        percent(counts[2], cells));
  if (truth_maker) {
    std::printf(
        "against the simulator's ground truth: %.2f %% of cells under objects not free; "
        "objects found %llu of %llu (%.2f %%); %.2f %% of cells a camera sees clearly "
        "are free\n",
        percent(score.inside_kept, score.inside_cells),
        static_cast<unsigned long long>(score.objects_found),
        static_cast<unsigned long long>(score.objects), percent(score.objects_found, score.objects),
        percent(score.clear_free, score.clear_cells));
    if (score.settled_maps < maps) {
      std::printf(
          "over the %llu maps more than 1 s after every sudden change of the scene: objects found "
          "%llu of %llu (%.2f %%); the worst, map %llu, has %.2f %% of the cells a camera sees "
          "clearly free\n",
          static_cast<unsigned long long>(score.settled_maps),
          static_cast<unsigned long long>(score.settled_found),
          static_cast<unsigned long long>(score.settled_objects),
          percent(score.settled_found, score.settled_objects),
          static_cast<unsigned long long>(score.settled_worst_map),
          100.0 * score.settled_worst_free);
    }
    const auto shares = [](const NotFreed& not_free, std::uint64_t clear) {
      char text[160];
      std::snprintf(text, sizeof text,
                    "%.2f %% under light in part of the room, %.2f %% within %.1f m of an object, "
                    "%.2f %% elsewhere",
                    percent(not_free.in_light, clear), percent(not_free.near_objects, clear),
                    NotFreed::kNear, percent(not_free.elsewhere, clear));
      return std::string(text);
    };
    std::printf("of the cells a camera sees clearly, not free: %s",
                shares(score.not_freed, score.clear_cells).c_str());
    if (score.settled_maps < maps) {
      std::printf("; at the worst map after the events: %s",
                  shares(score.settled_worst_not_freed, score.settled_worst_clear).c_str());
    }
    std::printf("\n");
  }
  if (local_light.changed > 0) printLocalLight(local_light);
  footprints.printZones();
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    const ViewReport& view = views[k];
    if (view.left_out == 0) continue;
    std::printf("camera %s: %llu frames left out, no change of light explaining them",
                cameras[k].name.c_str(), static_cast<unsigned long long>(view.left_out));
    if (view.moved_at) {
      std::printf(
          "; its view moved at map %llu: turned %.2f degrees (the image shifted %s at its "
          "centre, %.2f px off a turn alone)",
          static_cast<unsigned long long>(*view.moved_at), view.turn.degrees(),
          imageShiftText(view.motion.shift_x_px, view.motion.shift_y_px).c_str(),
          view.turn.residual_px);
    }
    for (const auto& [at_map, degrees] : view.reposed) {
      std::printf("; re-posed at map %llu (turned %.2f degrees)",
                  static_cast<unsigned long long>(at_map), degrees);
    }
    if (view.moved_at && view.reposed.empty()) {
      std::printf(": put the camera back or calibrate it again");
    }
    std::printf("\n");
  }
  return kExitOk;
}

}  // namespace

Command addFuseCommand(CLI::App& app) {
  auto options = std::make_shared<FuseOptions>();
  CLI::App* command = app.add_subcommand(
      "fuse",
      "Fuse every camera's frames off-line into maps, one per frame set.\n"
      "Reads each camera's files:// or sim:// source in lockstep until the first one ends (or "
      "--frames), and writes DIR/map_000000.png, map_000001.png, ... and nothing else: 8-bit grey, "
      "0 free, 255 occupied, 128 unseen, picture row r = map row r (the floor plan mirrored top "
      "to bottom, as the map's rows go from the smallest y).\n"
      "With simulated cameras it also scores the maps against the scene's ground truth.\n\n"
      "Example:\n"
      "  occmap fuse --config examples/sim-room.yaml --out maps --frames 90");
  command->add_option("--config", options->config, "Config file (YAML; see README)")->required();
  command->add_option("--out", options->out, "Folder for the maps (new, or empty)")->required();
  command->add_option("--frames", options->frames, "Stop after this many frame sets")
      ->check(CLI::PositiveNumber);
  command->add_flag("--overwrite", options->overwrite,
                    "Replace the maps an earlier run left in the folder");
  command->add_option("--snapshot", options->snapshot,
                      "Also write a picture of the last frame set's camera images next to its "
                      "map, drawn as a floor plan (PNG; outside the maps' folder)");
  return [options] { return run(*options); };
}

Command addTrackCommand(CLI::App& app) {
  auto options = std::make_shared<FuseOptions>();
  options->command = "track";
  CLI::App* command = app.add_subcommand(
      "track",
      "The people on the maps followed from map to map, off-line (docs/detection.md).\n"
      "Detects as occmap detect does and follows the detections with a constant-velocity Kalman "
      "filter each, given to the tracks by the optimal assignment; a track is reported after 3 "
      "detections within 1 s and ends after 2 s without one. Writes one CSV row per track and "
      "map: frame,track_id,x_m,y_m,vx_m_s,vy_m_s,area_m2. The time between maps is 1 / fps of "
      "the first camera (the simulator's, or the config's fps for files://; 30 lacking one).\n\n"
      "Example:\n"
      "  occmap track --config examples/sim-room.yaml --out tracks.csv --frames 300");
  command->add_option("--config", options->config, "Config file (YAML; see README)")->required();
  command->add_option("--out", options->tracks, "Tracks CSV to write")->required();
  command->add_option("--truth", options->truth,
                      "With simulated cameras: also write the scene's objects on each map as a "
                      "truth CSV for occmap score (frame,x_m,y_m,id,kind; id: the object's, kind: "
                      "person, chair, robot or box)");
  command->add_option("--frames", options->frames, "Stop after this many frame sets")
      ->check(CLI::PositiveNumber);
  return [options] { return run(*options); };
}

Command addDetectCommand(CLI::App& app) {
  auto options = std::make_shared<FuseOptions>();
  options->command = "detect";
  CLI::App* command = app.add_subcommand(
      "detect",
      "The people and objects on each map, off-line: where the cameras' evidence says something "
      "stands (docs/detection.md).\n"
      "Fuses every camera's frames as occmap fuse does and writes one CSV row per detection, "
      "frame,x_m,y_m,area_m2,score: frame is the frame set's index from 0, (x_m, y_m) the "
      "footprint's centre on the floor, area_m2 the occupied floor under a person-sized box "
      "there, score the least share of changed pixels any camera that sees it finds in its box "
      "(0 to 1). People are looked for with a person's box (0.5 x 1.75 m), then, where no one was "
      "found, what stands lower with a 0.5 m box (a cart, a small robot). The config's footprints "
      "section sets the boxes and the rules. With simulated cameras it also scores the detections "
      "against the scene's objects, and says how many of each kind were found.\n\n"
      "Example (EPFL Terrace; then occmap score, docs/detection.md):\n"
      "  occmap detect --config examples/epfl-terrace.yaml --out detections.csv");
  command->add_option("--config", options->config, "Config file (YAML; see README)")->required();
  command->add_option("--out", options->detections, "Detections CSV to write")->required();
  command->add_option("--truth", options->truth,
                      "With simulated cameras: also write the scene's objects on each map as a "
                      "truth CSV for occmap score (frame,x_m,y_m,id,kind; id: the object's, kind: "
                      "person, chair, robot or box)");
  command->add_option("--frames", options->frames, "Stop after this many frame sets")
      ->check(CLI::PositiveNumber);
  return [options] { return run(*options); };
}

}  // namespace occmap::tools
