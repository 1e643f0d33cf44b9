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

#include <libxml/tree.h>

#include "config/input_error.h"
#include "config/number_text.h"
#include "config/text_file.h"
#include "config/xml_document.h"

namespace occmap {
namespace {

// ---------------------------------------------------------------------------------------------------
// Tsai, ETISEO/PETS XML

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
    const XmlDocument document = parseXmlDocument(text_, file_, skipped_lines_);
    const xmlNode* camera = xmlDocGetRootElement(document.get());
    if (camera == nullptr) throw InputError(file_, 0, "", "has no XML element; expected <Camera>");
    const std::string root_name = plainText(camera->name);
    if (root_name != "Camera") {
      throw InputError(file_, elementLine(camera), "",
                       "root element is <" + root_name +
                           ">, expected <Camera> of the ETISEO/PETS Tsai layout" +
                           (root_name == "opencv_storage"
                                ? "; this is an OpenCV calibration (cv::FileStorage XML): give it "
                                  "as the camera's calibration, which reads either kind"
                                : ""));
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

std::shared_ptr<const CameraModel> LoadedCalibration::modelFor(int stream_width,
                                                               int stream_height) const {
  if (!sizeFromStream()) return model;
  // Only OpenCV files may leave the size out.
  OpenCvParameters sized = static_cast<const OpenCvCamera&>(*model).parameters();
  sized.width = stream_width;
  sized.height = stream_height;
  return std::make_shared<OpenCvCamera>(sized);
}

LoadedCalibration loadCalibration(const CalibrationFiles& files, std::optional<LengthUnit> units,
                                  WorldFrame world_frame) {
  const std::string name = files.file.string();
  const auto opencv = [&](OpenCvParameters p) {
    p.world_frame = world_frame;
    return LoadedCalibration{std::make_shared<OpenCvCamera>(p), units.value_or(LengthUnit::kMetre),
                             "opencv"};
  };
  if (files.extrinsics) return opencv(loadOpenCvCalibration(files.file, *files.extrinsics));
  const std::string text = readTextFile(files.file, "calibration");
  const std::string_view content = firstContent(text);
  if (content.empty()) {
    throw InputError(name, 0, "",
                     "is empty; expected a Tsai calibration (ETISEO XML) or an OpenCV "
                     "calibration (YAML or XML)");
  }
  const std::string extension = lowercase(files.file.extension().string());
  if (content.starts_with('<') && content.find("<opencv_storage") != std::string_view::npos) {
    return opencv(parseOpenCvStorage(text, name));
  }
  if (content.starts_with('<')) {
    if (world_frame == WorldFrame::kLeftHanded) {
      throw InputError(name, 0, "",
                       "is a Tsai calibration, whose world frame is right-handed by definition; "
                       "world_frame: left-handed is for OpenCV calibrations made in a left-handed "
                       "world (Unity's, MultiviewX's): remove it");
    }
    return {std::make_shared<TsaiCamera>(parseTsaiXml(text, name)),
            units.value_or(LengthUnit::kMillimetre), "tsai"};
  }
  if (content.starts_with("%YAML") || extension == ".yml" || extension == ".yaml") {
    return opencv(parseOpenCvYaml(text, name));
  }
  throw InputError(name, 1, "",
                   "is neither a Tsai calibration (ETISEO XML, starting with <?xml) nor an "
                   "OpenCV calibration (YAML starting with %YAML:1.0 or named .yml or .yaml, or "
                   "XML with <opencv_storage>)");
}

LoadedCalibration loadCalibration(const std::filesystem::path& file,
                                  std::optional<LengthUnit> units) {
  return loadCalibration(CalibrationFiles{file, std::nullopt}, units);
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
