// occmap web: the live map, tracks, zones and every daemon's status in a browser (web/,
// docs/web.md).
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/config.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "tools/commands.h"
#include "tools/pictures.h"
#include "web/bus_feed.h"
#include "web/listen_address.h"
#include "web/live_state.h"
#include "web/web_server.h"

namespace occmap::tools {
namespace {

struct WebOptions {
  std::string lcm_url = TransportSettings{}.lcm_url;
  std::string listen = "127.0.0.1:8080";
  std::string map_channel = TransportSettings{}.map_channel;
  std::string status_channel = TransportSettings{}.status_channel;
  std::size_t max_clients = 64;
  std::vector<std::string> allowed_hosts;
};

// /map.png: the map as `occmap view --png` draws it, without the zones and tracks (those are in
// /api/zones and /api/tracks): +y up, a scale bar, about 600 pixels across with a whole number of
// pixels per cell (at least one).
std::vector<std::uint8_t> mapPicture(const web::HeldMap& held) {
  const MapGeometry& g = held.map.geometry;
  const int pixels_per_cell = std::max(1, 600 / std::max(g.width, g.height));
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", floorPlan(held.map, pixels_per_cell), png)) png.clear();
  return png;
}

// A camera's changed pixels and cells: RGBA as a PNG with its alpha.
std::vector<std::uint8_t> rgbaPicture(int width, int height, std::span<const std::uint8_t> rgba) {
  const cv::Mat pixels(height, width, CV_8UC4, const_cast<std::uint8_t*>(rgba.data()));
  cv::Mat bgra;
  cv::cvtColor(pixels, bgra, cv::COLOR_RGBA2BGRA);
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", bgra, png)) png.clear();
  return png;
}

// /coverage.png: the cameras' coverage as `occmap coverage` colours it, one pixel per cell, +y up.
std::vector<std::uint8_t> coveragePicture(int map_width, int map_height,
                                          std::span<const std::uint32_t> seen_by,
                                          std::size_t cameras) {
  MapGeometry geometry;
  geometry.width = map_width;
  geometry.height = map_height;
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", coverageCells(geometry, seen_by, cameras), png)) png.clear();
  return png;
}

int run(const WebOptions& o) {
  // SIGINT and SIGTERM are taken by sigwait() below: blocked first, before any thread starts (the
  // server's picture thread starts with it), so that every thread inherits the block. A thread
  // that had them unblocked would take a SIGTERM to its default action and kill the process
  // uncleanly: web_server_test saw exit by SIGTERM once in a clean run, the picture thread having
  // started before the block.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  std::string error;
  const std::optional<web::ListenAddress> listen = web::parseListenAddress(o.listen, error);
  if (!listen) throw InputError("", 0, "--listen " + o.listen, error);

  web::LiveState state;
  web::BusFeed feed({o.lcm_url, o.map_channel, o.status_channel}, state);
  if (const std::string problem = feed.open(); !problem.empty()) {
    std::fprintf(stderr, "occmap web: failed: %s\n", problem.c_str());
    return kExitFailure;
  }
  web::WebServerOptions server_options;
  server_options.listen = *listen;
  server_options.max_clients = o.max_clients;
  server_options.allowed_hosts = o.allowed_hosts;
  const nlohmann::ordered_json hello = {
      {"lcm_url", o.lcm_url}, {"map_channel", o.map_channel}, {"status_channel", o.status_channel}};
  const std::string members = hello.dump(-1, ' ', true);
  server_options.hello_members = members.substr(1, members.size() - 2);  // without the braces
  web::WebServer server(state, {mapPicture, rgbaPicture, coveragePicture}, server_options);
  try {
    server.listen();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "occmap web: failed: %s\n", e.what());
    return kExitFailure;
  }

