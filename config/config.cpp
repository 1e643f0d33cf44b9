#include "config/config.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <span>
#include <system_error>

#include <yaml-cpp/yaml.h>

#include "config/input_error.h"
#include "config/number_text.h"
#include "config/text_file.h"

namespace occmap {

int CameraConfig::lineOf(std::string_view key) const {
  const auto found = key_lines.find(std::string(key));
  return found != key_lines.end() ? found->second : line;
}

int CameraConfig::effectiveThreshold(const FusionSettings& fusion) const {
  return threshold.value_or(fusion.threshold);
}

LightingSettings LightingOverride::over(LightingSettings settings) const {
  if (adapt) settings.adapt = *adapt;
  if (drift_frames) settings.drift_frames = *drift_frames;
  if (min_agreement) settings.min_agreement = *min_agreement;
  if (min_agreement_in_place) settings.min_agreement_in_place = *min_agreement_in_place;
  if (agreement_grey_levels) settings.agreement_grey_levels = *agreement_grey_levels;
  if (local) settings.local = *local;
  return settings;
}

LightingSettings CameraConfig::effectiveLighting(const FusionSettings& fusion) const {
  return lighting.over(fusion.lighting);
}

namespace {

using Keys = std::span<const std::string_view>;

constexpr std::string_view kTopKeys[] = {"map",     "cameras",    "fusion", "transport",
                                         "control", "footprints", "zones",  "merge"};
constexpr std::string_view kZoneKeys[] = {"name", "polygon_m"};
constexpr std::string_view kFootprintKeys[] = {
    "box_width_m",         "box_height_m",     "step_m",
    "min_support",         "min_fresh",        "min_separation_m",
    "min_cameras",         "enabled",          "object_height_m",
    "object_min_support",  "object_min_fresh", "settle_reach_m",
    "hidden_floor_unseen", "expected_reach_m", "expected_fresh_share",
    "expected_within_s",   "two_view_min_own", "box_strips",
    "hold_hidden",         "hold_own_factor"};
constexpr std::string_view kMapKeys[] = {"origin_m", "cell_size_m", "width", "height"};
constexpr std::string_view kFusionKeys[] = {"threshold", "column_height_m", "max_wait_ms",
                                            "lighting"};
constexpr std::string_view kLightingKeys[] = {
    "adapt", "drift_frames", "min_agreement", "min_agreement_in_place", "agreement_grey_levels",
    "local"};
constexpr std::string_view kTransportKeys[] = {"lcm_url", "map_channel", "status_channel",
                                               "encoding", "tiles"};
constexpr std::string_view kControlKeys[] = {"enabled", "key_file", "replay_window_s"};
constexpr std::string_view kCameraKeys[] = {
    "name",         "source",     "calibration", "calibration_units",
    "image_region", "background", "floor_mask",  "threshold",
    "lighting",     "fps",        "settings",    "world_frame"};
constexpr std::string_view kCalibrationFilesKeys[] = {"intrinsics", "extrinsics"};
constexpr std::string_view kMergeKeys[] = {"inputs", "max_age_ms"};
constexpr std::string_view kMergeInputKeys[] = {"name", "channel"};

int lineOf(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? 0 : mark.line + 1;
}

// A quoted scalar ("512") or one tagged !!str is text in YAML even when it reads like a number; a
// plain scalar is whatever it reads as.
bool isText(const YAML::Node& node) {
  return node.IsScalar() && (node.Tag() == "!" || node.Tag() == "tag:yaml.org,2002:str");
}

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined:
      return "nothing (an empty value)";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a mapping";
    case YAML::NodeType::Scalar:
      break;
  }
  std::string text = node.Scalar();
  if (text.size() > 40) text = text.substr(0, 40) + "...";
  return isText(node) ? "the text \"" + text + "\"" : text;
}

std::string join(Keys keys) {
  std::string text;
  for (const std::string_view key : keys) {
    if (!text.empty()) text += ", ";
    text += key;
  }
  return text;
}

// Levenshtein distance, to suggest the key a user probably meant.
std::size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

bool isCameraName(std::string_view name) {
  return !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '.' || c == '-';
  });
}

struct DocumentLines {
  int first_content = 0;    // line of the first document's first content, 0 if none
  int second_document = 0;  // line where a second document starts, 0 if none
};

