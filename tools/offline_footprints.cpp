#include "tools/offline_footprints.h"

#include <cstdio>

#include "config/input_error.h"
#include "tools/progress.h"

namespace occmap::tools {
namespace {

void openCsv(std::ofstream& file, const std::string& path, const char* what, const char* header) {
  file.open(path);
  if (!file) throw InputError(path, 0, "--out", std::string("cannot write the ") + what + " here");
  file << header << "\n";
}

}  // namespace

OfflineFootprints::OfflineFootprints(const Config& config, const std::vector<RigCamera>& cameras,
                                     const std::string& detections_csv,
                                     const std::string& tracks_csv)
    : config_(config),
      detections_path_(detections_csv),
      tracks_path_(tracks_csv),
      zones_(config.map, config.zones),
      zone_states_(zones_.size(), ZoneState::kUnseen),
      zone_tally_(zones_.size()) {
  if (!detections_csv.empty()) {
    openCsv(detections_file_, detections_csv, "detections file", "frame,x_m,y_m,area_m2,score");
  }
  if (!tracks_csv.empty()) {
    openCsv(tracks_file_, tracks_csv, "tracks file",
            "frame,track_id,x_m,y_m,vx_m_s,vy_m_s,area_m2");
    tracker_.emplace();
  }
  if (cameras.front().sim != nullptr) {
    frame_s_ = 1.0 / cameras.front().sim->fps();
  } else if (config.cameras.front().fps) {
    frame_s_ = 1.0 / *config.cameras.front().fps;
  }
  if (detections_file_.is_open() || tracker_) {
    std::vector<Camera> posed;
    for (const RigCamera& camera : cameras) posed.push_back(*camera.camera);
    detector_.emplace(config.map, posed, config.footprints);
  }
}

void OfflineFootprints::add(std::uint64_t map, std::span<const std::uint8_t* const> masks,
                            std::span<const CellState> cells,
                            const std::vector<sim::SceneObject>* objects) {
  const double time_s = static_cast<double>(map) * frame_s_;
  found_.clear();
  followed_.clear();
  followed_ids_.clear();
  if (detector_) {
    const std::vector<Detection>& detected = detector_->detect(masks, cells);
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
      for (const Track& t : tracker_->update(detected, time_s)) {
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
  const std::vector<ZoneStatus>& zones = zones_.update(cells, time_s);
  for (std::size_t z = 0; z < zones.size(); ++z) {
    ++zone_tally_[z].maps[static_cast<int>(zones[z].state)];
    zone_tally_[z].changes += map > 0 && zones[z].state != zone_states_[z] ? 1 : 0;
    zone_states_[z] = zones[z].state;
  }
  if (objects != nullptr) scoreAgainst(*objects);
}

void OfflineFootprints::scoreAgainst(const std::vector<sim::SceneObject>& objects) {
  scored_ = true;
  for (std::size_t z = 0; z < zones_.size(); ++z) {
    bool object_there = false;
    for (const sim::SceneObject& object : objects) {
      for (const std::uint32_t cell : zones_.cells(z)) {
        if (object.solid.footprintContains(config_.map.cellCentre(std::size_t{cell}))) {
          object_there = true;
          break;
        }
      }
      if (object_there) break;
    }
    const ZoneState state = zone_states_[z];
    zone_tally_[z].free_over_object += object_there && state == ZoneState::kFree ? 1 : 0;
    if (state != ZoneState::kUnseen) {
      ++zone_tally_[z].judged;
      zone_tally_[z].right += object_there == (state == ZoneState::kOccupied) ? 1 : 0;
    }
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
  if (tracker_) track_score_.addFrame(things_, thing_ids_, followed_, followed_ids_);
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
  if (tracker_) {
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
      std::printf(
          "; against the simulator's objects: right in %.2f %% of the maps where it is "
          "seen, free while an object stands in it in %llu maps",
          percent(t.right, t.judged), static_cast<unsigned long long>(t.free_over_object));
    }
    std::printf("\n");
  }
}

}  // namespace occmap::tools
