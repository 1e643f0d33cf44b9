#include "capture/source_spec.h"

#include <cctype>

namespace occmap {

std::optional<SourceSpec> parseSource(std::string_view text, const std::filesystem::path& base,
                                      std::string& error) {
  const std::size_t separator = text.find("://");
  if (separator == std::string_view::npos) {
    error = "source '" + std::string(text) +
            "' has no scheme; use files://<glob>, sim://<scene>/<camera>, aravis://<device> or "
            "v4l2:///dev/videoN";
    return std::nullopt;
  }
  const std::string_view scheme = text.substr(0, separator);
  const std::string_view rest = text.substr(separator + 3);
  SourceSpec spec;
  if (scheme == "files") {
    spec.kind = SourceSpec::Kind::kFiles;
    if (rest.empty()) {
      error = "files:// needs a glob of image files, e.g. files://frames/c0/*.png";
      return std::nullopt;
    }
    std::filesystem::path pattern(rest);
    if (pattern.is_relative()) pattern = base / pattern;
    spec.pattern = pattern.lexically_normal().string();
  } else if (scheme == "sim") {
    spec.kind = SourceSpec::Kind::kSim;
    const std::size_t slash = rest.find('/');
    if (slash == std::string_view::npos || slash == 0 || slash + 1 == rest.size()) {
      error = "sim source '" + std::string(text) +
              "' must read sim://<scene>/<camera>, e.g. sim://room/c0";
      return std::nullopt;
    }
    spec.scene = std::string(rest.substr(0, slash));
    spec.camera = std::string(rest.substr(slash + 1));
  } else if (scheme == "aravis") {
    spec.kind = SourceSpec::Kind::kAravis;
    spec.device = std::string(rest);
  } else if (scheme == "v4l2") {
    spec.kind = SourceSpec::Kind::kV4l2;
    spec.device = std::string(rest);
    if (spec.device.empty() || spec.device.front() != '/') {
      error = "v4l2 source '" + std::string(text) +
              "' must name a device path, e.g. v4l2:///dev/video0";
      return std::nullopt;
    }
  } else {
    error = "unknown source scheme '" + std::string(scheme) +
            "://'; use files://, sim://, aravis:// or v4l2://";
    return std::nullopt;
  }
  return spec;
}

bool naturalLess(std::string_view a, std::string_view b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      // Compare digit runs as numbers: skip leading zeros, then the longer run is larger.
      std::size_t ia = i, jb = j;
      while (ia < a.size() && a[ia] == '0') ++ia;
      while (jb < b.size() && b[jb] == '0') ++jb;
      std::size_t ea = ia, eb = jb;
      while (ea < a.size() && std::isdigit(static_cast<unsigned char>(a[ea]))) ++ea;
      while (eb < b.size() && std::isdigit(static_cast<unsigned char>(b[eb]))) ++eb;
      if (ea - ia != eb - jb) return ea - ia < eb - jb;
      const int order = a.substr(ia, ea - ia).compare(b.substr(jb, eb - jb));
      if (order != 0) return order < 0;
      // Equal numbers: fewer leading zeros first, so the order is total.
      if (ia - i != jb - j) return ia - i < jb - j;
      i = ea;
      j = eb;
      continue;
    }
    if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
    ++i;
    ++j;
  }
  return a.size() - i < b.size() - j;
}

}  // namespace occmap