// Where the YAML stream's documents are, from the markers "---" (start) and "..." (end), which
// YAML reserves at the start of a line, and content lines (neither blank, comment nor directive).
DocumentLines documentLines(std::string_view text) {
  auto isMarker = [](std::string_view line, std::string_view marker) {
    return line.starts_with(marker) &&
           (line.size() == marker.size() || line[marker.size()] == ' ' ||
            line[marker.size()] == '\t' || line[marker.size()] == '\r');
  };
  auto hasContent = [](std::string_view rest) {
    const std::size_t first = rest.find_first_not_of(" \t\r");
    return first != std::string_view::npos && rest[first] != '#';
  };
  DocumentLines result;
  bool ended = false;  // the first document was closed by "..."
  int number = 0;
  for (std::size_t start = 0; start <= text.size();) {
    const std::size_t end = std::min(text.find('\n', start), text.size());
    const std::string_view line = text.substr(start, end - start);
    start = end + 1;
    ++number;
    if (isMarker(line, "---")) {
      if (result.first_content != 0) {
        result.second_document = number;
        return result;
      }
      if (hasContent(line.substr(3))) result.first_content = number;
    } else if (isMarker(line, "...")) {
      ended = result.first_content != 0;
    } else if (hasContent(line) && !(result.first_content == 0 && line.starts_with('%'))) {
      if (ended) {
        result.second_document = number;
        return result;
      }
      if (result.first_content == 0) result.first_content = number;
    }
  }
  return result;
}

// A value in the document with what messages need to point at it.
struct Value {
  YAML::Node node;
  std::string field;  // key path: "cameras[2].image_region[0]"
  int line;
};

// One key of a mapping: its name, its line and its value.
struct Entry {
  std::string key;
  int key_line;
  Value value;
};

class ConfigReader {
 public:
  explicit ConfigReader(const std::filesystem::path& file) : name_(file.string()) {
    // Relative paths are taken from the config file's folder, made absolute so that they stay right
    // whatever the daemon's working directory becomes.
    std::error_code error;
    const std::filesystem::path absolute = std::filesystem::absolute(file, error);
    base_ = (error ? file : absolute).parent_path();
  }

  Config read(const std::string& text) const {
    try {
      return readDocument(text);
    } catch (const YAML::Exception& error) {
      fail(error.mark.is_null() ? 0 : error.mark.line + 1, "",
           "is not valid YAML: " + error.msg + "; fix the YAML syntax");
    }
  }

 private:
  [[noreturn]] void fail(int line, const std::string& field, const std::string& message) const {
    throw InputError(name_, line, field, message);
  }

  Config readDocument(const std::string& text) const {
    // YAML::Load reads the first document only; YAML::LoadAll, which would show the others, loops
    // for ever allocating on a stray ',' in yaml-cpp 0.7 (jbeder/yaml-cpp#1040). So the others are
    // found by their markers, which YAML reserves at the start of a line.
    const DocumentLines lines = documentLines(text);
    if (lines.second_document != 0) {
      fail(lines.second_document, "",
           "holds more than one YAML document (---); a config is a single document");
    }
    const YAML::Node root = YAML::Load(text);
    if (root.IsNull()) {
      if (lines.first_content == 0) {
        fail(0, "", "is empty; a config needs at least `map` and `cameras`");
      }
      // yaml-cpp 0.7 reads some broken starts (a stray ',') as an empty document.
      fail(lines.first_content, "",
           "top level must be a mapping with keys " + join(kTopKeys) +
               "; nothing of that can be read from here");
    }
    if (!root.IsMap()) {
      fail(lineOf(root), "",
           "top level must be a mapping with keys " + join(kTopKeys) + ", got " + describe(root));
    }
    Config config;
    std::optional<Value> zones_value;
    bool has_map = false;
    bool has_cameras = false;
    std::optional<int> merge_line;
    for (const Entry& entry : entries(Value{root, "", lineOf(root)}, kTopKeys)) {
      if (entry.key == "map") {
        config.map = readMap(entry.value);
        has_map = true;
      } else if (entry.key == "cameras") {
        config.cameras = readCameras(entry.value);
        has_cameras = true;
      } else if (entry.key == "fusion") {
        config.fusion = readFusion(entry.value);
      } else if (entry.key == "transport") {
        config.transport = readTransport(entry.value);
      } else if (entry.key == "control") {
        config.control = readControl(entry.value);
      } else if (entry.key == "footprints") {
        config.footprints = readFootprints(entry.value);
      } else if (entry.key == "zones") {
        zones_value = entry.value;
      } else if (entry.key == "merge") {
        config.merge = readMerge(entry.value);
        merge_line = entry.key_line;
      }
    }
    if (!has_map) {
      fail(lineOf(root), "map",
           "is missing; add `map: {origin_m: [x, y], cell_size_m: 0.02, width: 512, height: "
           "512}` (metres, cells)");
    }
    if (has_cameras && merge_line) {
      fail(*merge_line, "merge",
           "and cameras are both given; a config either fuses cameras or merges other daemons' "
           "maps (a merge node): keep one");
    }
    if (!has_cameras && !merge_line) {
      fail(lineOf(root), "cameras",
           "is missing; list the cameras to fuse (or, for a merge node, give merge: {inputs: "
           "[{name, channel}, ...]})");
    }
    if (config.merge) {
      for (const MergeInputConfig& input : config.merge->inputs) {
        if (input.channel == config.transport.map_channel) {
          fail(input.line, "merge.inputs",
               "input \"" + input.name + "\" listens on " + input.channel +
                   ", where this node publishes its merged map (transport.map_channel): give the "
                   "camera PCs' maps channels of their own");
        }
      }
    }
    // After the map, wherever they stand in the file: each must cover some of it.
    if (zones_value) config.zones = readZones(*zones_value, config.map);
    return config;
  }

