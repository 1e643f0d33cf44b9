// config: occmapd's config file, read as `occmapd --config FILE` reads it (loadConfig is
// readTextFile, which only bounds the size, then parseConfig on the text), then every camera's
// source taken apart as the rig does next. The file's path is never opened: parseConfig only
// resolves paths against it, so no file is touched.
#include <cmath>
#include <set>
#include <string>

#include "capture/source_spec.h"
#include "config/config.h"
#include "config/input_error.h"
#include "fuzz/fuzz_target.h"
#include "transport/map_codec.h"

namespace occmap::fuzz {
namespace {

bool isCameraNameCharacter(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '.' || c == '-';
}

bool startsWithKnownScheme(const std::string& source) {
  for (const std::string_view scheme : kSourceSchemes) {
    if (source.starts_with(scheme)) return true;
  }
  return false;
}

// What config.h and docs/daemon.md promise of a config that loads: the daemon goes on to use these
// values without checking them again.
void checkAcceptedConfig(const Config& config) {
  const MapGeometry& map = config.map;
  // The map encoder throws outside 1..kMaxMapSide (which would end the daemon's LCM thread).
  require(
      map.width >= 1 && map.width <= kMaxMapSide && map.height >= 1 && map.height <= kMaxMapSide,
      "an accepted map is 1..8192 cells a side");
  require(std::isfinite(map.cell_size_m) && map.cell_size_m > 0 && map.cell_size_m <= 10,
          "an accepted cell size is in (0, 10] m");
  require(std::isfinite(map.origin_x_m) && std::isfinite(map.origin_y_m),
          "an accepted origin is finite");
  require(config.fusion.threshold >= 1 && config.fusion.threshold <= 255,
          "an accepted threshold is 1..255");
  require(std::isfinite(config.fusion.column_height_m) && config.fusion.column_height_m >= 0 &&
              config.fusion.column_height_m <= 5,
          "an accepted column height is in [0, 5] m");
  require(config.fusion.max_wait_ms >= 0 && config.fusion.max_wait_ms <= 10000,
          "an accepted max_wait_ms is 0..10000");
  // The daemon's LCM thread takes parseMapEncoding(...).value().
  require(parseMapEncoding(config.transport.encoding).has_value(),
          "an accepted transport.encoding is one the map encoder knows");
  require(!config.transport.lcm_url.empty(), "an accepted lcm_url is not empty");
  require(!config.transport.map_channel.empty() && !config.transport.status_channel.empty() &&
              config.transport.map_channel != config.transport.status_channel,
          "accepted map and status channels are two different names");
  require(config.control.replay_window_s >= 1 && config.control.replay_window_s <= 3600,
          "an accepted control.replay_window_s is 1..3600 s");
  require(!config.control.enabled || config.control.key_file.is_absolute(),
          "an enabled control section names its key file, made absolute");
  require(config.cameras.empty() == config.merge.has_value(),
          "an accepted config has cameras or is a merge node, not both and not neither");
  if (config.merge) {
    // A merge node: its inputs appear as the merged map's cameras (map_frame_t counts them in an
    // int16_t), each with a name and a channel of its own, none the node's own map channel.
    require(!config.merge->inputs.empty() && config.merge->inputs.size() <= 32767,
            "an accepted merge node has 1..32767 inputs");
    require(config.merge->max_age_ms > 0 && std::isfinite(config.merge->max_age_ms),
            "an accepted max_age_ms is finite and > 0");
    std::set<std::string> inputs, channels;
    for (const MergeInputConfig& input : config.merge->inputs) {
      require(inputs.insert(input.name).second && channels.insert(input.channel).second &&
                  !input.channel.empty() && input.channel != config.transport.map_channel,
              "accepted merge inputs have names and channels of their own");
    }
  }
  // map_frame_t and status_t count cameras in an int16_t.
  require(config.cameras.size() <= 32767, "an accepted config has at most 32767 cameras");

  std::set<std::string> names;
  for (const CameraConfig& camera : config.cameras) {
    require(!camera.name.empty() && camera.name.size() <= 64 &&
                std::all_of(camera.name.begin(), camera.name.end(), isCameraNameCharacter),
            "an accepted camera name is 1 to 64 letters, digits, '_', '.' or '-'");
    require(names.insert(camera.name).second, "accepted camera names are unique");
    require(startsWithKnownScheme(camera.source), "an accepted source has a known scheme");
    if (!camera.source.starts_with("sim://")) {
      require(camera.calibration && camera.background,
              "an accepted camera that is not simulated has a calibration and a background");
    }
    for (const auto& path : {camera.calibration, camera.background, camera.floor_mask}) {
      require(!path || path->is_absolute(), "accepted paths are made absolute");
    }
    require(camera.effectiveThreshold(config.fusion) >= 1 &&
                camera.effectiveThreshold(config.fusion) <= 255,
            "an accepted camera threshold is 1..255");
    require(!camera.fps || (std::isfinite(*camera.fps) && *camera.fps > 0 && *camera.fps <= 1000),
            "an accepted fps is in (0, 1000]");
    if (camera.image_region) {
      const ImageRegion& r = *camera.image_region;
      require(std::isfinite(r.x0) && std::isfinite(r.y0) && r.x0 >= 0 && r.y0 >= 0 &&
                  std::isfinite(r.width) && std::isfinite(r.height) && r.width > 0 && r.height > 0,
              "an accepted image_region has a finite corner >= 0 and a positive size");
    }
    // Rig::open takes the source apart next; a malformed one is refused with a message.
    std::string error;
    const std::optional<SourceSpec> spec =
        parseSource(camera.source, config.file.parent_path(), error);
    require(spec.has_value() || !error.empty(), "a refused source comes with a reason");
  }
}

}  // namespace

bool fuzzConfig(Input input) {
  Config config;
  try {
    config = parseConfig(std::string(asText(input)), "/occmap-fuzz/occmapd.yaml");
  } catch (const InputError&) {
    return false;  // refused with file, line and field: what should happen to a bad config
  }
  checkAcceptedConfig(config);
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzConfig)
