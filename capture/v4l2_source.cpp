// v4l2:// is not in this build yet (the backend is being written); until then a V4L2 camera in a
// config is an error that says so, as before live cameras existed.
#include "capture/live_source.h"

namespace occmap {

std::unique_ptr<FrameSource> openV4l2Source(const std::string&, const LiveSourceOptions&,
                                            std::string& error) {
  error = "v4l2:// cameras are not in this build yet; use aravis://, files:// or sim://";
  return nullptr;
}

}  // namespace occmap
