#pragma once

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "capture/frame_source.h"

namespace occmap {

// What the config asks of a live camera.
struct LiveSourceOptions {
  // The stream size the daemon expects (the background image's); 0 = the device's own choice.
  int width = 0;
  int height = 0;
  double fps = 0;  // 0 = the device's own choice
  // Backend features as the config wrote them: GenICam feature names for Aravis (PixelFormat,
  // ExposureTime, Gain, GevSCPSPacketSize, ...), V4L2 format and control names for V4L2.
  std::vector<std::pair<std::string, std::string>> settings;
  // The camera's name in the config, for log lines.
  std::string name;
  // Hears what a person should know that is not an error: a setting the camera adjusted, a
  // realtime priority refused. Called on open, on reconnect and on such rare events, never per
  // frame; from the thread that opens the source or the one that reads it.
  std::function<void(const std::string& message)> notice;
};

// The backends. Each returns nullptr with `error` set for what the config got wrong (an unknown
// setting, a pixel format the camera cannot give, a size it refuses). A camera that is absent or
// does not answer is not a config error: the source is returned anyway, in the lost state (its
// first read() says kLost, and reopen() keeps trying), as long as its stream size is known from
// `options` (else: an error saying so).
std::unique_ptr<FrameSource> openAravisSource(const std::string& device,
                                              const LiveSourceOptions& options, std::string& error);
std::unique_ptr<FrameSource> openV4l2Source(const std::string& device,
                                            const LiveSourceOptions& options, std::string& error);

}  // namespace occmap