  static std::string child(const std::string& path, std::string_view key) {
    return path.empty() ? std::string(key) : path + "." + std::string(key);
  }

  // The entries of a mapping in file order. Keys must be plain text, appear once and, when
  // `allowed` is given, be among them: a misspelt key silently ignored is a setting the user
  // believes in and does not have.
  std::vector<Entry> entries(const Value& mapping, std::optional<Keys> allowed) const {
    if (!mapping.node.IsMap()) {
      std::string expected = "a mapping";
      if (allowed) expected += " of " + join(*allowed);
      fail(mapping.line, mapping.field, "must be " + expected + ", got " + describe(mapping.node));
    }
    std::vector<Entry> result;
    for (auto it = mapping.node.begin(); it != mapping.node.end(); ++it) {
      const YAML::Node key = it->first;  // copies: the iterator hands out a temporary pair
      const int key_line = lineOf(key) != 0 ? lineOf(key) : mapping.line;
      if (!key.IsScalar() || key.Scalar().empty()) {
        fail(key_line, mapping.field, "has a key that is " + describe(key) + "; keys are names");
      }
      const std::string name = key.Scalar();
      const std::string field = child(mapping.field, name);
      if (allowed && std::find(allowed->begin(), allowed->end(), name) == allowed->end()) {
        std::string hint;
        for (const std::string_view known : *allowed) {
          if (editDistance(name, known) <= 2) hint = " (did you mean " + std::string(known) + "?)";
        }
        fail(key_line, field,
             "unknown key \"" + name + "\"" + hint + "; allowed here: " + join(*allowed));
      }
      for (const Entry& earlier : result) {
        if (earlier.key == name) {
          fail(key_line, field,
               "appears twice (lines " + std::to_string(earlier.key_line) + " and " +
                   std::to_string(key_line) + "); keep one");
        }
      }
      const YAML::Node value = it->second;
      // An empty value's mark is where the next token starts: point at the key instead.
      const int value_line = value.IsNull() || lineOf(value) == 0 ? key_line : lineOf(value);
      result.push_back(Entry{name, key_line, Value{value, field, value_line}});
    }
    return result;
  }

  std::vector<Value> list(const Value& value, const std::string& expected) const {
    if (!value.node.IsSequence()) {
      fail(value.line, value.field, "must be " + expected + ", got " + describe(value.node));
    }
    std::vector<Value> elements;
    for (std::size_t i = 0; i < value.node.size(); ++i) {
      const YAML::Node element = value.node[i];
      const int line = element.IsNull() || lineOf(element) == 0 ? value.line : lineOf(element);
      elements.push_back(Value{element, value.field + "[" + std::to_string(i) + "]", line});
    }
    return elements;
  }

  long long integer(const Value& value, long long min, long long max) const {
    const std::string range = " from " + std::to_string(min) + " to " + std::to_string(max);
    if (!value.node.IsScalar() || isText(value.node)) {
      fail(value.line, value.field,
           "must be a whole number" + range + ", got " + describe(value.node));
    }
    const std::optional<long long> number = parseInteger(value.node.Scalar());
    if (!number) {
      fail(value.line, value.field,
           "must be a whole number" + range + ", got " + describe(value.node));
    }
    if (*number < min || *number > max) {
      fail(value.line, value.field, "is " + value.node.Scalar() + "; it must be" + range);
    }
    return *number;
  }

