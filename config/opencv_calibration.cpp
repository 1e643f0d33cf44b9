// OpenCV calibrations as cv::FileStorage writes them, in YAML or XML, in one file or as intrinsics
// and extrinsics in two (WILDTRACK, MultiviewX): read into the tree of storage_node.h and checked
// here, each error naming the file, the line of the value and the field.
#include <algorithm>
#include <array>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "config/calibration_file.h"
#include "config/input_error.h"
#include "config/number_text.h"
#include "config/storage_node.h"
#include "config/text_file.h"

namespace occmap {
namespace {

using Kind = StorageNode::Kind;

struct Matrix {
  int rows = 0;
  int cols = 0;
  std::vector<double> values;  // row-major
  bool plain_list = false;     // written as a list of numbers, not as a cv::Mat
};

// Which fields a file must hold: all of them, or the camera's own (camera_matrix,
// distortion_coefficients, its image size if known) apart from where it stands (rvec, tvec).
enum class Part : std::uint8_t { kWhole, kIntrinsics, kExtrinsics };

class OpenCvReader {
 public:
  OpenCvReader(const StorageNode& root, const std::string& file, Part part)
      : root_(root), file_(file), part_(part) {
    if (root_.kind != Kind::kMapping)
      fail(root_, "", "top level must be a mapping with " + needs());
  }

  // image_width and image_height, both or neither: a file without them (WILDTRACK's, MultiviewX's)
  // takes its size from the stream (0 here).
  void readIntrinsics(OpenCvParameters& p) const {
    const StorageNode* width = given("image_width");
    const StorageNode* height = given("image_height");
    if (width != nullptr) p.width = imageSide(*width, "image_width");
    if (height != nullptr) p.height = imageSide(*height, "image_height");
    if ((width == nullptr) != (height == nullptr)) {
      throw InputError(file_, 0, width == nullptr ? "image_width" : "image_height",
                       std::string("is missing while ") +
                           (width == nullptr ? "image_height" : "image_width") +
                           " is given; give both, or neither to take the size from the stream");
    }

    const StorageNode& k_node = required("camera_matrix");
    Matrix k = matrix(k_node, "camera_matrix");
    if (k.plain_list && k.values.size() == 9) k.rows = k.cols = 3;  // row-major, as cv::Mat
    if (k.rows != 3 || k.cols != 3) {
      fail(k_node, "camera_matrix", "is " + shape(k) + "; the camera matrix is 3x3");
    }
    auto at = [&k](int row, int col) { return k.values[static_cast<std::size_t>(row * 3 + col)]; };
    // cv::projectPoints ignores skew, so a matrix with skew would be a camera neither OpenCV nor we
    // reproduce; other non-zero entries make it no intrinsic matrix at all.
    if (at(0, 1) != 0.0) {
      fail(k_node, "camera_matrix",
           "has skew K(0,1) = " + formatReal(at(0, 1)) +
               "; cv::projectPoints ignores skew, so occmap cannot model it: recalibrate with "
               "zero skew (cv::calibrateCamera's default)");
    }
    const std::pair<int, int> zeros[] = {{1, 0}, {2, 0}, {2, 1}};
    for (const auto& [row, col] : zeros) {
      if (at(row, col) != 0.0) {
        fail(k_node, "camera_matrix",
             "has K(" + std::to_string(row) + "," + std::to_string(col) + ") = " +
                 formatReal(at(row, col)) + "; an intrinsic matrix is [fx 0 cx; 0 fy cy; 0 0 1]");
      }
    }
    if (at(2, 2) != 1.0) {
      fail(k_node, "camera_matrix",
           "has K(2,2) = " + formatReal(at(2, 2)) +
               "; an intrinsic matrix is [fx 0 cx; 0 fy cy; 0 0 1]");
    }
    p.fx = at(0, 0);
    p.fy = at(1, 1);
    p.cx = at(0, 2);
    p.cy = at(1, 2);
    if (!(p.fx > 0.0) || !(p.fy > 0.0)) {
      fail(k_node, "camera_matrix",
           "has fx = " + formatReal(p.fx) + ", fy = " + formatReal(p.fy) +
               "; both focal lengths (in pixels) must be > 0");
    }
    p.distortion = distortion();
  }

