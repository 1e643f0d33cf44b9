#include "config/calibration_file.h"

#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <exception>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include <libxml/parser.h>
#include <libxml/tree.h>
#include <libxml/xmlerror.h>
#include <yaml-cpp/yaml.h>

#include "config/input_error.h"
#include "config/number_text.h"
#include "config/text_file.h"

namespace occmap {
namespace {

constexpr int kMaxImageSide = 65536;

// The text from its first character that is not a byte order mark or a blank: what tells the kinds
// of calibration file apart.
std::string_view firstContent(std::string_view text) {
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  return first == std::string_view::npos ? std::string_view{} : text.substr(first);
}

std::string inQuotes(std::string_view text) {
  constexpr std::size_t kShown = 40;
  if (text.size() > kShown) return "\"" + std::string(text.substr(0, kShown)) + "...\"";
  return "\"" + std::string(text) + "\"";
}

// ---------------------------------------------------------------------------------------------------
// Tsai, ETISEO/PETS XML

struct XmlDocumentFree {
  void operator()(xmlDoc* document) const { xmlFreeDoc(document); }
};
struct XmlParserFree {
  void operator()(xmlParserCtxt* parser) const { xmlFreeParserCtxt(parser); }
};
struct XmlTextFree {
  void operator()(xmlChar* text) const { xmlFree(text); }
};

const xmlChar* xmlText(const char* text) { return reinterpret_cast<const xmlChar*>(text); }
const char* plainText(const xmlChar* text) { return reinterpret_cast<const char*>(text); }

void initialiseLibxml2() {
  // libxml2 wants its global state set up once before threads use it; loading may run on a reload
  // thread while another part of the program reads XML.
  static const bool initialised = [] {
    xmlInitParser();
    return true;
  }();
  (void)initialised;
}

// Some libxml2 errors (an encoding that does not convert) bypass the parser context and print on
// stderr through the thread's generic handler; the context reports them too, so the handler is
// silenced while a file is parsed (it is per thread: other threads' libxml2 use is unaffected).
class QuietLibxml2 {
 public:
  QuietLibxml2() : handler_(xmlGenericError), context_(xmlGenericErrorContext) {
    xmlSetGenericErrorFunc(nullptr, &ignore);
  }
  ~QuietLibxml2() { xmlSetGenericErrorFunc(context_, handler_); }
  QuietLibxml2(const QuietLibxml2&) = delete;
  QuietLibxml2& operator=(const QuietLibxml2&) = delete;

 private:
  static void ignore(void*, const char*, ...) {}

  xmlGenericErrorFunc handler_;
  void* context_;
};

class TsaiXmlReader {
 public:
  TsaiXmlReader(std::string_view text, const std::string& file) : text_(text), file_(file) {
    // XML allows nothing before its declaration, but a file that starts with a blank line is
    // clearly meant as XML: read it from the declaration and keep the file's line numbers.
    const std::string_view content = firstContent(text_);
    if (content.starts_with("<?xml") && content.size() != text_.size()) {
      const std::string_view skipped = text_.substr(0, text_.size() - content.size());
      skipped_lines_ = static_cast<int>(std::count(skipped.begin(), skipped.end(), '\n'));
      text_ = content;
    }
  }