  int smallInteger(const Value& value, int min, int max) const {
    return static_cast<int>(integer(value, min, max));
  }

  double finite(const Value& value) const {
    if (!value.node.IsScalar() || isText(value.node)) {
      fail(value.line, value.field, "must be a number, got " + describe(value.node));
    }
    const std::string& text = value.node.Scalar();
    // YAML's own spellings of infinity and not-a-number, which std::from_chars does not know.
    static constexpr std::string_view kNotFinite[] = {".inf", "+.inf", "-.inf", ".nan"};
    std::string lower = text;
    std::transform(lower.begin(), lower.end(), lower.begin(), [](char c) {
      return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c;
    });
    const bool yaml_not_finite =
        std::find(std::begin(kNotFinite), std::end(kNotFinite), lower) != std::end(kNotFinite);
    const std::optional<double> number = yaml_not_finite ? std::nullopt : parseReal(text);
    if (yaml_not_finite || (number && !std::isfinite(*number))) {
      fail(value.line, value.field, "is " + text + "; it must be a finite number");
    }
    if (!number) fail(value.line, value.field, "must be a number, got " + describe(value.node));
    return *number;
  }

  // A finite number in (min, max] when `min_open`, else in [min, max].
  double real(const Value& value, double min, bool min_open, double max,
              const std::string& unit) const {
    const double number = finite(value);
    if (min_open ? !(number > min) : !(number >= min)) {
      fail(value.line, value.field,
           "is " + value.node.Scalar() + "; it must be " + (min_open ? "> " : ">= ") +
               formatReal(min) + unit + " and <= " + formatReal(max) + unit);
    }
    if (!(number <= max)) {
      fail(value.line, value.field,
           "is " + value.node.Scalar() + "; it must be <= " + formatReal(max) + unit);
    }
    return number;
  }

  std::string text(const Value& value) const {
    if (!value.node.IsScalar()) {
      fail(value.line, value.field, "must be text, got " + describe(value.node));
    }
    return value.node.Scalar();
  }

  std::string nonEmptyText(const Value& value) const {
    std::string result = text(value);
    if (result.empty()) fail(value.line, value.field, "is empty; give a value");
    return result;
  }

  std::filesystem::path path(const Value& value) const {
    const std::filesystem::path written(nonEmptyText(value));
    if (written.is_absolute()) return written.lexically_normal();
    return (base_ / written).lexically_normal();
  }

  MapGeometry readMap(const Value& value) const {
    MapGeometry map;
    for (const Entry& entry : entries(value, kMapKeys)) {
      if (entry.key == "origin_m") {
        const std::vector<Value> xy = list(entry.value, "a list [x, y] in metres");
        if (xy.size() != 2) {
          fail(entry.value.line, entry.value.field,
               "has " + std::to_string(xy.size()) +
                   " values; it is the outer corner of cell (0, 0) as [x, y] in metres");
        }
        map.origin_x_m = finite(xy[0]);
        map.origin_y_m = finite(xy[1]);
      } else if (entry.key == "cell_size_m") {
        map.cell_size_m = real(entry.value, 0.0, true, 10.0, " m");
      } else if (entry.key == "width") {
        map.width = smallInteger(entry.value, 1, 8192);
      } else if (entry.key == "height") {
        map.height = smallInteger(entry.value, 1, 8192);
      }
    }
    return map;
  }

  FusionSettings readFusion(const Value& value) const {
    FusionSettings fusion;
    for (const Entry& entry : entries(value, kFusionKeys)) {
      if (entry.key == "threshold") {
        fusion.threshold = smallInteger(entry.value, 1, 255);
      } else if (entry.key == "column_height_m") {
        fusion.column_height_m = real(entry.value, 0.0, false, 5.0, " m");
      } else if (entry.key == "max_wait_ms") {
        fusion.max_wait_ms = smallInteger(entry.value, 0, 10000);
      } else if (entry.key == "lighting") {
        fusion.lighting = readLighting(entry.value).over(fusion.lighting);
      }
    }
    return fusion;
  }

