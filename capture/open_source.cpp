#include "capture/open_source.h"

#include "capture/files_source.h"

namespace occmap {

std::unique_ptr<FrameSource> openSource(const SourceSpec& spec, const LiveSourceOptions& live,
                                        std::string& error) {
  switch (spec.kind) {
    case SourceSpec::Kind::kFiles:
      return FilesSource::open(spec.pattern, error);
    case SourceSpec::Kind::kAravis:
      return openAravisSource(spec.device, live, error);
    case SourceSpec::Kind::kV4l2:
      return openV4l2Source(spec.device, live, error);
    case SourceSpec::Kind::kSim:
      break;
  }
  error = "a sim:// source is a view of its scene: the rig opens it with the camera's geometry";
  return nullptr;
}

}  // namespace occmap
