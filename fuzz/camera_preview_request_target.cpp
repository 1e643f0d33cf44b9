// camera_preview_request: a camera_preview_request_t as occmapd's publisher thread reads it from
// the preview request channel (transport/camera_preview_message.h, decodeCameraPreviewRequest; the
// daemon then publishes previews of the camera named, or of all, for 10 s). Anyone on the network
// segment can publish there.
#include <algorithm>
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include <occmap/camera_preview_request_t.hpp>

#include "fuzz/fuzz_target.h"
#include "fuzz/heap_use.h"
#include "transport/camera_preview_message.h"

namespace occmap::fuzz {

bool fuzzCameraPreviewRequest(Input input) {
  std::optional<std::string_view> camera;
  {
    const HeapUse heap;
    camera = decodeCameraPreviewRequest(input.data(), input.size());
    // It runs for every message on the channel, in the thread that publishes the maps.
    require(!heap.counted() || heap.allocations() == 0,
            "decodeCameraPreviewRequest allocates nothing");
  }
  if (!camera) return false;  // ignored by the daemon
  // The name points into the message, at its string's bytes.
  const auto* first = reinterpret_cast<const std::uint8_t*>(camera->data());
  require(first >= input.data() && first + camera->size() < input.data() + input.size() &&
              first[camera->size()] == 0,
          "the camera named points into the message, before the string's NUL");
  require(camera->find('\0') == std::string_view::npos, "the camera named holds no NUL");
  // Accepted means exactly one camera_preview_request_t: LCM's decoder takes all of it and reads
  // the same name, and encoded again, by occmap's own encoder too, it is the same bytes.
  occmap::camera_preview_request_t request{};
  require(request.decode(input.data(), 0, static_cast<int>(input.size())) ==
              static_cast<int>(input.size()),
          "an accepted request is one whole camera_preview_request_t");
  require(request.camera == *camera, "the camera named is the request's");
  std::vector<std::uint8_t> again(static_cast<std::size_t>(request.getEncodedSize()));
  request.encode(again.data(), 0, static_cast<int>(again.size()));
  require(std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted request encodes back to the bytes received");
  const std::vector<std::uint8_t> made = encodeCameraPreviewRequest(request.utime, request.camera);
  require(std::equal(made.begin(), made.end(), input.begin(), input.end()),
          "encodeCameraPreviewRequest makes the same bytes of the same request");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzCameraPreviewRequest)