  FootprintSettings readFootprints(const Value& value) const {
    FootprintSettings footprints;
    for (const Entry& entry : entries(value, kFootprintKeys)) {
      if (entry.key == "box_width_m") {
        footprints.box_width_m = real(entry.value, 0.0, true, 5.0, " m");
      } else if (entry.key == "box_height_m") {
        footprints.box_height_m = real(entry.value, 0.0, true, 5.0, " m");
      } else if (entry.key == "step_m") {
        footprints.step_m = real(entry.value, 0.0, true, 2.0, " m");
      } else if (entry.key == "min_support") {
        footprints.min_support = real(entry.value, 0.0, true, 1.0, "");
      } else if (entry.key == "min_fresh") {
        footprints.min_fresh = real(entry.value, 0.0, true, 1.0, "");
      } else if (entry.key == "min_cameras") {
        footprints.min_cameras = smallInteger(entry.value, 1, 64);
      } else if (entry.key == "min_separation_m") {
        footprints.min_separation_m = real(entry.value, 0.0, false, 5.0, " m");
      } else if (entry.key == "enabled") {
        footprints.enabled = boolean(entry.value);
      } else if (entry.key == "object_height_m") {
        footprints.object_height_m = real(entry.value, 0.0, false, 5.0, " m");
      } else if (entry.key == "object_min_support") {
        footprints.object_min_support = real(entry.value, 0.0, true, 1.0, "");
      } else if (entry.key == "object_min_fresh") {
        footprints.object_min_fresh = real(entry.value, 0.0, true, 1.0, "");
      } else if (entry.key == "two_view_min_own") {
        footprints.two_view_min_own = real(entry.value, 0.0, false, 1.0, "");
      } else if (entry.key == "settle_reach_m") {
        footprints.settle_reach_m = real(entry.value, 0.0, false, 5.0, " m");
      } else if (entry.key == "hidden_floor_unseen") {
        footprints.hidden_floor_unseen = boolean(entry.value);
      } else if (entry.key == "hold_hidden") {
        footprints.hold_hidden = boolean(entry.value);
      } else if (entry.key == "hold_own_factor") {
        footprints.hold_own_factor = real(entry.value, 0.0, true, 5.0, "");
      } else if (entry.key == "expected_reach_m") {
        footprints.expected_reach_m = real(entry.value, 0.0, false, 2.0, " m");
      } else if (entry.key == "expected_fresh_share") {
        footprints.expected_fresh_share = real(entry.value, 0.0, false, 1.0, "");
      } else if (entry.key == "expected_within_s") {
        footprints.expected_within_s = real(entry.value, 0.0, false, 10.0, " s");
      } else if (entry.key == "box_strips") {
        footprints.box_strips = smallInteger(entry.value, 1, 16);
      }
    }
    return footprints;
  }

  LightingOverride readLighting(const Value& value) const {
    LightingOverride lighting;
    for (const Entry& entry : entries(value, kLightingKeys)) {
      if (entry.key == "adapt") {
        lighting.adapt = boolean(entry.value);
      } else if (entry.key == "drift_frames") {
        lighting.drift_frames = smallInteger(entry.value, 1, 1000000);
      } else if (entry.key == "min_agreement") {
        lighting.min_agreement = real(entry.value, 0.0, false, 1.0, "");
      } else if (entry.key == "min_agreement_in_place") {
        lighting.min_agreement_in_place = real(entry.value, 0.0, false, 1.0, "");
      } else if (entry.key == "agreement_grey_levels") {
        lighting.agreement_grey_levels = smallInteger(entry.value, 1, 64);
      } else if (entry.key == "local") {
        lighting.local = boolean(entry.value);
      }
    }
    return lighting;
  }

