// Writes the seed corpora of the LCM message targets from occmap's own encoders, so that the seeds
// are exactly what occmapd and `occmap status` send. Run after a message type changes (a new type,
// since types are never changed in place) and commit the files:
//   build-fuzz/fuzz/fuzz_make_seeds fuzz/corpus
// The config and calibration seeds are text files written by hand (docs/fuzzing.md, "Seeds").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <occmap/camera_frame_t.hpp>
#include <occmap/camera_preview_t.hpp>
#include <occmap/control_reply_t.hpp>
#include <occmap/control_request_t.hpp>
#include <occmap/control_status_t.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/map_tile_t.hpp>
#include <occmap/merge_status_t.hpp>
#include <occmap/status_request_t.hpp>
#include <occmap/status_t.hpp>
#include <occmap/tracks_t.hpp>
#include <occmap/view_status_t.hpp>
#include <occmap/zones_t.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fuzz/fuzz_target.h"
#include "fuzz/map_tile_input.h"
#include "transport/camera_preview_message.h"
#include "transport/control_message.h"
#include "transport/map_codec.h"
#include "transport/map_tiles.h"

namespace {

namespace fs = std::filesystem;

void write(const fs::path& file, std::span<const std::uint8_t> bytes) {
  fs::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + file.string());
  std::printf("%s (%zu bytes)\n", file.c_str(), bytes.size());
}

template <typename Message>
void writeMessage(const fs::path& file, const Message& message) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  write(file, bytes);
}

// A room-like map: unseen border, free floor, a few occupied blobs (moved by `shift` cells), the
// second camera down, the others streaming.
occmap::MapFrame roomFrame(const occmap::MapGeometry& geometry, std::size_t camera_count,
                           std::int64_t seq, std::int64_t utime, int shift = 0) {
  using occmap::CameraState;
  using occmap::CellState;
  occmap::MapFrame frame(geometry, camera_count);
  frame.seq = seq;
  frame.utime = utime;
  for (int row = 0; row < geometry.height; ++row) {
    for (int column = 0; column < geometry.width; ++column) {
      const bool border =
          row == 0 || column == 0 || row == geometry.height - 1 || column == geometry.width - 1;
      const bool blob = (row / 3 + (column + shift) / 3) % 4 == 1;
      frame.map.cells[static_cast<std::size_t>(geometry.index(row, column))] =
          border ? CellState::kUnseen
          : blob ? CellState::kOccupied
                 : CellState::kFree;
    }
  }
  for (std::size_t k = 0; k < camera_count; ++k) {
    const bool down = k == 1;
    frame.cameras[k] = {down ? CameraState::kDown : CameraState::kStreaming, !down,
                        down ? -1 : static_cast<std::int64_t>(100 + k),
                        down ? 0 : frame.utime - static_cast<std::int64_t>(k) * 1000};
  }
  return frame;
}

std::vector<std::uint8_t> encodeMap(const occmap::MapGeometry& geometry,
                                    const std::vector<std::string>& names,
                                    occmap::MapEncoding encoding, const occmap::MapFrame& frame) {
  occmap::MapEncoder encoder(geometry, names, encoding);
  const std::span<const std::uint8_t> bytes = encoder.encode(frame);
  if (bytes.empty()) throw std::runtime_error(encoder.lastError());
  return {bytes.begin(), bytes.end()};
}