  TsaiParameters read() const {
    initialiseLibxml2();
    if (text_.size() > static_cast<std::size_t>(INT_MAX)) {
      throw InputError(file_, 0, "", "is too large to be a calibration file");
    }
    const QuietLibxml2 quiet;
    const std::unique_ptr<xmlParserCtxt, XmlParserFree> parser(xmlNewParserCtxt());
    if (!parser) throw std::bad_alloc();
    // NONET: a calibration file never makes the daemon fetch anything. Without NOENT and DTDLOAD no
    // external entity is read either. Errors come back through the context, not on stderr.
    const int options =
        XML_PARSE_NONET | XML_PARSE_NOERROR | XML_PARSE_NOWARNING | XML_PARSE_BIG_LINES;
    const std::unique_ptr<xmlDoc, XmlDocumentFree> document(
        xmlCtxtReadMemory(parser.get(), text_.data(), static_cast<int>(text_.size()), file_.c_str(),
                          nullptr, options));
    if (!document) {
      const xmlError* error = xmlCtxtGetLastError(parser.get());
      std::string reason = error != nullptr && error->message != nullptr
                               ? std::string(trimBlanks(error->message))
                               : "unknown libxml2 error";
      std::replace(reason.begin(), reason.end(), '\n', ' ');  // one message, one line
      throw InputError(file_,
                       error != nullptr && error->line > 0 ? error->line + skipped_lines_ : 0, "",
                       "is not well-formed XML: " + reason + "; fix the XML syntax");
    }
    const xmlNode* camera = xmlDocGetRootElement(document.get());
    if (camera == nullptr) throw InputError(file_, 0, "", "has no XML element; expected <Camera>");
    const std::string root_name = plainText(camera->name);
    if (root_name != "Camera") {
      std::string hint = "expected <Camera> of the ETISEO/PETS Tsai layout";
      if (root_name == "opencv_storage") {
        hint += "; this is an OpenCV FileStorage XML file: save the calibration as YAML (.yml)";
      }
      throw InputError(file_, elementLine(camera), "",
                       "root element is <" + root_name + ">, " + hint);
    }

    const xmlNode* geometry = child(camera, "Geometry");
    const xmlNode* intrinsic = child(camera, "Intrinsic");
    const xmlNode* extrinsic = child(camera, "Extrinsic");

    TsaiParameters p;
    p.width = pixels(geometry, "width", "image width");
    p.height = pixels(geometry, "height", "image height");
    p.ncx = positive(geometry, "ncx", "number of sensor elements in x");
    p.nfx = positive(geometry, "nfx", "number of pixels in a frame grabber row");
    p.dx = positive(geometry, "dx", "sensor element spacing in x");
    p.dy = positive(geometry, "dy", "sensor element spacing in y");
    // Willson's model defines dpx = dx ncx / nfx and dpy = dy; a file may leave them out, but one
    // that gives them must agree, or the file holds two different cameras.
    p.dpx = effectivePixelSpacing(geometry, "dpx", p.dx * p.ncx / p.nfx,
                                  "Geometry.dx * Geometry.ncx / Geometry.nfx", "dx * ncx / nfx");
    p.dpy = effectivePixelSpacing(geometry, "dpy", p.dy, "Geometry.dy", "dy");

    p.focal = positive(intrinsic, "focal", "focal length");
    p.kappa1 = number(intrinsic, "kappa1", "radial distortion kappa1");
    p.cx = number(intrinsic, "cx", "image centre column");
    p.cy = number(intrinsic, "cy", "image centre row");
    p.sx = positive(intrinsic, "sx", "horizontal scale factor");

    p.tx = number(extrinsic, "tx", "translation x");
    p.ty = number(extrinsic, "ty", "translation y");
    p.tz = number(extrinsic, "tz", "translation z");
    p.rx = number(extrinsic, "rx", "rotation angle about x");
    p.ry = number(extrinsic, "ry", "rotation angle about y");
    p.rz = number(extrinsic, "rz", "rotation angle about z");
    return p;
  }

 private:
  static std::string field(const xmlNode* element, const char* attribute) {
    return std::string(plainText(element->name)) + "." + attribute;
  }

  int lineAt(std::size_t offset) const {
    return skipped_lines_ + 1 +
           static_cast<int>(std::count(text_.begin(),
                                       text_.begin() + static_cast<std::ptrdiff_t>(offset), '\n'));
  }

  // libxml2 records the line where an element's start tag ends; an element written over several
  // lines (as the EPFL files are) is found by the user where it starts, and an attribute on its own
  // line. So the start tag is looked up in the text: it is the last "<Name" before the end of that
  // line (a start tag holds no '<').
  std::optional<std::size_t> startTagOffset(const xmlNode* element) const {
    const long line = xmlGetLineNo(element);
    if (line <= 0) return std::nullopt;
    std::size_t end = 0;
    for (long l = 0; l < line && end != std::string_view::npos; ++l) {
      end = text_.find('\n', l == 0 ? 0 : end + 1);
    }
    if (end == std::string_view::npos) end = text_.size();
    const std::string tag = "<" + std::string(plainText(element->name));
    for (std::size_t at = text_.rfind(tag, end); at != std::string_view::npos;
         at = at == 0 ? std::string_view::npos : text_.rfind(tag, at - 1)) {
      const std::size_t after = at + tag.size();
      if (after < text_.size() &&
          std::string_view(" \t\r\n/>").find(text_[after]) != std::string_view::npos) {
        return at;
      }
    }
    return std::nullopt;
  }

