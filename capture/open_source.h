#pragma once
// Source URL -> FrameSource: the one place that knows which backend serves which kind of source
// (source_spec.h parses the URL). The simulator is the exception: a sim:// camera is a view of a
// scene that the rig makes with the camera's geometry (sim_source.h), so it is opened there.

#include <memory>
#include <string>

#include "capture/frame_source.h"
#include "capture/live_source.h"
#include "capture/source_spec.h"

namespace occmap {

// A files://, aravis:// or v4l2:// source; nullptr with `error` set (what is wrong, what to do)
// when it cannot be opened as the config asks. `live` is used by cameras only. A camera that is
// absent is not an error (live_source.h): it comes back in the lost state, and reopen() tries.
std::unique_ptr<FrameSource> openSource(const SourceSpec& spec, const LiveSourceOptions& live,
                                        std::string& error);

}  // namespace occmap