  void readExtrinsics(OpenCvParameters& p) const {
    p.rvec = vector3("rvec");
    p.tvec = vector3("tvec");
  }

 private:
  [[noreturn]] void fail(const StorageNode& node, const std::string& field,
                         const std::string& message) const {
    throw InputError(file_, node.line, field, message);
  }

  std::string needs() const {
    switch (part_) {
      case Part::kIntrinsics:
        return "camera_matrix and distortion_coefficients (and image_width, image_height if "
               "known), as cv::FileStorage writes them";
      case Part::kExtrinsics:
        return "rvec and tvec, as cv::FileStorage writes them";
      case Part::kWhole:
        break;
    }
    return "image_width, image_height, camera_matrix, distortion_coefficients, rvec and tvec, as "
           "cv::FileStorage writes them";
  }

  const StorageNode* given(const char* key) const {
    const StorageNode* node = root_.find(key);
    return node != nullptr && node->kind != Kind::kNone ? node : nullptr;
  }

  const StorageNode& required(const char* key) const {
    const StorageNode* node = root_.find(key);
    if (node == nullptr || node->kind == Kind::kNone) {
      // Absent, it is nowhere in the file (line 0); empty, it is where its key is.
      throw InputError(file_, node != nullptr ? node->line : 0, key,
                       "is missing; an OpenCV calibration" +
                           std::string(part_ == Part::kWhole        ? ""
                                       : part_ == Part::kIntrinsics ? "'s intrinsics file"
                                                                    : "'s extrinsics file") +
                           " needs " + needs());
    }
    return *node;
  }

  static bool isNumberText(const StorageNode& node) {
    return node.kind == Kind::kScalar && !node.quoted;
  }

  static std::string describe(const StorageNode& node) {
    switch (node.kind) {
      case Kind::kList:
        return "a list";
      case Kind::kMapping:
        return "a mapping";
      case Kind::kNone:
        return "nothing";
      case Kind::kScalar:
        break;
    }
    if (node.quoted) return "the text " + inQuotes(node.scalar);
    return node.scalar.size() > 40 ? node.scalar.substr(0, 40) + "..." : node.scalar;
  }

  int imageSide(const StorageNode& node, const char* key) const {
    const std::optional<long long> value =
        isNumberText(node) ? parseInteger(node.scalar) : std::nullopt;
    if (!value) fail(node, key, "must be a whole number of pixels, got " + describe(node));
    if (*value < 1 || *value > kMaxImageSide) {
      fail(node, key,
           "is " + node.scalar + "; it must be from 1 to " + std::to_string(kMaxImageSide) +
               " pixels");
    }
    return static_cast<int>(*value);
  }

  // A number as YAML and cv::FileStorage write it: also ".inf", "-.Inf", ".NaN", which
  // std::from_chars does not read, so that the message says "not finite" rather than "no number".
  static std::optional<double> number(const StorageNode& node) {
    if (!isNumberText(node)) return std::nullopt;
    std::string lower = node.scalar;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (lower == ".inf" || lower == "+.inf") return std::numeric_limits<double>::infinity();
    if (lower == "-.inf") return -std::numeric_limits<double>::infinity();
    if (lower == ".nan") return std::numeric_limits<double>::quiet_NaN();
    return parseReal(node.scalar);
  }

  static std::string shape(const Matrix& m) {
    return std::to_string(m.rows) + "x" + std::to_string(m.cols);
  }

