#include "config/floor_survey_file.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "config/input_error.h"
#include "config/number_text.h"
#include "config/text_file.h"

namespace occmap {
namespace {

// OpenCV's largest predefined dictionary (DICT_ARUCO_ORIGINAL, DICT_4X4_1000 ...) has 1024 ids.
constexpr long long kLastMarkerId = 1023;

class MarkersReader {
 public:
  explicit MarkersReader(const std::string& file) : file_(file) {}

  FloorMarkers read(const YAML::Node& root) const {
    if (!root.IsMap()) {
      fail(root, "",
           "must be a mapping: dictionary: DICT_4X4_50, then markers: [{id: 0, "
           "centre_m: [x, y], side_m: 0.3, yaw_deg: 0}, ...]");
    }
    for (const auto& entry : root) {
      const std::string key = entry.first.Scalar();
      if (key != "dictionary" && key != "markers") {
        fail(entry.first, key, "unknown key; a markers file has dictionary and markers");
      }
    }
    FloorMarkers result;
    const YAML::Node dictionary = root["dictionary"];
    if (!dictionary.IsDefined() || !dictionary.IsScalar() || dictionary.Scalar().empty()) {
      fail(dictionary.IsDefined() ? dictionary : root, "dictionary",
           "is missing; name the markers' ArUco dictionary as OpenCV does, such as DICT_4X4_50");
    }
    result.dictionary = dictionary.Scalar();
    const YAML::Node markers = root["markers"];
    if (!markers.IsDefined() || !markers.IsSequence() || markers.size() == 0) {
      fail(markers.IsDefined() ? markers : root, "markers",
           "must list the markers on the floor, each {id: N, centre_m: [x, y], side_m: S, "
           "yaw_deg: A}");
    }
    for (std::size_t i = 0; i < markers.size(); ++i) {
      const YAML::Node item = markers[i];
      const std::string field = "markers[" + std::to_string(i) + "]";
      FloorMarker marker = readMarker(item, field);
      for (std::size_t j = 0; j < result.markers.size(); ++j) {
        if (result.markers[j].id == marker.id) {
          fail(item, field + ".id",
               "marker " + std::to_string(marker.id) + " is listed on lines " +
                   std::to_string(result.lines[j]) + " and " + std::to_string(lineOf(item)) +
                   "; a printed marker lies in one place: keep the right line, and print "
                   "markers with distinct ids");
        }
      }
      result.markers.push_back(marker);
      result.lines.push_back(lineOf(item));
    }
    return result;
  }

 private:
  static int lineOf(const YAML::Node& node) {
    const YAML::Mark mark = node.Mark();
    return mark.is_null() ? 0 : mark.line + 1;
  }

  [[noreturn]] void fail(const YAML::Node& node, const std::string& field,
                         const std::string& message) const {
    throw InputError(file_, lineOf(node), field, message);
  }

  double finite(const YAML::Node& node, const std::string& field) const {
    const std::optional<double> value =
        node.IsDefined() && node.IsScalar() ? parseReal(node.Scalar()) : std::nullopt;
    if (!value || !std::isfinite(*value)) fail(node, field, "must be a finite number");
    return *value;
  }

  FloorMarker readMarker(const YAML::Node& item, const std::string& field) const {
    if (!item.IsMap()) {
      fail(item, field, "must be {id: N, centre_m: [x, y], side_m: S, yaw_deg: A}");
    }
    for (const auto& entry : item) {
      const std::string key = entry.first.Scalar();
      if (key != "id" && key != "centre_m" && key != "side_m" && key != "yaw_deg") {
        fail(entry.first, field + "." + key,
             "unknown key; a marker has id, centre_m, side_m and yaw_deg");
      }
    }
    FloorMarker marker;
    const YAML::Node id = item["id"];
    const std::optional<long long> id_value =
        id.IsDefined() && id.IsScalar() ? parseInteger(id.Scalar()) : std::nullopt;
    if (!id_value || *id_value < 0 || *id_value > kLastMarkerId) {
      fail(id.IsDefined() ? id : item, field + ".id",
           "must be the marker's id as printed, a whole number from 0 to " +
               std::to_string(kLastMarkerId));
    }
    marker.id = static_cast<int>(*id_value);
    const YAML::Node centre = item["centre_m"];
    if (!centre.IsDefined() || !centre.IsSequence() || centre.size() != 2) {
      fail(centre.IsDefined() ? centre : item, field + ".centre_m",
           "must be the marker's centre on the floor, [x, y] in metres");
    }
    marker.centre_m = {finite(centre[0], field + ".centre_m"),
                       finite(centre[1], field + ".centre_m")};
    const YAML::Node side = item["side_m"];
    if (!side.IsDefined()) fail(item, field + ".side_m", "is missing; the black square's side, m");
    marker.side_m = finite(side, field + ".side_m");
    if (!(marker.side_m > 0.0) || marker.side_m > 10.0) {
      fail(side, field + ".side_m",
           "is " + formatReal(marker.side_m) +
               "; the black square's side in metres, black border included (such as 0.3)");
    }
    const YAML::Node yaw = item["yaw_deg"];
    marker.yaw_deg = yaw.IsDefined() ? finite(yaw, field + ".yaw_deg") : 0.0;
    return marker;
  }

  const std::string& file_;
};

}  // namespace

FloorMarkers parseFloorMarkers(std::string_view text, const std::string& file_name) {
  try {
    return MarkersReader(file_name).read(YAML::Load(std::string(text)));
  } catch (const YAML::Exception& error) {
    throw InputError(file_name, error.mark.is_null() ? 0 : error.mark.line + 1, "",
                     "is not valid YAML: " + error.msg + "; fix the YAML syntax");
  }
}

FloorMarkers loadFloorMarkers(const std::filesystem::path& file) {
  return parseFloorMarkers(readTextFile(file, "markers"), file.string());
}

std::vector<PointPair> loadPointPairs(const std::filesystem::path& file) {
  const std::string name = file.string();
  std::istringstream in(readTextFile(file, "point pairs"));
  std::string line;
  int number = 0;
  bool header = false;
  std::vector<PointPair> pairs;
  constexpr const char* kColumns[] = {"x_m", "y_m", "z_m", "u", "v"};
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (trimBlanks(line).empty() || trimBlanks(line).starts_with('#')) continue;
    std::vector<std::string> fields;
    std::stringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) {
      fields.emplace_back(trimBlanks(cell));
    }
    if (!header) {
      if (fields != std::vector<std::string>(std::begin(kColumns), std::end(kColumns))) {
        throw InputError(name, number, "",
                         "the first line must be the header x_m,y_m,z_m,u,v: a world point in "
                         "metres and its pixel (u = column, v = row) a line");
      }
      header = true;
      continue;
    }
    if (fields.size() != 5) {
      throw InputError(
          name, number, "",
          "has " + std::to_string(fields.size()) + " values; each line is x_m,y_m,z_m,u,v");
    }
    double values[5];
    for (std::size_t k = 0; k < 5; ++k) {
      const std::optional<double> value = parseReal(fields[k]);
      if (!value || !std::isfinite(*value)) {
        throw InputError(name, number, kColumns[k],
                         inQuotes(fields[k]) + " is not a finite number");
      }
      values[k] = *value;
    }
    pairs.push_back({{values[0], values[1], values[2]}, {values[3], values[4]}, number});
  }
  if (pairs.empty()) {
    throw InputError(name, 0, "",
                     "holds no point; measure at least 6 points spread over the floor and write "
                     "each as x_m,y_m,z_m,u,v");
  }
  return pairs;
}

}  // namespace occmap