void writeMap(const fs::path& file, const occmap::MapGeometry& geometry,
              const std::vector<std::string>& names, occmap::MapEncoding encoding) {
  write(file, encodeMap(geometry, names, encoding,
                        roomFrame(geometry, names.size(), 1234, 1'700'000'000'123'456)));
}

// Tile `index` of `frame`, as MapTileEncoder makes it.
std::span<const std::uint8_t> encodeTile(occmap::MapTileEncoder& encoder,
                                         const occmap::MapFrame& frame, int index) {
  const std::span<const std::uint8_t> bytes = encoder.encode(frame, index);
  if (bytes.empty()) throw std::runtime_error(encoder.lastError());
  return bytes;
}

// Tile `index` of `frame` in a grid of `side` cells, raw, built field by field with LCM's encoder:
// MapTileEncoder sizes its tiles to a datagram (240 cells a side unless the camera list is long),
// but the assembler takes any side of kMinTileSide..kMaxTileSide, and small tiles make small
// inputs that many tiles of one map fit.
std::vector<std::uint8_t> handMadeTile(const occmap::MapFrame& frame,
                                       const std::vector<std::string>& names, int side, int index) {
  const occmap::MapGeometry& g = frame.map.geometry;
  const int columns = (g.width + side - 1) / side, rows = (g.height + side - 1) / side;
  occmap::map_tile_t tile{};
  tile.utime = frame.utime;
  tile.seq = frame.seq;
  tile.width = g.width;
  tile.height = g.height;
  tile.cell_size_m = g.cell_size_m;
  tile.origin_x_m = g.origin_x_m;
  tile.origin_y_m = g.origin_y_m;
  tile.tile_side = side;
  tile.first_column = index % columns * side;
  tile.first_row = index / columns * side;
  tile.tile_width = std::min(side, g.width - tile.first_column);
  tile.tile_height = std::min(side, g.height - tile.first_row);
  tile.tile_index = index;
  tile.tile_count = columns * rows;
  tile.encoding = occmap::map_tile_t::ENCODING_RAW;
  for (int row = tile.first_row; row < tile.first_row + tile.tile_height; ++row) {
    for (int column = tile.first_column; column < tile.first_column + tile.tile_width; ++column) {
      tile.data.push_back(static_cast<std::uint8_t>(
          frame.map.cells[static_cast<std::size_t>(g.index(row, column))]));
    }
  }
  tile.data_size = static_cast<std::int32_t>(tile.data.size());
  for (std::size_t k = 0; k < names.size(); ++k) {
    const occmap::CameraContribution& c = frame.cameras[k];
    occmap::camera_frame_t camera{};
    camera.name = names[k];
    camera.state = static_cast<std::int8_t>(c.state);
    camera.used = c.used;
    camera.sequence = c.sequence;
    camera.capture_utime = c.capture_time_us;
    tile.cameras.push_back(camera);
  }
  tile.num_cameras = static_cast<std::int16_t>(tile.cameras.size());
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(tile.getEncodedSize()));
  tile.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

void writeMapTileSeeds(const fs::path& folder) {
  using occmap::fuzz::appendTileInput;
  using occmap::fuzz::kFlushAfter;
  using occmap::fuzz::kOnMapChannel;
  const std::int64_t utime = 1'700'000'000'123'456;

  // occmapd's own tiles (zstd): a 250 x 250 map is 2 x 2 tiles of 240. A map's tiles in order; the
  // next map's out of order with a copy; then a late tile of the first, and a copy of one of the
  // second after it was given out.
  {
    const occmap::MapGeometry geometry{-0.5, -1.5, 0.02, 250, 250};
    const std::vector<std::string> names{"c0", "c1", "c2"};
    occmap::MapTileEncoder encoder(geometry, names, occmap::MapEncoding::kZstd);
    const occmap::MapFrame first = roomFrame(geometry, names.size(), 1234, utime);
    const occmap::MapFrame second = roomFrame(geometry, names.size(), 1235, utime + 33'333, 1);
    std::vector<std::uint8_t> input;
    for (const int index : {0, 1, 2, 3}) appendTileInput(input, encodeTile(encoder, first, index));
    for (const int index : {2, 0, 0, 3, 1})
      appendTileInput(input, encodeTile(encoder, second, index));
    appendTileInput(input, encodeTile(encoder, first, 1));
    appendTileInput(input, encodeTile(encoder, second, 2));
    write(folder / "zstd-250x250-shuffled-copied-late.bin", input);
  }
  // occmapd's own tiles (raw): a 241 x 5 map is a tile of 240 x 5 and one of 1 x 5. A map whose
  // second tile is lost (given out when the next map's first tile comes); a whole map_frame_t on
  // the map channel; the next map's tiles backwards; a map cut short by the stream stopping.
  {
    const occmap::MapGeometry geometry{0.0, 0.0, 0.1, 241, 5};
    const std::vector<std::string> names{"c0", "c1"};
    occmap::MapTileEncoder encoder(geometry, names, occmap::MapEncoding::kRaw);
    std::vector<std::uint8_t> input;
    appendTileInput(input, encodeTile(encoder, roomFrame(geometry, 2, 10, utime), 0));
    const occmap::MapGeometry whole{-1.0, -1.5, 0.25, 8, 6};
    appendTileInput(input,
                    encodeMap(whole, names, occmap::MapEncoding::kRaw,
                              roomFrame(whole, 2, 4321, utime + 10'000)),
                    kOnMapChannel);
    const occmap::MapFrame next = roomFrame(geometry, 2, 11, utime + 33'333, 2);
    appendTileInput(input, encodeTile(encoder, next, 1));
    appendTileInput(input, encodeTile(encoder, next, 0));
    appendTileInput(input, encodeTile(encoder, roomFrame(geometry, 2, 12, utime + 66'666), 0),
                    kFlushAfter);
    write(folder / "raw-241x5-lost-tile-whole-map-flush.bin", input);
  }
  // Tiles of 16 cells: a 40 x 30 map is 3 x 2 tiles, the last column 8 wide and the last row 14
  // high, sent backwards; then a restarted publisher (seq from 0 again, a newer capture) with a
  // 20 x 20 map of 2 x 2 tiles and no cameras.
  {
    const occmap::MapGeometry geometry{-0.4, -0.3, 0.05, 40, 30};
    const std::vector<std::string> names{"door-camera"};
    const occmap::MapFrame frame = roomFrame(geometry, names.size(), 500, utime);
    std::vector<std::uint8_t> input;
    for (int index = 5; index >= 0; --index) {
      appendTileInput(input, handMadeTile(frame, names, 16, index));
    }
    const occmap::MapGeometry restarted{0.0, 0.0, 0.05, 20, 20};
    const occmap::MapFrame again = roomFrame(restarted, 0, 0, utime + 1'000'000);
    for (const int index : {0, 1, 2, 3}) appendTileInput(input, handMadeTile(again, {}, 16, index));
    write(folder / "side-16-40x30-then-restarted-publisher.bin", input);
  }
}

// A camera preview as occmapd's previewer (daemon/previewer.cpp) makes it: the stream at its
// scale as a grey JPEG of quality 80 (OpenCV), a person-sized block of changed pixels in it, and a
// wedge of the map in front of the camera as its coverage, packed and compressed by transport's
// own functions (packBits, compressCoverage, encodeCameraPreview).
void writeCameraPreview(const fs::path& file, const std::string& camera, std::int8_t state,
                        int stream_width, int stream_height, int map_width, int map_height) {
  occmap::camera_preview_t preview{};
  preview.utime = 1'700'000'000'123'456;
  preview.sequence = 4321;
  preview.hostname = "camera-pc";
  preview.camera = camera;
  preview.state = state;
  preview.stream_width = stream_width;
  preview.stream_height = stream_height;
  preview.scale = occmap::previewScale(stream_width);
  preview.width = occmap::previewSide(stream_width, preview.scale);
  preview.height = occmap::previewSide(stream_height, preview.scale);
  const int width = preview.width, height = preview.height;
  const bool streaming = state == occmap::camera_frame_t::STATE_STREAMING;
  cv::Mat grey(height, width, CV_8UC1);
  std::vector<std::uint8_t> changed(static_cast<std::size_t>(width) *
                                    static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      // A lit floor below a darker wall; a person in the middle when the camera streams.
      const bool person = streaming && x >= width * 2 / 5 && x < width * 3 / 5 && y >= height / 4 &&
                          y < height * 9 / 10;
      const int floor = y > height / 3 ? 150 + (x + y) % 40 : 70 + x % 16;
      grey.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(person ? 35 : floor);
      changed[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
              static_cast<std::size_t>(x)] = person ? 1 : 0;
    }
  }
  if (!cv::imencode(".jpg", grey, preview.jpeg, {cv::IMWRITE_JPEG_QUALITY, 80})) {
    throw std::runtime_error("OpenCV could not encode the JPEG");
  }
  preview.jpeg_size = static_cast<std::int32_t>(preview.jpeg.size());
  preview.changed.resize(occmap::packedBytes(changed.size()));
  occmap::packBits(changed, preview.changed);
  preview.changed_size = static_cast<std::int32_t>(preview.changed.size());
  preview.map_width = map_width;
  preview.map_height = map_height;
  // The camera at the middle of row 0, looking along the rows: the cells within 30 degrees of its
  // axis and nearer than three quarters of the map.
  std::vector<std::uint8_t> coverage(static_cast<std::size_t>(map_width) *
                                     static_cast<std::size_t>(map_height));
  for (int row = 0; row < map_height; ++row) {
    for (int column = 0; column < map_width; ++column) {
      const double dx = column - map_width / 2.0, dy = row + 0.5;
      const bool seen = std::abs(dx) <= dy * 0.58 && dy <= map_height * 0.75;
      coverage[static_cast<std::size_t>(row) * static_cast<std::size_t>(map_width) +
               static_cast<std::size_t>(column)] = seen ? 1 : 0;
    }
  }
  std::vector<std::uint8_t> packed(occmap::packedBytes(coverage.size()));
  occmap::packBits(coverage, packed);
  preview.coverage = occmap::compressCoverage(packed);
  preview.coverage_size = static_cast<std::int32_t>(preview.coverage.size());
  std::vector<std::uint8_t> bytes;
  occmap::encodeCameraPreview(preview, bytes);
  write(file, bytes);
}

occmap::camera_status_t camera(const std::string& name, const std::string& source, int state) {
  occmap::camera_status_t c{};
  c.name = name;
  c.source = source;
  c.state = static_cast<std::int8_t>(state);
  c.frames_in = 36000;
  c.frames_dropped = 2;
  c.fps = 30.0;
  c.last_capture_utime = 1'700'000'000'000'000 - 9000;
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds CORPUS_FOLDER (fuzz/corpus)\n");
    return 2;
  }
  const fs::path corpus = argv[1];

  occmap::status_request_t request{};
  request.utime = 1'700'000'000'000'000;
  request.request_id = 0x1234'5678'9abc'def0;
  writeMessage(corpus / "status_request" / "request.bin", request);

  occmap::status_t status{};
  status.utime = 1'700'000'000'000'000;
  status.request_id = -1;
  status.hostname = "camera-pc";
  status.config_file = "/etc/occmap/occmapd.yaml";
  status.state = occmap::status_t::STATE_RUNNING;
  status.uptime_s = 93784.5;
  status.maps_published = 2'800'000;
  status.publish_errors = 3;
  status.maps_per_s = 29.9;
  status.fusion_p50_ms = 6.5;
  status.fusion_p99_ms = 9.6;
  status.cameras = {camera("c0", "sim://room/c0", 1), camera("c1", "aravis://GV02", 2),
                    camera("c2", "v4l2:///dev/video0", 0)};
  status.cameras[1].frames_incomplete = 4;
  status.cameras[1].missing_packets = 120;
  status.cameras[1].resent_packets = 80;
  status.cameras[1].underruns = 1;
  status.cameras[1].reconnects = 2;
  status.cameras[1].last_error = "no frame for 1 s";
  status.num_cameras = static_cast<std::int16_t>(status.cameras.size());
  writeMessage(corpus / "status" / "periodic-3-cameras.bin", status);

  // The control status published with that status (the same utime, request_id and hostname).
  occmap::control_status_t control_status{};
  control_status.utime = status.utime;
  control_status.request_id = status.request_id;
  control_status.hostname = status.hostname;
  control_status.control_enabled = true;
  control_status.disabled = 0;
  control_status.malformed = 5;
  control_status.bad_mac = 2;
  control_status.stale = 1;
  control_status.refused = 1;
  control_status.accepted = 3;
  control_status.camera_name = {"c0", "c1", "c2"};
  control_status.camera_threshold = {20, 35, 128};
  control_status.camera_background_utime = {0, 1'699'999'000'000'000, 0};
  control_status.num_cameras = static_cast<std::int16_t>(control_status.camera_name.size());
  writeMessage(corpus / "control_status" / "periodic-3-cameras.bin", control_status);

  status.request_id = 77;
  status.state = occmap::status_t::STATE_STARTING;
  status.cameras.clear();
  status.num_cameras = 0;
  writeMessage(corpus / "status" / "answer-no-cameras.bin", status);
  control_status.request_id = 77;
  control_status.control_enabled = false;
  control_status.camera_name.clear();
  control_status.camera_threshold.clear();
  control_status.camera_background_utime.clear();
  control_status.num_cameras = 0;
  writeMessage(corpus / "control_status" / "answer-control-off-no-cameras.bin", control_status);

  // The lighting status published with the periodic status: one camera in a dimmer light, one
  // degraded, one with the model off.
  occmap::lighting_status_t lighting{};
  lighting.utime = status.utime;
  lighting.request_id = -1;
  lighting.hostname = status.hostname;
  lighting.camera_name = {"c0", "c1", "c2"};
  lighting.adapt = {1, 1, 0};
  lighting.gain = {0.62, 1.0, 1.0};
  lighting.agreement = {0.93, 0.12, 1.0};
  lighting.explained = {1, 0, 1};
  lighting.unexplained_frames = {0, 450, 0};
  lighting.num_cameras = static_cast<std::int16_t>(lighting.camera_name.size());
  writeMessage(corpus / "lighting_status" / "periodic-3-cameras.bin", lighting);
  lighting.request_id = 77;
  lighting.camera_name.clear();
  lighting.adapt.clear();
  lighting.gain.clear();
  lighting.agreement.clear();
  lighting.explained.clear();
  lighting.unexplained_frames.clear();
  lighting.num_cameras = 0;
  writeMessage(corpus / "lighting_status" / "answer-no-cameras.bin", lighting);

  // The view status published with it: one camera as calibrated, one moved, one whose view nothing
  // explains, one re-posed twice; then an answer without cameras.
  occmap::view_status_t view{};
  view.utime = status.utime;
  view.request_id = -1;
  view.hostname = status.hostname;
  view.camera_name = {"c0", "c1", "c2", "c3"};
  view.view = {occmap::view_status_t::AS_CALIBRATED, occmap::view_status_t::MOVED,
               occmap::view_status_t::UNEXPLAINED, occmap::view_status_t::AS_CALIBRATED};
  view.shift_x_px = {0, 10.1, 0, 0};
  view.shift_y_px = {0, -3.3, 0, 0};
  view.turn_deg = {0, 1.01, 0, 0};
  view.residual_px = {0, 0.29, 0, 0};
  view.checked_utime = {0, status.utime - 400'000, status.utime - 700'000, 0};
  view.reposes = {0, 0, 0, 2};
  view.reposed_turn_deg = {0, 0, 0, 0.8};
  view.reposed_utime = {0, 0, 0, status.utime - 60'000'000};
  view.num_cameras = static_cast<std::int16_t>(view.camera_name.size());
  writeMessage(corpus / "view_status" / "periodic-4-cameras.bin", view);
  view = occmap::view_status_t{};
  view.utime = status.utime;
  view.request_id = 77;
  view.hostname = status.hostname;
  writeMessage(corpus / "view_status" / "answer-no-cameras.bin", view);

  // The tracks occmapd publishes beside its maps: two people on a map, one of them found again
  // on it, among three footprints; then a map where nobody is, found after a newer map was sent.
  occmap::tracks_t tracks{};
  tracks.utime = status.utime - 40'000;
  tracks.seq = 2'799'998;
  tracks.hostname = status.hostname;
  tracks.footprints = {
      {1.21, 0.34, 0.21, 0.62, 1.75}, {-0.42, 2.08, 0.17, 0.35, 1.75}, {2.9, 3.1, 0.04, 0.61, 0.5}};
  tracks.num_footprints = static_cast<std::int16_t>(tracks.footprints.size());
  occmap::track_t person{};
  person.id = 4;
  person.x_m = 1.2;
  person.y_m = 0.35;
  person.vx_m_s = 0.79;
  person.vy_m_s = -0.12;
  person.area_m2 = 0.21;
  person.age_s = 12.4;
  person.unseen_s = 0;
  tracks.tracks = {person, person};
  tracks.tracks[1].id = 7;
  tracks.tracks[1].x_m = -0.4;
  tracks.tracks[1].y_m = 2.1;
  tracks.tracks[1].vx_m_s = 0;
  tracks.tracks[1].vy_m_s = 0.01;
  tracks.tracks[1].age_s = 3.1;
  tracks.tracks[1].unseen_s = 0.1;
  tracks.num_tracks = static_cast<std::int16_t>(tracks.tracks.size());
  writeMessage(corpus / "tracks" / "two-people-3-footprints.bin", tracks);
  tracks.seq = -1;
  tracks.footprints.clear();
  tracks.num_footprints = 0;
  tracks.tracks.clear();
  tracks.num_tracks = 0;
  writeMessage(corpus / "tracks" / "nobody-map-never-sent.bin", tracks);

  // The zones published right after a map: one of each state, with 4, 3 and 5 corners; then a
  // zones_t without zones (occmapd sends none then, but anyone may).
  occmap::zones_t zones{};
  zones.utime = status.utime - 33'000;
  zones.seq = 2'799'999;
  zones.hostname = status.hostname;
  const auto zone = [](const char* name, std::int8_t state, double state_s, std::vector<double> x_m,
                       std::vector<double> y_m) {
    occmap::zone_t z{};
    z.name = name;
    z.state = state;
    z.state_s = state_s;
    z.cells = 2500;
    z.occupied_cells = state == occmap::zone_t::OCCUPIED ? 41 : 0;
    z.unseen_cells = state == occmap::zone_t::UNSEEN ? 120 : 0;
    z.num_corners = static_cast<std::int16_t>(x_m.size());
    z.corner_x_m = std::move(x_m);
    z.corner_y_m = std::move(y_m);
    return z;
  };
  zones.zones = {zone("robot-cell", occmap::zone_t::OCCUPIED, 3.2, {0, 1, 1, 0}, {0, 0, 1, 1}),
                 zone("door", occmap::zone_t::FREE, 754.0, {2, 3, 2.5}, {0, 0, 1}),
                 zone("desk", occmap::zone_t::UNSEEN, 0, {-1, 0, 0, -0.5, -1}, {2, 2, 3, 3.5, 3})};
  zones.num_zones = static_cast<std::int16_t>(zones.zones.size());
  writeMessage(corpus / "zones" / "three-zones.bin", zones);
  zones.zones.clear();
  zones.num_zones = 0;
  writeMessage(corpus / "zones" / "no-zones.bin", zones);

  // Signed with the control target's key (fuzz/fuzz_target.h), so that a seed goes all the way.
  occmap::control_request_t control{};
  control.request_id = 0x0123'4567'89ab'cdef;
  control.utime = 1'700'000'000'000'000;
  control.nonce = 0x5eed'5eed'5eed'5eed;
  control.command = std::string(occmap::kSetThreshold);
  control.camera = "c0";
  control.value = 35;
  write(corpus / "control_request" / "set-threshold.bin",
        occmap::encodeControlRequest(occmap::fuzz::controlFuzzKey(), control));
  control.command = std::string(occmap::kRecaptureBackground);
  control.camera = "door-camera";
  control.value = 50;
  write(corpus / "control_request" / "recapture-background.bin",
        occmap::encodeControlRequest(occmap::fuzz::controlFuzzKey(), control));

  // Replies as occmapd signs them, under the same key.
  occmap::control_reply_t reply{};
  reply.utime = 1'700'000'000'000'123;
  reply.request_id = 0x0123'4567'89ab'cdef;
  reply.outcome = occmap::control_reply_t::OUTCOME_DONE;
  reply.message = "c0: threshold 20 -> 35";
  std::vector<std::uint8_t> reply_bytes;
  occmap::encodeControlReply(occmap::fuzz::controlFuzzKey(), reply, reply_bytes);
  write(corpus / "control_reply" / "done-threshold.bin", reply_bytes);
  reply.outcome = occmap::control_reply_t::OUTCOME_STARTED;
  reply.message = "door-camera: the median of the next 50 frames";
  occmap::encodeControlReply(occmap::fuzz::controlFuzzKey(), reply, reply_bytes);
  write(corpus / "control_reply" / "started-recapture.bin", reply_bytes);

  writeMap(corpus / "map_frame" / "raw-8x6-2-cameras.bin", {-1.0, -1.5, 0.25, 8, 6}, {"c0", "c1"},
           occmap::MapEncoding::kRaw);
  writeMap(corpus / "map_frame" / "zstd-24x16-3-cameras.bin", {-0.62, -1.87, 0.02, 24, 16},
           {"c0", "c1", "c2"}, occmap::MapEncoding::kZstd);
  writeMap(corpus / "map_frame" / "zstd-5x5-no-cameras.bin", {0.0, 0.0, 1.0, 5, 5}, {},
           occmap::MapEncoding::kZstd);

  writeMapTileSeeds(corpus / "map_tile");

  // A merge node's status (lcmtypes/merge_status_t.lcm): one input fresh, one down that lost
  // tiles, refused messages and whose clock is off, one never heard (its age and clock offset NaN,
  // not yet known); then an answer of a node just started, without inputs.
  occmap::merge_status_t merge{};
  merge.utime = status.utime;
  merge.request_id = -1;
  merge.hostname = "merge-pc";
  merge.config_file = "/etc/occmap/merge.yaml";
  merge.map_channel = "OCCMAP_MAP";
  merge.state = occmap::status_t::STATE_RUNNING;
  merge.uptime_s = 3725.25;
  merge.maps_published = 111'000;
  merge.publish_errors = 1;
  merge.maps_per_s = 29.8;
  merge.max_age_ms = 200;
  merge.latency_p50_ms = 0.9;
  merge.latency_p99_ms = 2.6;
  merge.latency_last_ms = 1.1;
  merge.merge_p50_ms = 0.4;
  merge.merge_p99_ms = 1.7;
  merge.clock_warning_ms = 10;
  const auto mergeInput = [](const char* name, const char* channel, std::int8_t state) {
    occmap::merge_input_status_t in{};
    in.name = name;
    in.channel = channel;
    in.state = state;
    in.age_ms = std::numeric_limits<double>::quiet_NaN();
    in.clock_offset_ms = std::numeric_limits<double>::quiet_NaN();
    return in;
  };
  merge.inputs = {
      mergeInput("pc-north", "OCCMAP_MAP_NORTH", occmap::merge_input_status_t::STATE_FRESH),
      mergeInput("pc-south", "OCCMAP_MAP_SOUTH", occmap::merge_input_status_t::STATE_DOWN),
      mergeInput("pc-east", "OCCMAP_MAP_EAST", occmap::merge_input_status_t::STATE_NEVER_HEARD)};
  merge.inputs[0].maps = 111'200;
  merge.inputs[0].maps_per_s = 29.9;
  merge.inputs[0].age_ms = 0;
  merge.inputs[0].lost_maps = 3;
  merge.inputs[0].clock_offset_ms = 0.4;
  merge.inputs[1].maps = 90'000;
  merge.inputs[1].maps_per_s = 0;
  merge.inputs[1].age_ms = 2400;
  merge.inputs[1].lost_maps = 17;
  merge.inputs[1].tiles_lost = 12;
  merge.inputs[1].refused = 2;
  merge.inputs[1].clock_offset_ms = -14.2;
  merge.inputs[1].last_error = "OCCMAP_MAP_SOUTH_TILES: tile_index 9 is outside 0..8";
  merge.num_inputs = static_cast<std::int16_t>(merge.inputs.size());
  writeMessage(corpus / "merge_status" / "periodic-3-inputs.bin", merge);
  merge.request_id = 77;
  merge.state = occmap::status_t::STATE_STARTING;
  merge.uptime_s = 0.2;
  merge.maps_published = 0;
  merge.publish_errors = 0;
  merge.maps_per_s = 0;
  merge.latency_p50_ms = merge.latency_p99_ms = merge.latency_last_ms = 0;
  merge.merge_p50_ms = merge.merge_p99_ms = 0;
  merge.inputs.clear();
  merge.num_inputs = 0;
  writeMessage(corpus / "merge_status" / "answer-no-inputs.bin", merge);

  // Camera previews (lcmtypes/camera_preview_t.lcm): a streaming camera at scale 1 whose coverage
  // bits end in padding; a wide stream at scale 3 (a ragged last column), the camera down, on a
  // 250 x 200 map; the smallest there is, one pixel and one cell, while the camera starts.
  writeCameraPreview(corpus / "camera_preview" / "streaming-160x120-map-41x29.bin", "door-camera",
                     occmap::camera_frame_t::STATE_STREAMING, 160, 120, 41, 29);
  writeCameraPreview(corpus / "camera_preview" / "down-700x90-scale-3-map-250x200.bin", "c1",
                     occmap::camera_frame_t::STATE_DOWN, 700, 90, 250, 200);
  writeCameraPreview(corpus / "camera_preview" / "starting-1x1-map-1x1.bin", "c0",
                     occmap::camera_frame_t::STATE_STARTING, 1, 1, 1, 1);
  // Requests for previews, as `occmap web` sends them (every camera) and for one camera.
  write(corpus / "camera_preview_request" / "every-camera.bin",
        occmap::encodeCameraPreviewRequest(1'700'000'000'000'000, ""));
  write(corpus / "camera_preview_request" / "door-camera.bin",
        occmap::encodeCameraPreviewRequest(1'700'000'000'500'000, "door-camera"));
  return 0;
}
