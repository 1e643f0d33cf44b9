#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/camera.h"
#include "core/camera_model.h"
#include "core/footprints.h"
#include "core/lighting_model.h"
#include "core/map_geometry.h"
#include "core/opencv_camera.h"
#include "core/zones.h"

namespace occmap {

// occmapd's config file (ARCHITECTURE.md, "Interfaces other people program against"): YAML, lengths
// in metres, paths relative to the file. Loading checks everything that can be checked without
// opening other files; every problem is an InputError naming the file, the line and the key path
// ("cameras[2].threshold"). Whether referenced files exist is for the stage that opens them, which
// names the line with CameraConfig::lineOf().

struct FusionSettings {
  int threshold = 20;            // grey levels a live pixel must differ from the background by
  double column_height_m = 0.3;  // column carving height; 0 carves the floor point only
  int max_wait_ms = 50;          // how long fusion waits for the other cameras after a first frame
  LightingSettings lighting;     // the background that follows the light (docs/lighting.md)
};

// A camera's `lighting:` keys: each one given replaces the fusion section's.
struct LightingOverride {
  std::optional<bool> adapt;
  std::optional<int> drift_frames;
  std::optional<double> min_agreement;
  std::optional<double> min_agreement_in_place;
  std::optional<int> agreement_grey_levels;
  std::optional<bool> local;
  LightingSettings over(LightingSettings settings) const;
};

struct TransportSettings {
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";
  std::string map_channel = "OCCMAP_MAP";
  std::string status_channel = "OCCMAP_STATUS";
  std::string encoding = "zstd";  // "raw" or "zstd"
  // Each map as map_tile_t tiles of at most 60 KiB on map_channel + "_TILES" instead of one
  // map_frame_t on map_channel: for maps whose encoded size can exceed one datagram
  // (docs/daemon.md).
  bool tiles = false;
};

// State-changing requests over LCM (docs/control.md): off unless enabled; then each must carry an
// HMAC under the key in `key_file` and pass the replay window.
struct ControlSettings {
  bool enabled = false;
  std::filesystem::path key_file;  // resolved like every path; required when enabled
  int replay_window_s = 30;  // requests whose utime is further from the daemon's clock are refused
  int key_file_line = 0;     // line of key_file, or 0: where a bad key file is pointed at
};

struct CameraConfig {
  std::string name;
  std::string source;  // as written: files://..., sim://..., aravis://..., v4l2://...
  // Paths are resolved against the config file's folder (made absolute) and normalised.
  // The calibration file, or an OpenCV camera's intrinsics when its extrinsics are in a file of
  // their own (`calibration: {intrinsics: F, extrinsics: F}`). Absent only for sim:// sources.
  std::optional<std::filesystem::path> calibration;
  std::optional<std::filesystem::path> extrinsics;
  WorldFrame world_frame = WorldFrame::kRightHanded;  // world_frame: left-handed (OpenCV only)
  std::optional<LengthUnit> calibration_units;        // absent: the calibration kind's default
  std::optional<ImageRegion> image_region;            // absent: the whole calibration frame
  std::optional<std::filesystem::path> background;    // absent only for sim:// sources
  std::optional<std::filesystem::path> floor_mask;
  std::optional<int> threshold;  // absent: FusionSettings::threshold
  LightingOverride lighting;     // over FusionSettings::lighting
  std::optional<double> fps;
  // Backend features (GenICam names for Aravis, V4L2 controls), values as written, in file order.
  std::vector<std::pair<std::string, std::string>> settings;
  int line = 0;                          // line of the camera's entry
  std::map<std::string, int> key_lines;  // line of each key given ("calibration" -> 12)

  // The line of `key` if the entry gives it, else the entry's line: where to point a later error.
  int lineOf(std::string_view key) const;
  int effectiveThreshold(const FusionSettings& fusion) const;
  LightingSettings effectiveLighting(const FusionSettings& fusion) const;
};

// A merge node's inputs (issue 16, docs/merge.md): instead of cameras, the maps of other occmapd
// (camera PCs), each on its own channel, merged into this config's map.
struct MergeInputConfig {
  std::string name;
  std::string channel;
  int line = 0;
};
struct MergeSettings {
  std::vector<MergeInputConfig> inputs;
  double max_age_ms = 150.0;  // an input's newest map older than this behind the newest is down
};

struct Config {
  std::filesystem::path file;  // as given to loadConfig
  MapGeometry map;
  FusionSettings fusion;
  TransportSettings transport;
  ControlSettings control;
  FootprintSettings footprints;  // footprints: people and objects on the map (docs/detection.md)
  std::vector<ZoneSpec> zones;   // zones: polygons with a state per map
  std::vector<CameraConfig> cameras;   // empty for a merge node
  std::optional<MergeSettings> merge;  // a merge node's inputs, instead of cameras
};

// Reads and checks a config file. A missing or unreadable file is an InputError too.
Config loadConfig(const std::filesystem::path& file);
// The same for text in memory; `file` names the source in errors and is the base of relative paths.
Config parseConfig(const std::string& yaml_text, const std::filesystem::path& file);

// The source schemes occmapd knows, as they start a camera's `source`.
inline constexpr std::string_view kSourceSchemes[] = {"files://", "sim://", "aravis://", "v4l2://"};

}  // namespace occmap
