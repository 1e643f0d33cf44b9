// map_frame: a map_frame_t as `occmap view` and every C++ subscriber read it (MapDecoder). Anyone
// on the network segment can publish on the map channel.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "fuzz/fuzz_target.h"
#include "transport/map_codec.h"

namespace occmap::fuzz {
namespace {

// The parts of a decoded map a subscriber uses (not the sizes on the wire, which another
// compression of the same cells changes).
bool sameMap(const DecodedMap& a, const DecodedMap& b) {
  auto sameCamera = [](const DecodedCamera& x, const DecodedCamera& y) {
    return x.name == y.name && x.state == y.state && x.used == y.used && x.sequence == y.sequence &&
           x.capture_utime == y.capture_utime;
  };
  return a.ok() == b.ok() && a.utime == b.utime && a.seq == b.seq && a.geometry == b.geometry &&
         a.encoding == b.encoding && a.cells == b.cells &&
         std::equal(a.cameras.begin(), a.cameras.end(), b.cameras.begin(), b.cameras.end(),
                    sameCamera);
}

// A small valid map, decoded before and after the input: what a hostile message leaves behind in
// the decoder (its buffers are reused from message to message) must not change the next map.
const std::vector<std::uint8_t>& referenceMessage() {
  static const std::vector<std::uint8_t> message = [] {
    const MapGeometry geometry{-1.0, -2.0, 0.5, 7, 5};
    MapEncoder encoder(geometry, {"c0", "c1"}, MapEncoding::kZstd);
    MapFrame frame(geometry, 2);
    frame.seq = 41;
    frame.utime = 1'700'000'000'000'000;
    for (std::size_t k = 0; k < frame.map.cells.size(); ++k) {
      frame.map.cells[k] = static_cast<CellState>(k % 3);
    }
    frame.cameras[0] = {CameraState::kStreaming, true, 7, frame.utime};
    frame.cameras[1] = {CameraState::kDown, false, -1, 0};
    const std::span<const std::uint8_t> bytes = encoder.encode(frame);
    return std::vector<std::uint8_t>(bytes.begin(), bytes.end());
  }();
  return message;
}

void checkAcceptedMap(const DecodedMap& map) {
  const MapGeometry& g = map.geometry;
  require(g.width >= 1 && g.width <= kMaxMapSide && g.height >= 1 && g.height <= kMaxMapSide,
          "an accepted map is 1..8192 cells a side");
  require(std::isfinite(g.cell_size_m) && g.cell_size_m > 0, "an accepted cell size is > 0");
  require(std::isfinite(g.origin_x_m) && std::isfinite(g.origin_y_m),
          "an accepted origin is finite");
  require(map.cells.size() == g.cellCount(), "an accepted map has width * height cells");
  require(std::all_of(map.cells.begin(), map.cells.end(), [](std::uint8_t v) { return v <= 2; }),
          "accepted cells are 0 free, 1 occupied or 2 unseen");
  for (const DecodedCamera& camera : map.cameras) {
    require(static_cast<int>(camera.state) <= 2, "an accepted camera state is 0, 1 or 2");
  }
  require(map.toOccupancyMap().cells.size() == map.cells.size(),
          "an accepted map becomes an OccupancyMap of its cells");
}

// Encoded again by occmapd's own encoder, an accepted map decodes to the same map: the decoder
// accepts nothing that the encoder could not have sent.
void checkRoundTrip(const DecodedMap& map) {
  std::vector<std::string> names;
  for (const DecodedCamera& camera : map.cameras) names.push_back(camera.name);
  MapFrame frame(map.geometry, map.cameras.size());
  frame.seq = map.seq;
  frame.utime = map.utime;
  std::transform(map.cells.begin(), map.cells.end(), frame.map.cells.begin(),
                 [](std::uint8_t v) { return static_cast<CellState>(v); });
  for (std::size_t k = 0; k < map.cameras.size(); ++k) {
    const DecodedCamera& camera = map.cameras[k];
    frame.cameras[k] = {camera.state, camera.used, camera.sequence, camera.capture_utime};
  }
  MapEncoder encoder(map.geometry, names, map.encoding);
  const std::span<const std::uint8_t> bytes = encoder.encode(frame);
  require(!bytes.empty(),
          std::string("an accepted map can be encoded again: ") + encoder.lastError());
  MapDecoder decoder;
  require(sameMap(decoder.decode(bytes.data(), bytes.size()), map),
          "an accepted map, encoded again, decodes to the same map");
}

}  // namespace

bool fuzzMapFrame(Input input) {
  const std::vector<std::uint8_t>& reference = referenceMessage();
  MapDecoder decoder;
  const DecodedMap before = decoder.decode(reference.data(), reference.size());
  require(before.ok(), "the reference map decodes: " + before.error);

  const DecodedMap map = decoder.decode(input.data(), input.size());
  if (map.ok()) {
    checkAcceptedMap(map);
    // Encoding allocates the largest message of the map's size: only small maps, so that a zstd
    // frame of 8192 x 8192 cells in a few kilobytes does not make every such input slow.
    if (map.cells.size() <= (1u << 20)) checkRoundTrip(map);
  } else {
    require(!map.error.empty() && map.cells.empty() && map.cameras.empty(),
            "a refused map says why and holds no cells or cameras");
  }

  require(sameMap(decoder.decode(reference.data(), reference.size()), before),
          "a message leaves the decoder as it found it: the next map decodes the same");
  return map.ok();
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzMapFrame)