  int elementLine(const xmlNode* element) const {
    if (const std::optional<std::size_t> start = startTagOffset(element)) return lineAt(*start);
    const long line = xmlGetLineNo(element);
    return line > 0
               ? static_cast<int>(std::min(line, static_cast<long>(INT_MAX / 2))) + skipped_lines_
               : 0;
  }

  // The line of `attribute` in the element's start tag, read with the start tag's own grammar
  // (name = "value" pairs), else the element's line.
  int attributeLine(const xmlNode* element, std::string_view attribute) const {
    const std::optional<std::size_t> start = startTagOffset(element);
    if (!start) return elementLine(element);
    constexpr std::string_view kBlanks = " \t\r\n";
    std::size_t at = *start + 1 + std::string_view(plainText(element->name)).size();
    auto skipBlanks = [&] {
      while (at < text_.size() && kBlanks.find(text_[at]) != std::string_view::npos) ++at;
    };
    while (true) {
      skipBlanks();
      if (at >= text_.size() || text_[at] == '/' || text_[at] == '>') break;
      const std::size_t name_start = at;
      while (at < text_.size() && kBlanks.find(text_[at]) == std::string_view::npos &&
             text_[at] != '=' && text_[at] != '/' && text_[at] != '>') {
        ++at;
      }
      const std::string_view name = text_.substr(name_start, at - name_start);
      skipBlanks();
      if (at >= text_.size() || text_[at] != '=') break;
      ++at;
      skipBlanks();
      if (at >= text_.size() || (text_[at] != '"' && text_[at] != '\'')) break;
      const std::size_t close = text_.find(text_[at], at + 1);
      if (close == std::string_view::npos) break;
      if (name == attribute) return lineAt(name_start);
      at = close + 1;
    }
    return elementLine(element);
  }

  const xmlNode* child(const xmlNode* camera, const char* name) const {
    const xmlNode* found = nullptr;
    for (const xmlNode* node = camera->children; node != nullptr; node = node->next) {
      if (node->type != XML_ELEMENT_NODE || std::string_view(plainText(node->name)) != name) {
        continue;
      }
      if (found != nullptr) {
        throw InputError(file_, elementLine(node), name,
                         "<" + std::string(name) + "> appears twice (lines " +
                             std::to_string(elementLine(found)) + " and " +
                             std::to_string(elementLine(node)) + "); keep one");
      }
      found = node;
    }
    if (found == nullptr) {
      throw InputError(file_, elementLine(camera), name,
                       "element <" + std::string(name) +
                           "> is missing from <Camera>; a Tsai calibration has <Geometry>, "
                           "<Intrinsic> and <Extrinsic>");
    }
    return found;
  }

  std::optional<double> optionalNumber(const xmlNode* element, const char* attribute,
                                       const char* meaning) const {
    if (xmlHasProp(element, xmlText(attribute)) == nullptr) return std::nullopt;
    const std::unique_ptr<xmlChar, XmlTextFree> value(xmlGetProp(element, xmlText(attribute)));
    const std::string_view text = value ? plainText(value.get()) : "";
    const std::optional<double> number = parseReal(text);
    if (!number) {
      throw InputError(file_, attributeLine(element, attribute), field(element, attribute),
                       inQuotes(text) + " is not a number; write the " + meaning +
                           " as a decimal number (such as 1.5 or 2.3e-02)");
    }
    if (!std::isfinite(*number)) {
      throw InputError(file_, attributeLine(element, attribute), field(element, attribute),
                       "is " + inQuotes(text) + "; the " + meaning + " must be a finite number");
    }
    return number;
  }