  TransportSettings readTransport(const Value& value) const {
    TransportSettings transport;
    int map_channel_line = 0;
    int status_channel_line = 0;
    std::string status_channel_field;
    for (const Entry& entry : entries(value, kTransportKeys)) {
      if (entry.key == "lcm_url") {
        transport.lcm_url = nonEmptyText(entry.value);
        // LCM itself says only "provider not found" on stderr and opens nothing: name the
        // providers here, where the line is known.
        const std::string_view url = transport.lcm_url;
        const std::size_t scheme_end = url.find("://");
        const std::string_view scheme = url.substr(0, scheme_end);
        constexpr std::string_view kProviders[] = {"udpm", "mpudpm", "tcpq", "memq", "file"};
        if (scheme_end == std::string_view::npos ||
            std::find(std::begin(kProviders), std::end(kProviders), scheme) ==
                std::end(kProviders)) {
          fail(entry.value.line, entry.value.field,
               "'" + transport.lcm_url +
                   "' is not an LCM URL; use udpm://239.255.76.67:7667?ttl=0 (UDP multicast, "
                   "LCM's default), tcpq://host:port, memq:// or file://path");
        }
      } else if (entry.key == "map_channel") {
        transport.map_channel = nonEmptyText(entry.value);
        map_channel_line = entry.value.line;
      } else if (entry.key == "status_channel") {
        transport.status_channel = nonEmptyText(entry.value);
        status_channel_line = entry.value.line;
        status_channel_field = entry.value.field;
      } else if (entry.key == "encoding") {
        transport.encoding = text(entry.value);
        if (transport.encoding != "raw" && transport.encoding != "zstd") {
          fail(entry.value.line, entry.value.field,
               "is \"" + transport.encoding + "\"; use raw or zstd");
        }
      } else if (entry.key == "tiles") {
        transport.tiles = boolean(entry.value);
      }
    }
    if (transport.map_channel == transport.status_channel) {
      // Point at whichever of the two the file sets; if it sets one, that one clashes the default.
      const int line = status_channel_line != 0 ? status_channel_line : map_channel_line;
      fail(line != 0 ? line : value.line,
           status_channel_line != 0 ? status_channel_field : child(value.field, "map_channel"),
           "map_channel and status_channel are both \"" + transport.map_channel +
               "\"; subscribers tell maps from status by channel, so they must differ");
    }
    return transport;
  }

  bool boolean(const Value& value) const {
    // YAML 1.2's core schema: true or false (yaml-cpp would also take yes/no/on/off, which YAML
    // 1.2 reads as text: one spelling avoids surprises).
    if (value.node.IsScalar() && !isText(value.node)) {
      if (value.node.Scalar() == "true") return true;
      if (value.node.Scalar() == "false") return false;
    }
    fail(value.line, value.field, "must be true or false, got " + describe(value.node));
  }

  ControlSettings readControl(const Value& value) const {
    ControlSettings control;
    bool has_key_file = false;
    for (const Entry& entry : entries(value, kControlKeys)) {
      if (entry.key == "enabled") {
        control.enabled = boolean(entry.value);
      } else if (entry.key == "key_file") {
        control.key_file = path(entry.value);
        control.key_file_line = entry.value.line;
        has_key_file = true;
      } else if (entry.key == "replay_window_s") {
        control.replay_window_s = smallInteger(entry.value, 1, 3600);
      }
    }
    if (control.enabled && !has_key_file) {
      fail(value.line, child(value.field, "key_file"),
           "is missing; control requests are authenticated with a key: make one with `occmap "
           "control --make-key /etc/occmap/control.key` and name it here (docs/control.md)");
    }
    return control;
  }

  std::vector<ZoneSpec> readZones(const Value& value, const MapGeometry& map) const {
    std::vector<ZoneSpec> zones;
    for (const Value& item : list(value, "a list of zones {name, polygon_m}")) {
      ZoneSpec zone;
      int polygon_line = item.line;
      std::string polygon_field = item.field + ".polygon_m";
      for (const Entry& entry : entries(item, kZoneKeys)) {
        if (entry.key == "name") {
          zone.name = text(entry.value);
          for (const ZoneSpec& other : zones) {
            if (other.name == zone.name) {
              fail(entry.value.line, entry.value.field,
                   "zone name \"" + zone.name + "\" is used twice; give each zone its own name");
            }
          }
        } else if (entry.key == "polygon_m") {
          polygon_line = entry.value.line;
          polygon_field = entry.value.field;
          for (const Value& corner : list(entry.value, "a list of corners [x, y] in metres")) {
            const std::vector<Value> xy = list(corner, "a corner [x, y] in metres");
            if (xy.size() != 2) {
              fail(corner.line, corner.field, "is not [x, y]: a corner has two coordinates");
            }
            zone.polygon_m.emplace_back(finite(xy[0]), finite(xy[1]));
          }
        }
      }
      if (zone.name.empty()) fail(item.line, item.field + ".name", "is missing; name the zone");
      if (zone.polygon_m.size() < 3) {
        fail(polygon_line, polygon_field,
             "has " + std::to_string(zone.polygon_m.size()) +
                 " corners; a zone is a polygon of at least 3, [[x, y], ...] in metres");
      }
      if (cellsInside(map, zone.polygon_m).empty()) {
        fail(polygon_line, polygon_field,
             "holds no cell centre of the map; a zone lies on the map (map: origin_m, "
             "cell_size_m, width, height)");
      }
      zones.push_back(std::move(zone));
    }
    return zones;
  }

