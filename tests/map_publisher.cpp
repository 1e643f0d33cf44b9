// map_publisher: a stand-in for occmapd's LCM side in the transport tests. It publishes scene maps
// (tests/map_scenes.h), or random ones (tests/tiled_maps.h), through MapEncoder (or, with --tiles,
// MapTileEncoder: map_tile_t on the channel + _TILES) and LcmBus at a steady rate, with each map
// its zones and tracks if asked (tests/footprint_scenes.h), can leave sequence numbers or single
// tiles out and send undecodable messages first (to test what receivers count), and can answer
// status requests as the daemon would.
#include <chrono>
#include <cstdio>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <occmap/status_request_t.hpp>
#include <occmap/status_t.hpp>

#include "footprint_scenes.h"
#include "map_scenes.h"
#include "tiled_maps.h"
#include "transport/footprints_message.h"
#include "transport/lcm_bus.h"
#include "transport/map_codec.h"
#include "transport/map_tiles.h"

namespace {

using namespace occmap;

std::int64_t nowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct Options {
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";
  std::string channel = "OCCMAP_MAP";
  std::string status_channel = "OCCMAP_STATUS";
  int count = 60;
  double rate = 30;
  std::string encoding = "zstd";
  int width = 512;
  int height = 512;
  int cameras = 4;
  std::int64_t first_seq = 0;
  std::vector<std::int64_t> drop;
  int garbage = 0;
  double answer_status = 0;
  bool zones_and_tracks = false;
  bool tiles = false;
  std::string cells = "scene";
  std::vector<std::string> drop_tiles;  // "SEQ:INDEX"
};

// Answers status requests for `seconds` with a made-up daemon of two cameras.
int answerStatus(LcmBus& bus, const Options& o) {
  int answered = 0;
  std::vector<std::uint8_t> buffer;
  bus.subscribe(statusRequestChannel(o.status_channel),
                [&](const std::uint8_t* data, std::size_t size, std::int64_t) {
                  occmap::status_request_t request{};
                  if (request.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) {
                    return;
                  }
                  occmap::status_t status{};
                  status.utime = nowUtime();
                  status.request_id = request.request_id;
                  status.hostname = "test-host";
                  status.config_file = "/etc/occmap/test.yaml";
                  status.state = occmap::status_t::STATE_RUNNING;
                  status.uptime_s = 3723.5;
                  status.maps_published = 111683;
                  status.publish_errors = 2;
                  status.maps_per_s = 29.97;
                  status.fusion_p50_ms = 3.25;
                  status.fusion_p99_ms = 7.5;
                  const char* names[] = {"c0", "door-camera"};
                  for (int k = 0; k < 2; ++k) {
                    occmap::camera_status_t camera{};
                    camera.name = names[k];
                    camera.source = "sim://room/c" + std::to_string(k);
                    camera.state = static_cast<std::int8_t>(k == 0 ? 1 : 2);
                    camera.frames_in = 111700 - 5000 * k;
                    camera.frames_dropped = 3 * k;
                    camera.fps = k == 0 ? 30.0 : 0.0;
                    camera.last_capture_utime = status.utime - (k == 0 ? 12'000 : 4'200'000);
                    status.cameras.push_back(camera);
                  }
                  status.num_cameras = 2;
                  buffer.resize(static_cast<std::size_t>(status.getEncodedSize()));
                  status.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
                  if (bus.publish(o.status_channel, buffer)) ++answered;
                });
  std::printf("answering status requests on %s\n", statusRequestChannel(o.status_channel).c_str());
  std::fflush(stdout);
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                       std::chrono::duration<double>(o.answer_status));
  while (std::chrono::steady_clock::now() < end) bus.handleTimeout(50);
  std::printf("answered %d status requests\n", answered);
  return 0;
}

int publishMaps(LcmBus& bus, const Options& o) {
  const MapGeometry geometry{-0.5, -1.5, 0.02, o.width, o.height};
  const auto names = testing::sceneCameraNames(static_cast<std::size_t>(o.cameras));
  const MapEncoding encoding = parseMapEncoding(o.encoding).value();
  std::optional<MapEncoder> encoder;
  std::optional<MapTileEncoder> tile_encoder;
  if (o.tiles) {
    tile_encoder.emplace(geometry, names, encoding);
  } else {
    encoder.emplace(geometry, names, encoding);
  }
  const std::string map_channel = o.tiles ? tilesChannel(o.channel) : o.channel;
  MapFrame frame(geometry, names.size());
  for (int g = 0; g < o.garbage; ++g) {
    const std::vector<std::uint8_t> garbage(100, static_cast<std::uint8_t>(g + 1));
    bus.publish(map_channel, garbage);
  }
  const std::set<std::int64_t> drop(o.drop.begin(), o.drop.end());
  std::set<std::pair<std::int64_t, int>> drop_tiles;
  for (const std::string& item : o.drop_tiles) {
    const std::size_t colon = item.find(':');
    drop_tiles.insert({std::stoll(item.substr(0, colon)), std::stoi(item.substr(colon + 1))});
  }
  long long tiles_sent = 0;
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / o.rate));
  auto next = std::chrono::steady_clock::now();
  int published = 0, failed = 0;
  std::size_t largest = 0;
  std::vector<std::uint8_t> buffer;
  // As occmapd's: a map's zones right after it; here its tracks too (the detector keeping up).
  const auto publishBeside = [&](const std::string& channel, const auto& message) {
    buffer.resize(static_cast<std::size_t>(message.getEncodedSize()));
    message.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
    if (!bus.publish(channel, buffer)) ++failed;
  };
  for (int n = 0; n < o.count; ++n) {
    const std::int64_t seq = o.first_seq + n;
    std::this_thread::sleep_until(next);
    next += period;
    if (drop.count(seq) != 0) continue;
    if (o.cells == "random") {
      testing::fillRandom(frame, seq);
    } else {
      testing::fillScene(frame, seq);
    }
    // As the daemon's: the newest camera frame was captured just before the map was made.
    frame.utime = nowUtime();
    for (CameraContribution& camera : frame.cameras) {
      if (camera.used) camera.capture_time_us = frame.utime - 2000;
    }
    if (tile_encoder) {
      bool all = true;
      for (int index = 0; index < tile_encoder->tileCount(); ++index) {
        if (drop_tiles.count({seq, index}) != 0) continue;
        const auto message = tile_encoder->encode(frame, index);
        largest = std::max(largest, message.size());
        if (!message.empty() && bus.publish(map_channel, message)) {
          ++tiles_sent;
        } else {
          all = false;
        }
      }
      (all ? published : failed) += 1;
    } else {
      const auto message = encoder->encode(frame);
      largest = std::max(largest, message.size());
      if (!message.empty() && bus.publish(o.channel, message)) {
        ++published;
      } else {
        ++failed;
      }
    }
    if (o.zones_and_tracks) {
      publishBeside(zonesChannel(o.channel), testing::sceneZones(seq, frame.utime));
      publishBeside(tracksChannel(o.channel), testing::sceneTracks(seq, frame.utime));
    }
  }
  if (tile_encoder) {
    std::printf(
        "published %d maps in %lld tiles of side %d (%d a map; %s, %d x %d, largest "
        "message %zu bytes), %d failed\n",
        published, tiles_sent, tile_encoder->tileSide(), tile_encoder->tileCount(),
        o.encoding.c_str(), o.width, o.height, largest, failed);
  } else {
    std::printf("published %d maps (%s, %d x %d, largest message %zu bytes), %d failed\n",
                published, o.encoding.c_str(), o.width, o.height, largest, failed);
  }
  return failed == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app("Publishes test maps (and answers status requests) over LCM", "map_publisher");
  app.add_option("--lcm-url", o.lcm_url);
  app.add_option("--channel", o.channel);
  app.add_option("--status-channel", o.status_channel);
  app.add_option("--count", o.count);
  app.add_option("--rate", o.rate, "Maps per second")->check(CLI::PositiveNumber);
  app.add_option("--encoding", o.encoding)->check(CLI::IsMember({"raw", "zstd"}));
  app.add_option("--width", o.width);
  app.add_option("--height", o.height);
  app.add_option("--cameras", o.cameras);
  app.add_option("--first-seq", o.first_seq);
  app.add_option("--drop", o.drop, "Sequence numbers not to send");
  app.add_option("--garbage", o.garbage, "Undecodable messages to send before the maps");
  app.add_flag("--tiles", o.tiles, "Each map as map_tile_t tiles on the channel + _TILES");
  app.add_option("--cells", o.cells, "scene (tests/map_scenes.h) or random (tests/tiled_maps.h)")
      ->check(CLI::IsMember({"scene", "random"}));
  app.add_option("--drop-tile", o.drop_tiles, "SEQ:INDEX, a tile not to send (with --tiles)");
  app.add_flag("--zones-and-tracks", o.zones_and_tracks,
               "After each map, its zones_t and tracks_t (tests/footprint_scenes.h)");
  app.add_option("--answer-status", o.answer_status,
                 "Instead of maps, answer status requests for this many seconds");
  CLI11_PARSE(app, argc, argv);
  LcmBus bus(o.lcm_url);
  if (!bus.good()) {
    std::fprintf(stderr, "map_publisher: cannot open LCM at %s\n", o.lcm_url.c_str());
    return 1;
  }
  return o.answer_status > 0 ? answerStatus(bus, o) : publishMaps(bus, o);
}