  double number(const xmlNode* element, const char* attribute, const char* meaning) const {
    const std::optional<double> value = optionalNumber(element, attribute, meaning);
    if (!value) {
      throw InputError(file_, elementLine(element), field(element, attribute),
                       "attribute " + std::string(attribute) + " (the " + meaning +
                           ") is missing; add " + attribute + "=\"...\" to <" +
                           plainText(element->name) + ">");
    }
    return *value;
  }

  void requirePositive(const xmlNode* element, const char* attribute, const char* meaning,
                       double value) const {
    if (!(value > 0.0)) {
      throw InputError(file_, attributeLine(element, attribute), field(element, attribute),
                       "is " + formatReal(value) + "; the " + meaning + " must be > 0");
    }
  }

  double positive(const xmlNode* element, const char* attribute, const char* meaning) const {
    const double value = number(element, attribute, meaning);
    requirePositive(element, attribute, meaning, value);
    return value;
  }

  int pixels(const xmlNode* element, const char* attribute, const char* meaning) const {
    const double value = positive(element, attribute, meaning);
    if (value != std::floor(value) || value > kMaxImageSide) {
      throw InputError(file_, attributeLine(element, attribute), field(element, attribute),
                       "is " + formatReal(value) + "; the " + meaning +
                           " must be a whole number of pixels from 1 to " +
                           std::to_string(kMaxImageSide));
    }
    return static_cast<int>(value);
  }

  double effectivePixelSpacing(const xmlNode* geometry, const char* attribute, double defined,
                               const std::string& defined_fields,
                               const std::string& definition) const {
    const std::string meaning = std::string("effective pixel spacing ") + attribute;
    const std::optional<double> given = optionalNumber(geometry, attribute, meaning.c_str());
    if (!given) return defined;
    requirePositive(geometry, attribute, meaning.c_str(), *given);
    constexpr double kRelativeTolerance = 1e-6;
    const double difference = std::abs(*given - defined) / defined;
    if (!(difference <= kRelativeTolerance)) {
      throw InputError(file_, attributeLine(geometry, attribute), field(geometry, attribute),
                       "is " + formatReal(*given) + " but " + defined_fields + " = " +
                           formatReal(defined) + " (relative difference " + formatReal(difference) +
                           "); Willson's model defines " + attribute + " = " + definition +
                           ": correct the wrong value, or leave " + attribute +
                           " out to have it computed");
    }
    return *given;
  }

  std::string_view text_;
  const std::string& file_;
  int skipped_lines_ = 0;  // blank lines before the XML declaration
};

// ---------------------------------------------------------------------------------------------------
// OpenCV, cv::FileStorage YAML, read with yaml-cpp
//
// Not with cv::FileStorage: fuzzing found OpenCV 4.6's YAML parser (Debian bookworm's) looping for
// ever on "----Y\nY\nY" and on "!!binary" in a list, and overflowing the stack on 40 000 nested
// "[" (fuzz/regressions/opencv_calibration/): a calibration could hang occmapd at start or on a
// reload, or kill it. yaml-cpp reads what cv::FileStorage writes (its "%YAML:1.0" line, the
// !!opencv-matrix tags, flow lists over several lines), bounds its nesting, and says where each
// value is, so errors about values name their line too.

struct Matrix {
  int rows = 0;
  int cols = 0;
  std::vector<double> values;  // row-major
  bool plain_list = false;     // written as a list of numbers, not as a cv::Mat
};

class OpenCvYamlReader {
 public:
  OpenCvYamlReader(std::string_view text, const std::string& file) : text_(text), file_(file) {}

  OpenCvParameters read() const {
    YAML::Node root;
    try {
      root = YAML::Load(text_);
      return read(root);
    } catch (const YAML::Exception& error) {
      throw InputError(file_, error.mark.is_null() ? 0 : error.mark.line + 1, "",
                       "is not valid YAML: " + error.msg + "; fix the YAML syntax");
    }
  }

 private:
  static int lineOf(const YAML::Node& node) {
    const YAML::Mark mark = node.Mark();
    return mark.is_null() ? 0 : mark.line + 1;
  }

