#pragma once
// The paths of a camera's pictures (docs/web.md): /camera/HOST/CAMERA.jpg,
// /camera/HOST/CAMERA/changed.png and /camera/HOST/CAMERA/cells.png, each name percent-encoded.
// The path is cut at its slashes before the names are decoded, and a decoded name is refused when
// it could mean anything but a name (empty, "." or "..", a slash, a control character), so that no
// request names something other than a camera heard on the bus.

#include <optional>
#include <string>
#include <string_view>

namespace occmap::web {

struct CameraPath {
  enum class Picture { kFrame, kChanged, kCells };
  std::string hostname;
  std::string camera;
  Picture picture = Picture::kFrame;
};

enum class CameraPathError {
  kNotACameraPath,  // not under /camera/, or not one of its pictures: 404
  kBadName,         // a name that does not decode, or decodes to more than a name: 400
};

// `path` (without the query) as a camera's picture, or nothing, `error` saying why.
std::optional<CameraPath> parseCameraPath(std::string_view path, CameraPathError& error);

// `text` percent-decoded, or nothing when an escape is not %XX.
std::optional<std::string> percentDecoded(std::string_view text);

}  // namespace occmap::web
