#pragma once
// `occmap web`'s HTTP and WebSocket server (Boost.Beast; docs/web.md): the page, the API
// (GET /api/status, /api/tracks, /api/zones, /api/web, /map.png, /coverage.png, each camera's
// /camera/HOST/CAMERA.jpg, …/changed.png and …/cells.png) and the live feed of maps,
// statuses, tracks and zones to every browser over one WebSocket each. Read-only: it answers GET
// and HEAD, nothing else.
//
// Threads: one network thread runs every connection (an io_context); one picture thread draws the
// PNGs (/map.png, the cameras' overlays, /coverage.png), so that a request for one never holds up
// the other clients. Whatever thread puts into the LiveState only wakes the network thread (at most
// one wake-up waiting at a time). Each WebSocket client has one slot per kind of message: the
// newest map replaces a map not yet written to it (counted as skipped), so that a slow client holds
// at most the map being written and the next, both shared with every other client, and never slows
// the others.

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "web/listen_address.h"
#include "web/live_state.h"

namespace occmap::web {

struct WebServerOptions {
  ListenAddress listen{"127.0.0.1", 8080};
  // WebSocket clients at once; a browser more is refused (503) until one leaves.
  std::size_t max_clients = 64;
  // Connections at once, HTTP and WebSocket; more are closed as they come.
  std::size_t max_connections = 256;
  // While listening on a loopback address only requests whose Host header names the loopback
  // (localhost, 127.0.0.1, [::1]) are answered (a page elsewhere cannot reach this server by a DNS
  // name of its own: DNS rebinding); these names are answered too.
  std::vector<std::string> allowed_hosts;
  // What the page is told on connecting, as the members of a JSON object ("lcm_url":…, …).
  std::string hello_members;
};

// Draws a map as a PNG file's bytes (empty when it cannot). Runs on the picture thread.
using MapPicture = std::function<std::vector<std::uint8_t>(const HeldMap& map)>;
// Encodes `width` x `height` RGBA pixels (row-major from the top, 4 bytes each, alpha last) as a
// PNG file's bytes (empty when it cannot). Runs on the picture thread.
using RgbaPicture =
    std::function<std::vector<std::uint8_t>(int width, int height, std::span<const std::uint8_t>)>;
// Draws the coverage picture as `occmap coverage` colours it, one pixel per cell, +y up: for each
// cell (row-major from map row 0) the cameras that decide it, bit k for camera k of `cameras`
// (at most 32). Empty when it cannot. Runs on the picture thread.
using CoveragePicture = std::function<std::vector<std::uint8_t>(
    int map_width, int map_height, std::span<const std::uint32_t> seen_by, std::size_t cameras)>;

// What draws the server's pictures: handed in by whoever starts it, so that web/ needs no OpenCV.
struct PictureDrawers {
  MapPicture map;            // GET /map.png
  RgbaPicture rgba;          // GET /camera/HOST/CAMERA/changed.png and …/cells.png
  CoveragePicture coverage;  // GET /coverage.png
};

class WebServer {
 public:
  // `state` must outlive the server; whatever puts into it must stop before the server goes.
  WebServer(LiveState& state, PictureDrawers pictures, WebServerOptions options);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  // Binds and listens; std::runtime_error saying why not (the address in use, not this host's).
  void listen();
  // The port listened on (after listen(); the one taken for port 0).
  std::uint16_t port() const;
  // Starts the network and picture threads; stop() ends them (also done by the destructor).
  void start();
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace occmap::web
