#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace occmap {

// A camera's `source` from the config, taken apart.
//   files://<glob>           images on disk, relative globs from the config file's folder
//   sim://<scene>/<camera>   the simulator
//   aravis://<device-id>     a GigE Vision / USB3 Vision camera
//   v4l2:///dev/videoN       a Video4Linux2 device
struct SourceSpec {
  enum class Kind { kFiles, kSim, kAravis, kV4l2 };
  Kind kind = Kind::kFiles;
  std::string pattern;  // files: the glob, absolute
  std::string scene;    // sim
  std::string camera;   // sim: the scene's camera name
  std::string device;   // aravis: device id; v4l2: device path
};

// Empty with `error` set (what is wrong and what a valid source looks like) for a malformed source.
std::optional<SourceSpec> parseSource(std::string_view text, const std::filesystem::path& base,
                                      std::string& error);

// Numeric-aware ordering of file names: "frame2" < "frame10", as people number their frames.
bool naturalLess(std::string_view a, std::string_view b);

}  // namespace occmap