  server.start();
  feed.start();
  const bool v6 = listen->host.find(':') != std::string::npos;
  const std::string address = v6 ? "[" + listen->host + "]" : listen->host;
  std::printf(
      "occmap web: serving http://%s:%u/ (maps on %s, statuses on %s at %s); Ctrl-C stops\n",
      address.c_str(), static_cast<unsigned>(server.port()), o.map_channel.c_str(),
      o.status_channel.c_str(), o.lcm_url.c_str());
  if (!web::isLoopbackAddress(listen->host)) {
    std::printf(
        "occmap web: listening beyond the loopback: whoever reaches this port sees the live map "
        "and every camera's state (read-only, no authentication): docs/web.md\n");
  }
  std::fflush(stdout);
  int signal_number = 0;
  sigwait(&stop_signals, &signal_number);
  // The feed first: it wakes the server, which must still be there.
  feed.stop();
  server.stop();
  std::printf("occmap web: stopped (%s)\n", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
  return kExitOk;
}

}  // namespace

Command addWebCommand(CLI::App& app) {
  auto options = std::make_shared<WebOptions>();
  CLI::App* command = app.add_subcommand(
      "web",
      "Serve a live view of the daemons on the LCM bus to web browsers (docs/web.md).\n"
      "Open the address it prints in a browser: the newest map as a floor plan (+y up, with a "
      "metre scale; white free, black occupied, blue-grey unseen), with the zones in their "
      "state's colour (green free, red occupied, amber unseen) and the people and objects "
      "followed (each track's id, its trail over the last seconds and an arrow of one second's "
      "motion); and every daemon heard on the bus, camera PCs and merge nodes, with each camera's "
      "state, frame rate, frames dropped, why it is down or degraded (lit or turned beyond its "
      "background, moved), and its last error. The page follows the maps at their rate, or as "
      "fast as the browser draws (always the newest), and reconnects by itself when this server "
      "or the daemon goes away and comes back. Each camera's picture (a preview the daemons "
      "send while a page is open) shows the pixels it finds changed in red; the pointer over it "
      "highlights the cells it decides on the map; a switch shows the coverage picture.\n"
      "For programs: GET /api/status (a JSON array, one object per daemon heard in the last 3 s, "
      "each as `occmap status --json` prints it), /api/tracks and /api/zones (the newest "
      "tracks_t and zones_t as JSON, or null), /map.png (the newest map as a floor plan; "
      "/map.png?seq=N a map of the last 30), /coverage.png, /camera/HOST/CAMERA.jpg, "
      "/camera/HOST/CAMERA/changed.png and /camera/HOST/CAMERA/cells.png, /api/web (this "
      "server's clients and counts).\n"
      "It is read-only: it answers GET and HEAD and changes nothing in any daemon. It listens on "
      "the loopback unless --listen says otherwise; beyond it, anyone who reaches the port sees "
      "the map and "
      "the cameras (no authentication): put it behind a reverse proxy with TLS and a login "
      "(docs/web.md). Maps go to browsers as binary frames of two bits a cell (a 512 x 512 "
      "map is 64 KiB: about 2 MB/s per browser at 30 maps/s); a browser that cannot keep up "
      "skips maps, and slows neither the daemon nor the other browsers.\n"
      "It runs until Ctrl-C or SIGTERM.\n\n"
      "Examples:\n"
      "  occmap web                                   # http://127.0.0.1:8080/\n"
      "  occmap web --listen 127.0.0.1:0              # any free port (it says which)\n"
      "  occmap web --lcm-url 'udpm://239.255.76.67:7667?ttl=1' --listen 0.0.0.0:8080\n"
      "  curl -s http://127.0.0.1:8080/api/status\n\n"
      "Exit codes: 0 stopped by a signal; 1 failed (LCM could not be opened, the address could "
      "not be listened on); 2 bad arguments.");
  command
      ->add_option("--lcm-url", options->lcm_url,
                   "LCM URL to listen on: the daemons' transport.lcm_url")
      ->capture_default_str();
  command
      ->add_option("--listen", options->listen,
                   "Address and port to serve on, HOST:PORT ([::1]:8080 for IPv6; port 0: any "
                   "free one). 0.0.0.0:8080 serves every interface: read docs/web.md first")
      ->capture_default_str();
  command
      ->add_option("--map-channel", options->map_channel,
                   "Map channel (transport.map_channel); tiled maps, zones and tracks are heard on "
                   "its name + _TILES, + _ZONES and + _TRACKS")
      ->capture_default_str();
  command
      ->add_option("--status-channel", options->status_channel,
                   "Status channel (transport.status_channel); requests go on its name + "
                   "_REQUEST, merge nodes answer on its name + _MERGE")
      ->capture_default_str();
  command
      ->add_option("--max-clients", options->max_clients,
                   "Browsers (WebSocket clients) served at once; more are refused until one "
                   "leaves")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  command->add_option("--allow-host", options->allowed_hosts,
                      "While listening on the loopback, requests are answered only when their "
                      "Host names the loopback (against DNS rebinding); also answer this name "
                      "(a reverse proxy's), repeatable");
  return [options] { return run(*options); };
}

}  // namespace occmap::tools
