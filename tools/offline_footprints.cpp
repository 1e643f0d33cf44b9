#include "tools/offline_footprints.h"

#include <cstdio>
#include <string_view>

#include "config/input_error.h"
#include "tools/progress.h"

namespace occmap::tools {
namespace {

std::vector<Camera> posedCameras(const std::vector<RigCamera>& cameras) {
  std::vector<Camera> posed;
  for (const RigCamera& camera : cameras) posed.push_back(*camera.camera);
  return posed;
}

void openCsv(std::ofstream& file, const std::string& path, const char* what, const char* header) {
  file.open(path);
  if (!file) throw InputError(path, 0, "--out", std::string("cannot write the ") + what + " here");
  file << header << "\n";
}

}  // namespace

OfflineFootprints::OfflineFootprints(const Config& config, const std::vector<RigCamera>& cameras,
                                     const std::string& detections_csv,
                                     const std::string& tracks_csv, const std::string& truth_csv)
    : config_(config),
      detections_path_(detections_csv),
      tracks_path_(tracks_csv),
      truth_path_(truth_csv),
      posed_(posedCameras(cameras)),
      zones_(config.footprints.hidden_floor_unseen &&
                     (!detections_csv.empty() || !tracks_csv.empty())
                 ? Zones(config.map, config.zones, posed_, config.footprints,
                         config.fusion.column_height_m)
                 : Zones(config.map, config.zones)),
      zone_states_(zones_.size(), ZoneState::kUnseen),
      zone_tally_(zones_.size()) {
  if (!detections_csv.empty()) {
    openCsv(detections_file_, detections_csv, "detections file", "frame,x_m,y_m,area_m2,score");
  }
  if (!tracks_csv.empty()) {
    openCsv(tracks_file_, tracks_csv, "tracks file",
            "frame,track_id,x_m,y_m,vx_m_s,vy_m_s,area_m2");
    tracking_ = true;
  }
  if (!truth_csv.empty()) {
    if (cameras.front().sim == nullptr) {
      throw InputError(truth_csv, 0, "--truth",
                       "a truth can be written only of a simulated scene (sources sim://...); "
                       "for EPFL's data use occmap truth --epfl");
    }
    // The scene's objects keep their order, so an object's index is its identity.
    openCsv(truth_file_, truth_csv, "truth file", "frame,x_m,y_m,id,kind");
  }
  if (cameras.front().sim != nullptr) {
    frame_s_ = 1.0 / cameras.front().sim->fps();
    expect_ = true;
  } else if (config.cameras.front().fps) {
    frame_s_ = 1.0 / *config.cameras.front().fps;
    expect_ = true;
  }
  if (detections_file_.is_open() || tracking_) {
    detector_.emplace(config.map, posed_, config.footprints);
    if (tracking_ || expect_) tracker_.emplace();
  }
  for (const Camera& camera : posed_) camera_centres_.push_back(camera.centreMetres());
  for (std::size_t z = 0; z < zones_.size(); ++z) {
    std::vector<std::uint8_t>& sights = zone_sights_.emplace_back();
    for (const std::uint32_t cell : zones_.cells(z)) {
      const Eigen::Vector2d p = config.map.cellCentre(std::size_t{cell});
      for (const Camera& camera : posed_) {
        const std::optional<Eigen::Vector2d> pixel = camera.worldToStream({p.x(), p.y(), 0.0});
        sights.push_back(pixel && camera.pixelIndexAt(*pixel));
      }
    }
  }
}

void OfflineFootprints::add(std::uint64_t map, std::span<const std::uint8_t* const> masks,
                            std::span<const CellState> cells,
                            const std::vector<sim::SceneObject>* objects) {
  const double time_s = static_cast<double>(map) * frame_s_;
  found_.clear();
  detected_.clear();
  followed_.clear();
  followed_ids_.clear();
  if (detector_) {
    expected_.clear();
    if (tracker_ && expect_) {
      tracker_->expectedAt(time_s, config_.footprints.expected_within_s, expected_);
    }
    const std::vector<Detection>& detected = detector_->detect(masks, cells, expected_);
    detected_.assign(detected.begin(), detected.end());
    for (const Detection& d : detected) {
      found_.push_back({d.x_m, d.y_m});
      if (!detections_file_.is_open()) continue;
      char row[128];
      std::snprintf(row, sizeof row, "%llu,%.3f,%.3f,%.4f,%.3f\n",
                    static_cast<unsigned long long>(map), d.x_m, d.y_m, d.area_m2, d.score);
      detections_file_ << row;
      ++detections_;
    }
    if (tracker_) {
      const std::vector<Track>& tracks = tracker_->update(detected, time_s);
      // Without a tracks file, followed only for the detector's sake.
      for (const Track& t : tracking_ ? std::span<const Track>(tracks) : std::span<const Track>()) {
        followed_.push_back({t.x_m, t.y_m});
        followed_ids_.push_back(t.id);
        char row[160];
        std::snprintf(row, sizeof row, "%llu,%u,%.3f,%.3f,%.3f,%.3f,%.4f\n",
                      static_cast<unsigned long long>(map), t.id, t.x_m, t.y_m, t.vx_m_s, t.vy_m_s,
                      t.area_m2);
        tracks_file_ << row;
        ++track_rows_;
      }
    }
  }
  const std::vector<ZoneStatus>& zones = zones_.update(cells, time_s, detected_);
  for (std::size_t z = 0; z < zones.size(); ++z) {
    ++zone_tally_[z].maps[static_cast<int>(zones[z].state)];
    zone_tally_[z].changes += map > 0 && zones[z].state != zone_states_[z] ? 1 : 0;
    zone_states_[z] = zones[z].state;
  }
  if (objects != nullptr && truth_file_.is_open()) {
    for (std::size_t i = 0; i < objects->size(); ++i) {
      const sim::SceneObject& object = (*objects)[i];
      const std::string_view kind = sim::objectKindName(object.kind);
      char row[128];
      std::snprintf(row, sizeof row, "%llu,%.3f,%.3f,%zu,%.*s\n",
                    static_cast<unsigned long long>(map), object.solid.centre.x(),
                    object.solid.centre.y(), i, static_cast<int>(kind.size()), kind.data());
      truth_file_ << row;
      ++truth_rows_;
    }
  }
  if (objects != nullptr) scoreAgainst(*objects);
}

ZoneState OfflineFootprints::trueState(std::size_t zone,
                                       const std::vector<sim::SceneObject>& objects) const {
  const std::span<const std::uint32_t> cells = zones_.cells(zone);
  for (const sim::SceneObject& object : objects) {
    for (const std::uint32_t cell : cells) {
      if (object.solid.footprintContains(config_.map.cellCentre(std::size_t{cell}))) {
        return ZoneState::kOccupied;
      }
    }
  }
  // A camera vouches for a cell when nothing stands in the way of any ray through its column
  // (up to the fusion's column_height_m): each such ray runs on to the floor beyond, and an
  // object anywhere along it changes that pixel.
  const double column = config_.fusion.column_height_m;
  const double heights[4] = {0.0, column / 3, 2 * column / 3, column};
  const int samples = column > 0 ? 4 : 1;
  const std::size_t k_count = camera_centres_.size();
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Eigen::Vector2d p = config_.map.cellCentre(std::size_t{cells[i]});
    bool seen = false;  // by some camera with nothing in the way
    for (std::size_t k = 0; k < k_count && !seen; ++k) {
      if (zone_sights_[zone][i * k_count + k] == 0) continue;
      const Eigen::Vector3d& centre = camera_centres_[k];
      bool blocked = false;
      for (int h = 0; h < samples && !blocked; ++h) {
        const Eigen::Vector3d direction = Eigen::Vector3d(p.x(), p.y(), heights[h]) - centre;
        const double to_floor = -centre.z() / direction.z();  // the ray's t at z = 0
        for (std::size_t o = 0; o < objects.size() && !blocked; ++o) {
          blocked = objects[o].solid.intersect(centre, direction, 0.0, to_floor).has_value();
        }
      }
      seen = !blocked;
    }
    if (!seen) return ZoneState::kUnseen;
  }
  return ZoneState::kFree;
}