  std::vector<CameraConfig> readCameras(const Value& value) const {
    const std::vector<Value> items = list(value, "a list of cameras");
    if (items.empty()) fail(value.line, value.field, "is empty; list at least one camera");
    std::vector<CameraConfig> cameras;
    for (const Value& item : items) {
      cameras.push_back(readCamera(item));
      const CameraConfig& camera = cameras.back();
      for (std::size_t i = 0; i + 1 < cameras.size(); ++i) {
        if (cameras[i].name == camera.name) {
          fail(camera.lineOf("name"), item.field + ".name",
               "camera name \"" + camera.name + "\" is used on lines " +
                   std::to_string(cameras[i].lineOf("name")) + " and " +
                   std::to_string(camera.lineOf("name")) + "; give each camera its own name");
        }
      }
    }
    return cameras;
  }

  CameraConfig readCamera(const Value& item) const {
    CameraConfig camera;
    camera.line = item.line;
    bool has_name = false;
    bool has_source = false;
    for (const Entry& entry : entries(item, kCameraKeys)) {
      camera.key_lines[entry.key] = entry.key_line;
      const Value& value = entry.value;
      if (entry.key == "name") {
        camera.name = text(value);
        if (!isCameraName(camera.name)) {
          fail(value.line, value.field,
               "\"" + camera.name +
                   "\" is not a camera name; use 1 to 64 letters, digits, '_', '.' or '-'");
        }
        has_name = true;
      } else if (entry.key == "source") {
        camera.source = nonEmptyText(value);
        checkSource(value, camera.source);
        has_source = true;
      } else if (entry.key == "calibration") {
        readCalibrationFiles(value, camera);
      } else if (entry.key == "world_frame") {
        const std::string frame = text(value);
        if (frame != "right-handed" && frame != "left-handed") {
          fail(value.line, value.field,
               "is \"" + frame +
                   "\"; use right-handed (OpenCV's, the default) or left-handed (Unity's, "
                   "MultiviewX's)");
        }
        camera.world_frame =
            frame == "left-handed" ? WorldFrame::kLeftHanded : WorldFrame::kRightHanded;
      } else if (entry.key == "calibration_units") {
        const std::string unit = text(value);
        camera.calibration_units = parseLengthUnit(unit);
        if (!camera.calibration_units) {
          fail(value.line, value.field, "is \"" + unit + "\"; use mm, cm or m");
        }
      } else if (entry.key == "image_region") {
        camera.image_region = readImageRegion(value);
      } else if (entry.key == "background") {
        camera.background = path(value);
      } else if (entry.key == "floor_mask") {
        camera.floor_mask = path(value);
      } else if (entry.key == "threshold") {
        camera.threshold = smallInteger(value, 1, 255);
      } else if (entry.key == "lighting") {
        camera.lighting = readLighting(value);
      } else if (entry.key == "fps") {
        camera.fps = real(value, 0.0, true, 1000.0, "");
      } else if (entry.key == "settings") {
        for (const Entry& setting : entries(value, std::nullopt)) {
          if (!setting.value.node.IsScalar()) {
            fail(
                setting.value.line, setting.value.field,
                "must be a single value (a number or a word), got " + describe(setting.value.node));
          }
          camera.settings.emplace_back(setting.key, setting.value.node.Scalar());
        }
      }
    }
    if (!has_name) fail(item.line, item.field + ".name", "is missing; give the camera a name");
    if (!has_source) {
      fail(item.line, item.field + ".source",
           "is missing; say where frames come from, such as aravis://<device>, "
           "v4l2:///dev/video0, files:///data/c0/*.png or sim://room/c0");
    }
    // A simulated camera may take its calibration and background from its scene; a real one has
    // no other way to know where it looks or what the empty floor is.
    if (!camera.source.starts_with("sim://")) {
      if (!camera.calibration) {
        fail(item.line, item.field + ".calibration",
             "is missing; camera \"" + camera.name +
                 "\" needs a calibration file (Tsai XML or OpenCV YAML); only sim:// cameras "
                 "may do without");
      }
      if (!camera.background) {
        fail(item.line, item.field + ".background",
             "is missing; camera \"" + camera.name +
                 "\" needs an image of the empty scene; only sim:// cameras may do without");
      }
    }
    return camera;
  }