  // A quoted scalar ("640") is text in YAML even when it reads like a number.
  static bool isText(const YAML::Node& node) {
    return node.IsScalar() && (node.Tag() == "!" || node.Tag() == "tag:yaml.org,2002:str");
  }

  [[noreturn]] void fail(const YAML::Node& node, const std::string& field,
                         const std::string& message) const {
    throw InputError(file_, lineOf(node), field, message);
  }

  OpenCvParameters read(const YAML::Node& root) const {
    if (!root.IsMap()) {
      fail(root, "",
           "top level must be a mapping with image_width, image_height, camera_matrix, "
           "distortion_coefficients, rvec and tvec, as cv::FileStorage writes them");
    }
    OpenCvParameters p;
    p.width = imageSide(root, "image_width");
    p.height = imageSide(root, "image_height");

    const YAML::Node k_node = required(root, "camera_matrix");
    Matrix k = matrix(root, "camera_matrix");
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

    p.distortion = distortion(root);
    p.rvec = vector3(root, "rvec");
    p.tvec = vector3(root, "tvec");
    return p;
  }

  YAML::Node required(const YAML::Node& root, const char* key) const {
    const YAML::Node node = root[key];
    if (!node.IsDefined() || node.IsNull()) {
      // Absent, it is nowhere in the file (line 0); empty, it is where its key is.
      throw InputError(file_, node.IsDefined() ? lineOf(node) : 0, key,
                       "is missing; an OpenCV calibration needs image_width, image_height, "
                       "camera_matrix, distortion_coefficients, rvec and tvec");
    }
    return node;
  }

  static std::string describe(const YAML::Node& node) {
    if (node.IsSequence()) return "a list";
    if (node.IsMap()) return "a mapping";
    if (!node.IsScalar()) return "nothing";
    const std::string& text = node.Scalar();
    if (isText(node)) return "the text " + inQuotes(text);
    return text.size() > 40 ? text.substr(0, 40) + "..." : text;
  }

  int imageSide(const YAML::Node& root, const char* key) const {
    const YAML::Node node = required(root, key);
    const std::optional<long long> value =
        node.IsScalar() && !isText(node) ? parseInteger(node.Scalar()) : std::nullopt;
    if (!value) fail(node, key, "must be a whole number of pixels, got " + describe(node));
    if (*value < 1 || *value > kMaxImageSide) {
      fail(node, key,
           "is " + node.Scalar() + "; it must be from 1 to " + std::to_string(kMaxImageSide) +
               " pixels");
    }
    return static_cast<int>(*value);
  }

  // A number as YAML and cv::FileStorage write it: also ".inf", "-.Inf", ".NaN", which
  // std::from_chars does not read, so that the message says "not finite" rather than "no number".
  static std::optional<double> number(const YAML::Node& node) {
    if (!node.IsScalar() || isText(node)) return std::nullopt;
    std::string lower = node.Scalar();
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (lower == ".inf" || lower == "+.inf") return std::numeric_limits<double>::infinity();
    if (lower == "-.inf") return -std::numeric_limits<double>::infinity();
    if (lower == ".nan") return std::numeric_limits<double>::quiet_NaN();
    return parseReal(node.Scalar());
  }

  static std::string shape(const Matrix& m) {
    return std::to_string(m.rows) + "x" + std::to_string(m.cols);
  }