void OfflineFootprints::scoreAgainst(const std::vector<sim::SceneObject>& objects) {
  scored_ = true;
  for (std::size_t z = 0; z < zones_.size(); ++z) {
    const ZoneState truth = trueState(z, objects);
    ++zone_tally_[z].against[static_cast<int>(truth)][static_cast<int>(zone_states_[z])];
  }
  if (!detector_) return;
  people_.clear();
  things_.clear();
  thing_ids_.clear();
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const FloorPoint centre{objects[i].solid.centre.x(), objects[i].solid.centre.y()};
    things_.push_back(centre);
    thing_ids_.push_back(static_cast<std::int64_t>(i));  // the scene's objects keep their order
    if (objects[i].kind == sim::ObjectKind::kPerson) people_.push_back(centre);
  }
  if (tracking_) track_score_.addFrame(things_, thing_ids_, followed_, followed_ids_);
  people_score_.addFrame(people_, found_);
  object_score_.addFrame(things_, found_);
  for (std::size_t kind = 0; kind < std::size(kind_score_); ++kind) {
    kind_points_.clear();
    for (const sim::SceneObject& object : objects) {
      if (static_cast<std::size_t>(object.kind) != kind) continue;
      kind_points_.push_back({object.solid.centre.x(), object.solid.centre.y()});
    }
    kind_score_[kind].addFrame(kind_points_, found_);
  }
}

