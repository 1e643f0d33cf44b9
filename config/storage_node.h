#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace occmap {

// What cv::FileStorage writes, in YAML or in XML, read into one tree so that one reader checks an
// OpenCV calibration whichever way it was saved, and names the line of each value.
//
// Not read with cv::FileStorage: fuzzing found OpenCV 4.6's YAML parser (Debian bookworm's) looping
// for ever on "----Y\nY\nY" and on "!!binary" in a list, and overflowing the stack on 40 000 nested
// "[" (fuzz/regressions/opencv_calibration/): a calibration could hang occmapd at start or on a
// reload, or kill it. yaml-cpp reads what cv::FileStorage writes in YAML (its "%YAML:1.0" line, the
// !!opencv-matrix tags, flow lists over several lines) and libxml2 what it writes in XML
// (<opencv_storage>, type_id="opencv-matrix", a list as numbers between blanks); both bound their
// nesting and say where each value is.
struct StorageField;

struct StorageNode {
  enum class Kind : std::uint8_t { kNone, kScalar, kList, kMapping };
  Kind kind = Kind::kNone;         // kNone: a key with no value ("image_width:" in YAML)
  std::string scalar;              // kScalar: the text as written
  bool quoted = false;             // kScalar: written as text ("640" in YAML), not as a number
  int line = 0;                    // 1-based, 0 when unknown
  std::vector<StorageNode> items;  // kList
  // kMapping, in file order. A struct declared ahead rather than std::pair<std::string,
  // StorageNode>: a pair of a type not yet complete is refused by clang with libstdc++ 12
  // (scripts/fuzz's build), while std::vector of one is allowed.
  std::vector<StorageField> fields;

  // The first field of this name, or null (also when this is no mapping).
  const StorageNode* find(std::string_view key) const;
};

struct StorageField {
  std::string key;
  StorageNode value;
};

// The top level of a cv::FileStorage file: a mapping. Invalid syntax is an InputError with the
// parser's line and reason; `file` only names the source in errors.
StorageNode readYamlStorage(std::string_view text, const std::string& file);
StorageNode readXmlStorage(std::string_view text, const std::string& file);

}  // namespace occmap