  // A cv::Mat as cv::FileStorage writes it (!!opencv-matrix: rows, cols, dt, data), or a plain list
  // as it writes a std::vector (a column).
  Matrix matrix(const YAML::Node& root, const char* key) const {
    const YAML::Node node = required(root, key);
    Matrix m;
    YAML::Node data;
    if (node.IsMap()) {
      const YAML::Node rows = node["rows"];
      const YAML::Node cols = node["cols"];
      data = node["data"];
      const auto side = [](const YAML::Node& n) -> std::optional<long long> {
        return n.IsScalar() && !isText(n) ? parseInteger(n.Scalar()) : std::nullopt;
      };
      const std::optional<long long> row_count = side(rows), col_count = side(cols);
      if (!row_count || !col_count || !data.IsSequence()) {
        fail(node, key,
             "is not an OpenCV matrix: it needs rows, cols, dt and data, as cv::FileStorage "
             "writes a cv::Mat");
      }
      // Bounded by the values given, so that the product below cannot overflow.
      const auto limit = static_cast<long long>(data.size()) + 1;
      m.rows = static_cast<int>(std::clamp(*row_count, -1LL, limit));
      m.cols = static_cast<int>(std::clamp(*col_count, -1LL, limit));
      if (m.rows < 1 || m.cols < 1) fail(node, key, "is " + shape(m) + "; it must not be empty");
    } else if (node.IsSequence()) {
      data = node;
      m.rows = static_cast<int>(std::min<std::size_t>(node.size(), INT_MAX));
      m.cols = 1;
      m.plain_list = true;
    } else {
      fail(node, key,
           "must be a matrix (rows, cols, dt, data) or a list of numbers, got " + describe(node));
    }
    const long long count = static_cast<long long>(m.rows) * m.cols;
    if (count != static_cast<long long>(data.size())) {
      fail(node, key,
           "has " + std::to_string(data.size()) + " values in data for " + shape(m) +
               "; a single-channel matrix of rows x cols values is expected");
    }
    m.values.reserve(data.size());
    for (std::size_t index = 0; index < data.size(); ++index) {
      const YAML::Node element = data[index];
      const std::optional<double> value = number(element);
      if (!value) {
        fail(element, key,
             "value " + std::to_string(index) + " is " + describe(element) + ", not a number");
      }
      if (!std::isfinite(*value)) {
        fail(element, key,
             "value " + std::to_string(index) + " is " + element.Scalar() +
                 "; every value must be a finite number");
      }
      m.values.push_back(*value);
    }
    return m;
  }

  std::array<double, 5> distortion(const YAML::Node& root) const {
    constexpr const char* kKey = "distortion_coefficients";
    const YAML::Node node = required(root, kKey);
    const Matrix d = matrix(root, kKey);
    if (d.rows != 1 && d.cols != 1) fail(node, kKey, "is " + shape(d) + "; it must be 1xN or Nx1");
    const std::size_t count = d.values.size();
    std::array<double, 5> k{};  // k1 k2 p1 p2 k3
    if (count == 4 || count == 5) {
      std::copy(d.values.begin(), d.values.end(), k.begin());
      return k;
    }
    if (count == 8 || count == 12 || count == 14) {
      // OpenCV's rational, thin prism and tilted models: with their extra terms zero they are the
      // 5-coefficient model exactly.
      const bool extras_zero = std::all_of(d.values.begin() + 5, d.values.end(),
                                           [](double value) { return value == 0.0; });
      if (extras_zero) {
        std::copy(d.values.begin(), d.values.begin() + 5, k.begin());
        return k;
      }
      fail(node, kKey,
           "has " + std::to_string(count) +
               " coefficients (OpenCV's rational, thin prism or tilted model); only the "
               "4/5-coefficient model k1 k2 p1 p2 [k3] is supported: recalibrate without "
               "CALIB_RATIONAL_MODEL, CALIB_THIN_PRISM_MODEL and CALIB_TILTED_MODEL");
    }
    fail(node, kKey,
         "has " + std::to_string(count) +
             " coefficients; expected 5 (k1 k2 p1 p2 k3) or 4 (k1 k2 p1 p2)");
  }

  Eigen::Vector3d vector3(const YAML::Node& root, const char* key) const {
    const YAML::Node node = required(root, key);
    const Matrix v = matrix(root, key);
    if (v.values.size() != 3 || (v.rows != 1 && v.cols != 1)) {
      fail(node, key, "is " + shape(v) + "; it must hold 3 values (3x1 or 1x3)");
    }
    return {v.values[0], v.values[1], v.values[2]};
  }

