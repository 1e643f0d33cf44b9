#pragma once
// The stage after the fusion as occmap detect, occmap track and occmap fuse run it off-line
// (docs/detection.md): the people on each map, followed from map to map, written as CSV; the
// zones' states; and with simulated cameras, each scored against the scene's own objects.

#include <cstdint>
#include <fstream>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "capture/sim/scene.h"
#include "config/config.h"
#include "config/rig.h"
#include "core/detection_score.h"
#include "core/footprints.h"
#include "core/track_score.h"
#include "core/tracker.h"
#include "core/zones.h"

namespace occmap::tools {

class OfflineFootprints {
 public:
  // `detections_csv`, `tracks_csv`: the files to write, or empty for none (then nothing is
  // detected). `truth_csv`: where to write the simulated scene's objects on each map as a truth
  // occmap score reads (frame,x_m,y_m,id,kind), or empty. A file that cannot be written, or a
  // truth asked of cameras that are not simulated, is an InputError, before any map is made.
  OfflineFootprints(const Config& config, const std::vector<RigCamera>& cameras,
                    const std::string& detections_csv, const std::string& tracks_csv,
                    const std::string& truth_csv = {});

  // One map: its frame set's index, the masks it was fused from, its cells; with the simulator,
  // the scene's objects at its time (nullptr otherwise).
  void add(std::uint64_t map, std::span<const std::uint8_t* const> masks,
           std::span<const CellState> cells, const std::vector<sim::SceneObject>* objects);

  // Camera k re-posed after a knock (core/repose.h): its next masks are of `camera`'s pose, and
  // so is the next map's floor.
  void reposed(std::size_t k, const Camera& camera) {
    if (detector_) detector_->replaceCamera(k, camera);
    if (zones_.tellsHiddenFloor()) zones_.replaceCamera(k, Camera(camera), zones_.sightsOf(camera));
  }

  // Closes the files and prints what was written and its scores; false (said on stderr) when a
  // file could not be written whole.
  bool finishFiles(const char* command, std::uint64_t maps, double seconds);
  // Each zone's maps per state and changes (and with the simulator, how often it was right).
  void printZones() const;

 private:
  struct ZoneTally {
    std::uint64_t maps[3] = {0, 0, 0};  // by ZoneState
    std::uint64_t changes = 0;
    // Against the scene: [true state][state given], by ZoneState.
    std::uint64_t against[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  };
  // The zone's true state: occupied when an object's footprint holds one of its cell centres;
  // else unseen when a cell is in no camera's image, or every camera that has it sees an object
  // in front of it; else free.
  ZoneState trueState(std::size_t zone, const std::vector<sim::SceneObject>& objects) const;
  void scoreAgainst(const std::vector<sim::SceneObject>& objects);

  const Config& config_;
  std::string detections_path_, tracks_path_, truth_path_;
  std::ofstream detections_file_, tracks_file_, truth_file_;
  // Tracks and zones: the time between frame sets is 1 / fps of the first camera (the scene's for
  // the simulator, the config's `fps` for files://, 30 lacking one): off-line, frames are read as
  // fast as they go, so their read times are not their capture times.
  double frame_s_ = 1.0 / 30.0;
  std::optional<FootprintDetector> detector_;
  std::optional<Tracker> tracker_;
  // Where the tracker expects the people it follows on the next map (the detector looks there
  // first): only when the time between maps is known, never for files:// without an `fps`, which
  // may be still images a second apart (EPFL's moments). `occmap detect` follows them too.
  bool expect_ = false;
  bool tracking_ = false;  // writing tracks
  std::vector<Eigen::Vector2d> expected_;
  std::vector<Camera> posed_;
  Zones zones_;
  // Per zone, cells x cameras: 1 where the camera's image has the cell's centre.
  std::vector<std::vector<std::uint8_t>> zone_sights_;
  std::vector<Eigen::Vector3d> camera_centres_;
  std::vector<ZoneState> zone_states_;
  std::vector<ZoneTally> zone_tally_;
  bool scored_ = false;  // whether any map had the scene's objects
  std::uint64_t detections_ = 0, track_rows_ = 0, truth_rows_ = 0;
  // This frame set's detections and tracks, and the scene's objects (people among them).
  std::vector<FloorPoint> found_, followed_, people_, things_;
  std::vector<Detection> detected_;
  std::vector<std::int64_t> followed_ids_, thing_ids_;
  DetectionScorer people_score_, object_score_;
  // Each kind of object alone against every detection: how many of each are found.
  std::vector<FloorPoint> kind_points_;
  DetectionScorer kind_score_[4];  // by sim::ObjectKind
  TrackScorer track_score_;
};

}  // namespace occmap::tools