  // A cv::Mat as cv::FileStorage writes it (opencv-matrix: rows, cols, dt, data), or a plain list
  // as it writes a std::vector (a column).
  Matrix matrix(const StorageNode& node, const char* key) const {
    Matrix m;
    const StorageNode* data = nullptr;
    if (node.kind == Kind::kMapping) {
      const StorageNode* rows = node.find("rows");
      const StorageNode* cols = node.find("cols");
      data = node.find("data");
      const auto side = [](const StorageNode* n) -> std::optional<long long> {
        return n != nullptr && isNumberText(*n) ? parseInteger(n->scalar) : std::nullopt;
      };
      const std::optional<long long> row_count = side(rows), col_count = side(cols);
      if (!row_count || !col_count || data == nullptr || data->kind != Kind::kList) {
        fail(node, key,
             "is not an OpenCV matrix: it needs rows, cols, dt and data, as cv::FileStorage "
             "writes a cv::Mat");
      }
      // Bounded by the values given, so that the product below cannot overflow.
      const auto limit = static_cast<long long>(data->items.size()) + 1;
      m.rows = static_cast<int>(std::clamp(*row_count, -1LL, limit));
      m.cols = static_cast<int>(std::clamp(*col_count, -1LL, limit));
      if (m.rows < 1 || m.cols < 1) fail(node, key, "is " + shape(m) + "; it must not be empty");
    } else if (node.kind == Kind::kList) {
      data = &node;
      m.rows = static_cast<int>(std::min<std::size_t>(node.items.size(), INT_MAX));
      m.cols = 1;
      m.plain_list = true;
    } else {
      fail(node, key,
           "must be a matrix (rows, cols, dt, data) or a list of numbers, got " + describe(node));
    }
    const std::vector<StorageNode>& items = data->items;
    const long long count = static_cast<long long>(m.rows) * m.cols;
    if (count != static_cast<long long>(items.size())) {
      fail(node, key,
           "has " + std::to_string(items.size()) + " values in data for " + shape(m) +
               "; a single-channel matrix of rows x cols values is expected");
    }
    m.values.reserve(items.size());
    for (std::size_t index = 0; index < items.size(); ++index) {
      const StorageNode& element = items[index];
      const std::optional<double> value = number(element);
      if (!value) {
        fail(element, key,
             "value " + std::to_string(index) + " is " + describe(element) + ", not a number");
      }
      if (!std::isfinite(*value)) {
        fail(element, key,
             "value " + std::to_string(index) + " is " + element.scalar +
                 "; every value must be a finite number");
      }
      m.values.push_back(*value);
    }
    return m;
  }

  std::array<double, OpenCvParameters::kDistortionCount> distortion() const {
    constexpr const char* kKey = "distortion_coefficients";
    const StorageNode& node = required(kKey);
    const Matrix d = matrix(node, kKey);
    if (d.rows != 1 && d.cols != 1) fail(node, kKey, "is " + shape(d) + "; it must be 1xN or Nx1");
    const std::size_t count = d.values.size();
    // OpenCV's lengths: k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [taux tauy]]]].
    if (count != 4 && count != 5 && count != 8 && count != 12 && count != 14) {
      fail(node, kKey,
           "has " + std::to_string(count) +
               " coefficients; OpenCV's models have 4 or 5 (k1 k2 p1 p2 [k3]), 8 (+ k4 k5 k6, "
               "CALIB_RATIONAL_MODEL), 12 (+ s1 s2 s3 s4, CALIB_THIN_PRISM_MODEL) or 14 (+ taux "
               "tauy, CALIB_TILTED_MODEL)");
    }
    if (count == 14 && (d.values[12] != 0.0 || d.values[13] != 0.0)) {
      fail(node, kKey,
           "has a tilted sensor (taux = " + formatReal(d.values[12]) +
               ", tauy = " + formatReal(d.values[13]) +
               ", CALIB_TILTED_MODEL), which occmap does not model: recalibrate without "
               "CALIB_TILTED_MODEL (the rational and thin prism terms are supported)");
    }
    std::array<double, OpenCvParameters::kDistortionCount> k{};
    std::copy_n(d.values.begin(), std::min(count, k.size()), k.begin());
    return k;
  }

  Eigen::Vector3d vector3(const char* key) const {
    const StorageNode& node = required(key);
    const Matrix v = matrix(node, key);
    if (v.values.size() != 3 || (v.rows != 1 && v.cols != 1)) {
      fail(node, key, "is " + shape(v) + "; it must hold 3 values (3x1 or 1x3)");
    }
    return {v.values[0], v.values[1], v.values[2]};
  }