  std::string text_;
  const std::string& file_;
};

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

}  // namespace

TsaiParameters parseTsaiXml(std::string_view text, const std::string& file_name) {
  return TsaiXmlReader(text, file_name).read();
}

TsaiParameters loadTsaiXml(const std::filesystem::path& file) {
  return parseTsaiXml(readTextFile(file, "calibration"), file.string());
}

OpenCvParameters parseOpenCvYaml(std::string_view text, const std::string& file_name) {
  if (firstContent(text).empty()) {
    throw InputError(file_name, 0, "", "is empty; expected an OpenCV calibration in YAML");
  }
  return OpenCvYamlReader(text, file_name).read();
}

OpenCvParameters loadOpenCvYaml(const std::filesystem::path& file) {
  return parseOpenCvYaml(readTextFile(file, "calibration"), file.string());
}

LoadedCalibration loadCalibration(const std::filesystem::path& file,
                                  std::optional<LengthUnit> units) {
  const std::string text = readTextFile(file, "calibration");
  const std::string name = file.string();
  const std::string_view content = firstContent(text);
  if (content.empty()) {
    throw InputError(name, 0, "",
                     "is empty; expected a Tsai calibration (ETISEO XML) or an OpenCV "
                     "calibration (YAML)");
  }
  if (content.starts_with('<')) {
    return {std::make_shared<TsaiCamera>(parseTsaiXml(text, name)),
            units.value_or(LengthUnit::kMillimetre), "tsai"};
  }
  const std::string extension = lowercase(file.extension().string());
  if (content.starts_with("%YAML") || extension == ".yml" || extension == ".yaml") {
    return {std::make_shared<OpenCvCamera>(parseOpenCvYaml(text, name)),
            units.value_or(LengthUnit::kMetre), "opencv"};
  }
  throw InputError(name, 1, "",
                   "is neither a Tsai calibration (ETISEO XML, starting with <?xml) nor an "
                   "OpenCV calibration (YAML starting with %YAML:1.0, or a file named .yml or "
                   ".yaml)");
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
  const auto& [k1, k2, p1, p2, k3] = p.distortion;
  return "%YAML:1.0\n---\nimage_width: " + std::to_string(p.width) +
         "\nimage_height: " + std::to_string(p.height) + "\n" +
         matrix("camera_matrix", 3, {p.fx, 0, p.cx, 0, p.fy, p.cy, 0, 0, 1}) +
         matrix("distortion_coefficients", 5, {k1, k2, p1, p2, k3}) +
         matrix("rvec", 3, {p.rvec.x(), p.rvec.y(), p.rvec.z()}) +
         matrix("tvec", 3, {p.tvec.x(), p.tvec.y(), p.tvec.z()});
}

std::optional<CalibrationText> calibrationText(const CameraModel& model,
                                               const std::string& camera_name) {
  if (const auto* tsai = dynamic_cast<const TsaiCamera*>(&model)) {
    return CalibrationText{tsaiXmlText(tsai->parameters(), camera_name), ".xml"};
  }
  if (const auto* opencv = dynamic_cast<const OpenCvCamera*>(&model)) {
    return CalibrationText{openCvYamlText(opencv->parameters()), ".yaml"};
  }
  return std::nullopt;
}

std::string tsaiXmlText(const TsaiParameters& p, const std::string& camera_name) {
  char text[1024];
  std::snprintf(text, sizeof text,
                "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                "<Camera name=\"%s\">\n"
                "  <Geometry width=\"%d\" height=\"%d\" ncx=\"%.17g\" nfx=\"%.17g\" dx=\"%.17g\" "
                "dy=\"%.17g\" dpx=\"%.17g\" dpy=\"%.17g\"/>\n"
                "  <Intrinsic focal=\"%.17g\" kappa1=\"%.17g\" cx=\"%.17g\" cy=\"%.17g\" "
                "sx=\"%.17g\"/>\n"
                "  <Extrinsic tx=\"%.17g\" ty=\"%.17g\" tz=\"%.17g\" rx=\"%.17g\" ry=\"%.17g\" "
                "rz=\"%.17g\"/>\n"
                "</Camera>\n",
                camera_name.c_str(), p.width, p.height, p.ncx, p.nfx, p.dx, p.dy, p.dpx, p.dpy,
                p.focal, p.kappa1, p.cx, p.cy, p.sx, p.tx, p.ty, p.tz, p.rx, p.ry, p.rz);
  return text;
}

}  // namespace occmap
