#include "web/camera_path.h"

#include <algorithm>
#include <vector>

namespace occmap::web {
namespace {

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// A decoded name that names one thing and nothing else.
bool plainName(const std::string& name) {
  if (name.empty() || name == "." || name == ".." || name.size() > 255) return false;
  return std::none_of(name.begin(), name.end(), [](char c) {
    const auto byte = static_cast<unsigned char>(c);
    return c == '/' || c == '\\' || byte < 0x20 || byte == 0x7f;
  });
}

}  // namespace

std::optional<std::string> percentDecoded(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t k = 0; k < text.size(); ++k) {
    if (text[k] != '%') {
      out += text[k];
      continue;
    }
    if (k + 2 >= text.size()) return std::nullopt;
    const int high = hexValue(text[k + 1]);
    const int low = hexValue(text[k + 2]);
    if (high < 0 || low < 0) return std::nullopt;
    out += static_cast<char>(high * 16 + low);
    k += 2;
  }
  return out;
}

std::optional<CameraPath> parseCameraPath(std::string_view path, CameraPathError& error) {
  error = CameraPathError::kNotACameraPath;
  constexpr std::string_view kPrefix = "/camera/";
  if (!path.starts_with(kPrefix)) return std::nullopt;
  std::vector<std::string_view> parts;
  std::string_view rest = path.substr(kPrefix.size());
  for (;;) {
    const std::size_t slash = rest.find('/');
    parts.push_back(rest.substr(0, slash));
    if (slash == std::string_view::npos) break;
    rest = rest.substr(slash + 1);
  }
  CameraPath found;
  std::string_view camera;
  if (parts.size() == 2 && parts[1].ends_with(".jpg")) {
    camera = parts[1].substr(0, parts[1].size() - 4);
    found.picture = CameraPath::Picture::kFrame;
  } else if (parts.size() == 3 && parts[2] == "changed.png") {
    camera = parts[1];
    found.picture = CameraPath::Picture::kChanged;
  } else if (parts.size() == 3 && parts[2] == "cells.png") {
    camera = parts[1];
    found.picture = CameraPath::Picture::kCells;
  } else {
    return std::nullopt;
  }
  std::optional<std::string> hostname = percentDecoded(parts[0]);
  std::optional<std::string> camera_name = percentDecoded(camera);
  if (!hostname || !camera_name || !plainName(*hostname) || !plainName(*camera_name)) {
    error = CameraPathError::kBadName;
    return std::nullopt;
  }
  found.hostname = std::move(*hostname);
  found.camera = std::move(*camera_name);
  return found;
}

}  // namespace occmap::web