  const StorageNode& root_;
  const std::string& file_;
  Part part_;
};

// The file's tree: XML when it starts with '<', else YAML.
StorageNode readStorage(std::string_view text, const std::string& file) {
  const std::string_view content = firstContent(text);
  if (content.empty()) {
    throw InputError(file, 0, "", "is empty; expected an OpenCV calibration (YAML or XML)");
  }
  return content.starts_with('<') ? readXmlStorage(text, file) : readYamlStorage(text, file);
}

// Everything from one file.
OpenCvParameters wholeCalibration(const StorageNode& root, const std::string& file) {
  const OpenCvReader reader(root, file, Part::kWhole);
  OpenCvParameters p;
  reader.readIntrinsics(p);
  reader.readExtrinsics(p);
  return p;
}

}  // namespace

OpenCvParameters parseOpenCvStorage(std::string_view text, const std::string& file_name) {
  return wholeCalibration(readStorage(text, file_name), file_name);
}

OpenCvParameters parseOpenCvYaml(std::string_view text, const std::string& file_name) {
  if (firstContent(text).empty()) {
    throw InputError(file_name, 0, "", "is empty; expected an OpenCV calibration in YAML");
  }
  return wholeCalibration(readYamlStorage(text, file_name), file_name);
}

OpenCvParameters loadOpenCvYaml(const std::filesystem::path& file) {
  return parseOpenCvYaml(readTextFile(file, "calibration"), file.string());
}

OpenCvParameters loadOpenCvCalibration(const std::filesystem::path& intrinsics,
                                       const std::filesystem::path& extrinsics) {
  const std::string intrinsics_name = intrinsics.string();
  const std::string extrinsics_name = extrinsics.string();
  const StorageNode intrinsics_root =
      readStorage(readTextFile(intrinsics, "intrinsics"), intrinsics_name);
  const StorageNode extrinsics_root =
      readStorage(readTextFile(extrinsics, "extrinsics"), extrinsics_name);
  OpenCvParameters p;
  OpenCvReader(intrinsics_root, intrinsics_name, Part::kIntrinsics).readIntrinsics(p);
  OpenCvReader(extrinsics_root, extrinsics_name, Part::kExtrinsics).readExtrinsics(p);
  return p;
}

OpenCvParameters loadOpenCvIntrinsics(const std::filesystem::path& file) {
  const std::string name = file.string();
  const StorageNode root = readStorage(readTextFile(file, "intrinsics"), name);
  OpenCvParameters p;
  OpenCvReader(root, name, Part::kIntrinsics).readIntrinsics(p);
  return p;
}

std::string openCvYamlText(const OpenCvParameters& p) {
  const auto matrix = [](const char* name, int rows, const std::vector<double>& values) {
    std::string text =
        std::string(name) + ": !!opencv-matrix\n   rows: " + std::to_string(rows) +
        "\n   cols: " + std::to_string(values.size() / static_cast<std::size_t>(rows)) +
        "\n   dt: d\n   data: [";
    for (std::size_t i = 0; i < values.size(); ++i) {
      char number[32];
      std::snprintf(number, sizeof number, "%s%.17g", i == 0 ? " " : ", ", values[i]);
      text += number;
    }
    return text + " ]\n";
  };
  // As few coefficients as hold every non-zero one, in OpenCV's lengths (5, 8 or 12), so that a
  // usual lens is written as OpenCV's usual 5.
  const auto& k = p.distortion;
  std::size_t count = k.size();
  while (count > 5 && k[count - 1] == 0.0) --count;
  count = count <= 5 ? 5 : count <= 8 ? 8 : 12;
  // A camera whose size comes from its stream is written without one, as it was read.
  const std::string size = p.width > 0 ? "image_width: " + std::to_string(p.width) +
                                             "\nimage_height: " + std::to_string(p.height) + "\n"
                                       : "";
  return "%YAML:1.0\n---\n" + size +
         matrix("camera_matrix", 3, {p.fx, 0, p.cx, 0, p.fy, p.cy, 0, 0, 1}) +
         matrix("distortion_coefficients", static_cast<int>(count),
                {k.begin(), k.begin() + static_cast<std::ptrdiff_t>(count)}) +
         matrix("rvec", 3, {p.rvec.x(), p.rvec.y(), p.rvec.z()}) +
         matrix("tvec", 3, {p.tvec.x(), p.tvec.y(), p.tvec.z()});
}

}  // namespace occmap