  // One file, or {intrinsics: F, extrinsics: F} as WILDTRACK and MultiviewX ship OpenCV cameras.
  void readCalibrationFiles(const Value& value, CameraConfig& camera) const {
    if (!value.node.IsMap()) {
      camera.calibration = path(value);
      return;
    }
    for (const Entry& entry : entries(value, kCalibrationFilesKeys)) {
      (entry.key == "intrinsics" ? camera.calibration : camera.extrinsics) = path(entry.value);
    }
    if (!camera.calibration || !camera.extrinsics) {
      fail(value.line, value.field + (camera.calibration ? ".extrinsics" : ".intrinsics"),
           "is missing; a calibration in two files is {intrinsics: F, extrinsics: F} (OpenCV "
           "FileStorage YAML or XML), else give one file");
    }
  }

  MergeSettings readMerge(const Value& value) const {
    MergeSettings merge;
    bool has_inputs = false;
    for (const Entry& entry : entries(value, kMergeKeys)) {
      if (entry.key == "max_age_ms") {
        merge.max_age_ms = real(entry.value, 0.0, true, 60000.0, " ms");
      } else {
        has_inputs = true;
        const std::vector<Value> items = list(entry.value, "a list of inputs {name, channel}");
        if (items.empty()) fail(entry.value.line, entry.value.field, "is empty; list the inputs");
        for (const Value& item : items) {
          MergeInputConfig input;
          input.line = item.line;
          for (const Entry& field : entries(item, kMergeInputKeys)) {
            if (field.key == "name") {
              input.name = text(field.value);
              if (!isCameraName(input.name)) {
                fail(field.value.line, field.value.field,
                     "\"" + input.name +
                         "\" is not an input name; use 1 to 64 letters, digits, '_', '.' or '-'");
              }
            } else {
              input.channel = nonEmptyText(field.value);
            }
          }
          if (input.name.empty() || input.channel.empty()) {
            fail(item.line, item.field,
                 "needs a name and a channel, such as {name: west, channel: OCCMAP_MAP_WEST}");
          }
          for (const MergeInputConfig& other : merge.inputs) {
            if (other.name == input.name || other.channel == input.channel) {
              fail(item.line, item.field,
                   "repeats the name or channel of the input on line " +
                       std::to_string(other.line) + "; each input is one camera PC");
            }
          }
          merge.inputs.push_back(std::move(input));
        }
      }
    }
    if (!has_inputs) {
      fail(value.line, value.field + ".inputs",
           "is missing; list the camera PCs' maps, [{name: west, channel: OCCMAP_MAP_WEST}, ...]");
    }
    return merge;
  }

  void checkSource(const Value& value, const std::string& source) const {
    for (const std::string_view scheme : kSourceSchemes) {
      if (source.starts_with(scheme)) return;
    }
    std::string known;
    for (const std::string_view scheme : kSourceSchemes) {
      if (!known.empty()) known += ", ";
      known += scheme;
    }
    const std::size_t separator = source.find("://");
    const std::string problem = separator == std::string::npos
                                    ? "\"" + source + "\" names no source scheme"
                                    : "\"" + source + "\" has the unknown scheme \"" +
                                          source.substr(0, separator + 3) + "\"";
    fail(value.line, value.field, problem + "; use one of " + known);
  }

  ImageRegion readImageRegion(const Value& value) const {
    const std::vector<Value> numbers = list(value, "a list [x0, y0, width, height] in pixels");
    if (numbers.size() != 4) {
      fail(value.line, value.field,
           "has " + std::to_string(numbers.size()) +
               " values; write [x0, y0, width, height] in calibration pixels");
    }
    ImageRegion region;
    region.x0 = real(numbers[0], 0.0, false, kMaxRegion, " pixels");
    region.y0 = real(numbers[1], 0.0, false, kMaxRegion, " pixels");
    region.width = real(numbers[2], 0.0, true, kMaxRegion, " pixels");
    region.height = real(numbers[3], 0.0, true, kMaxRegion, " pixels");
    return region;
  }

  static constexpr double kMaxRegion = 65536.0;

  std::string name_;
  std::filesystem::path base_;
};

}  // namespace

Config parseConfig(const std::string& yaml_text, const std::filesystem::path& file) {
  Config config = ConfigReader(file).read(yaml_text);
  config.file = file;
  return config;
}

Config loadConfig(const std::filesystem::path& file) {
  return parseConfig(readTextFile(file, "config"), file);
}

}  // namespace occmap