bool OfflineFootprints::finishFiles(const char* command, std::uint64_t maps, double seconds) {
  const auto close = [&](std::ofstream& file, const std::string& path) {
    file.close();
    if (file) return true;
    std::fprintf(stderr, "occmap %s: writing %s failed\n", command, path.c_str());
    return false;
  };
  const double rate = static_cast<double>(maps) / seconds;
  if (truth_file_.is_open()) {
    if (!close(truth_file_, truth_path_)) return false;
    std::printf("wrote the scene's %llu objects on %llu maps to %s (score with --frames %llu)\n",
                static_cast<unsigned long long>(truth_rows_), static_cast<unsigned long long>(maps),
                truth_path_.c_str(), static_cast<unsigned long long>(maps));
  }
  if (tracking_) {
    if (!close(tracks_file_, tracks_path_)) return false;
    std::printf("wrote %llu track rows on %llu maps to %s (%.1f maps/s, %.3f s between maps)\n",
                static_cast<unsigned long long>(track_rows_), static_cast<unsigned long long>(maps),
                tracks_path_.c_str(), rate, frame_s_);
    if (scored_) {
      const TrackScore s = track_score_.score();
      std::printf(
          "against the simulator's objects and their identities (0.5 m gate): MOTA %.2f %%, IDF1 "
          "%.2f %%, identity switches %zu (%zu object points, %zu track points)\n",
          100 * s.mota(), 100 * s.idf1(), s.switches, s.truth, s.tracks);
    }
  }
  if (detections_file_.is_open()) {
    if (!close(detections_file_, detections_path_)) return false;
    std::printf("wrote %llu detections on %llu maps to %s (%.1f maps/s)\n",
                static_cast<unsigned long long>(detections_), static_cast<unsigned long long>(maps),
                detections_path_.c_str(), rate);
    if (scored_) {
      const auto print = [](const char* what, const DetectionScore& s) {
        std::printf(
            "against the simulator's %s (0.5 m gate): MODA %.2f %%, MODP %.2f %%, precision "
            "%.2f %%, recall %.2f %% (%zu of them over the maps, %zu detections)\n",
            what, 100 * s.moda(), 100 * s.modp(), 100 * s.precision(), 100 * s.recall(), s.people,
            s.detections);
      };
      print("objects, people among them", object_score_.score());
      print("people alone (objects found count as false positives)", people_score_.score());
      std::printf("found within 0.5 m, by kind:");
      const char* separator = " ";
      for (std::size_t kind = 0; kind < std::size(kind_score_); ++kind) {
        const DetectionScore& s = kind_score_[kind].score();
        if (s.people == 0) continue;
        std::printf("%s%s %.1f %% of %zu", separator,
                    std::string(sim::objectKindName(static_cast<sim::ObjectKind>(kind))).c_str(),
                    100 * s.recall(), s.people);
        separator = ", ";
      }
      std::printf("\n");
    }
  }
  return true;
}

void OfflineFootprints::printZones() const {
  for (std::size_t z = 0; z < zones_.size(); ++z) {
    const ZoneTally& t = zone_tally_[z];
    std::printf("zone %s: occupied in %llu maps, free in %llu, unseen in %llu; changed %llu times",
                config_.zones[z].name.c_str(), static_cast<unsigned long long>(t.maps[1]),
                static_cast<unsigned long long>(t.maps[0]),
                static_cast<unsigned long long>(t.maps[2]),
                static_cast<unsigned long long>(t.changes));
    if (scored_) {
      const auto& a = t.against;
      const std::uint64_t maps = t.maps[0] + t.maps[1] + t.maps[2];
      const auto kFree = static_cast<int>(ZoneState::kFree);
      const auto kOccupied = static_cast<int>(ZoneState::kOccupied);
      const auto kUnseen = static_cast<int>(ZoneState::kUnseen);
      std::printf(
          "; against the simulator's objects and what the cameras could see: right in %.2f %% "
          "of the maps, free while an object stands in it in %llu, occupied while nothing does "
          "in %llu (%llu of them with floor hidden), unseen while it is all in view or something "
          "stands in it in %llu "
          "(%llu of them with an object in it)",
          percent(a[0][0] + a[1][1] + a[2][2], maps),
          static_cast<unsigned long long>(a[kOccupied][kFree]),
          static_cast<unsigned long long>(a[kFree][kOccupied] + a[kUnseen][kOccupied]),
          static_cast<unsigned long long>(a[kUnseen][kOccupied]),
          static_cast<unsigned long long>(a[kFree][kUnseen] + a[kOccupied][kUnseen]),
          static_cast<unsigned long long>(a[kOccupied][kUnseen]));
    }
    std::printf("\n");
  }
}

}  // namespace occmap::tools
