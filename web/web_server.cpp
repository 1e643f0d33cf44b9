#include "web/web_server.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include <boost/asio/post.hpp>
#include <nlohmann/json.hpp>

#include "base/clock.h"
#include "web/listen_address.h"
#include "web/server_parts.h"

namespace occmap::web {
namespace {

// A daemon whose status is older than this is left out of GET /api/status (it answers about twice
// a second: its periodic status, and our request's answer).
constexpr std::int64_t kFreshStatusNs = 3'000'000'000;
// The page is sent the daemons at most this often (each status comes with three companions, each
// making the daemon's JSON again), and at least once a second (how long ago each was heard).
constexpr auto kDaemonsGap = std::chrono::milliseconds(200);
constexpr auto kTick = std::chrono::seconds(1);
// /map.png requests waiting for the picture thread; past this, 503.
constexpr std::size_t kMaxPicturesWaiting = 8;

bool equalsIgnoringCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

// "host" of "host:port", "[v6]:port", "host".
std::string_view hostOnly(std::string_view host) {
  if (!host.empty() && host.front() == '[') {
    const std::size_t end = host.find(']');
    return end == std::string_view::npos ? host : host.substr(0, end + 1);
  }
  const std::size_t colon = host.find(':');
  return colon == std::string_view::npos ? host : host.substr(0, colon);
}

}  // namespace

Hub::Hub(LiveState& state, PictureDrawers pictures, WebServerOptions options)
    : state_(state), pictures_drawers_(std::move(pictures)), options_(std::move(options)) {}

Hub::~Hub() { stop(); }

void Hub::listen() {
  beast::error_code ec;
  const asio::ip::address address = asio::ip::make_address(options_.listen.host, ec);
  if (ec) throw std::runtime_error("\"" + options_.listen.host + "\" is not an address");
  const tcp::endpoint endpoint(address, options_.listen.port);
  const std::string where =
      (address.is_v6() ? "[" + options_.listen.host + "]" : options_.listen.host) + ":" +
      std::to_string(options_.listen.port);
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw std::runtime_error("cannot listen on " + where + ": " + ec.message());
  port_ = acceptor_.local_endpoint().port();
}

void Hub::start() {
  state_.setOnChange([this] { wake(); });
  accept();
  tick();
  network_thread_ = std::thread([this] { io_.run(); });
}

void Hub::stop() {
  if (network_thread_.joinable()) {
    io_.stop();
    network_thread_.join();
  }
  // The network thread has ended: its objects are this thread's now. The port is let go at once
  // (a server started again takes it); the connections go with the io_context.
  beast::error_code ignored;
  acceptor_.close(ignored);
  pictures_.stop();
  pictures_.join();
}

void Hub::wake() {
  if (!wake_pending_.exchange(true)) {
    asio::post(io_, [this] {
      wake_pending_.store(false);
      distribute();
    });
  }
}

void Hub::accept() {
  acceptor_.async_accept(io_, [this](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted) return;
    if (ec) {
      // Out of descriptors (EMFILE) and the like: try again in a moment rather than spin.
      accept_timer_.expires_after(std::chrono::milliseconds(100));
      accept_timer_.async_wait([this](beast::error_code wait) {
        if (!wait) accept();
      });
      return;
    }
    if (connections_ >= options_.max_connections) {
      ++refused_connections;
      beast::error_code ignored;
      socket.close(ignored);
    } else {
      std::make_shared<HttpSession>(std::move(socket), *this, ConnectionSlot(&connections_))
          ->start();
    }
    accept();
  });
}

void Hub::join(WebSocketSession* client) {
  clients_.insert(client);
  state_.setViewers(clients_.size());
  client->offerText(TextKind::kHello, helloMessage());
  client->offerText(TextKind::kDaemons, daemonsMessage());
  if (SharedText zones = state_.zones()) {
    client->offerText(TextKind::kZones, wrapped("zones", zones));
  }
  if (SharedText tracks = state_.tracks()) {
    client->offerText(TextKind::kTracks, wrapped("tracks", tracks));
  }
  client->offerText(TextKind::kPreviews, previewsMessage());
  if (SharedBytes map = state_.newestMapFrame()) client->offerMap(map);
}

void Hub::leave(WebSocketSession* client) {
  clients_.erase(client);
  state_.setViewers(clients_.size());
}

void Hub::distribute() {
  const LiveGenerations now = state_.generations();
  if (now.map != seen_.map) {
    seen_.map = now.map;
    const SharedBytes map = state_.newestMapFrame();
    for (WebSocketSession* client : clients_) client->offerMap(map);
  }
  if (now.zones != seen_.zones) {
    seen_.zones = now.zones;
    const SharedText zones = wrapped("zones", state_.zones());
    for (WebSocketSession* client : clients_) client->offerText(TextKind::kZones, zones);
  }
  if (now.tracks != seen_.tracks) {
    seen_.tracks = now.tracks;
    const SharedText tracks = wrapped("tracks", state_.tracks());
    for (WebSocketSession* client : clients_) client->offerText(TextKind::kTracks, tracks);
  }
  if (now.previews != seen_.previews) {
    seen_.previews = now.previews;
    const SharedText previews = previewsMessage();
    for (WebSocketSession* client : clients_) client->offerText(TextKind::kPreviews, previews);
  }
  if (now.daemons != seen_.daemons) {
    seen_.daemons = now.daemons;
    const auto due = daemons_sent_ + kDaemonsGap;
    if (std::chrono::steady_clock::now() >= due) {
      sendDaemons();
    } else if (!daemons_waiting_) {
      daemons_waiting_ = true;
      daemons_timer_.expires_at(due);
      daemons_timer_.async_wait([this](beast::error_code ec) {
        daemons_waiting_ = false;
        if (!ec) sendDaemons();
      });
    }
  }
}

void Hub::sendDaemons() {
  daemons_sent_ = std::chrono::steady_clock::now();
  const SharedText daemons = daemonsMessage();
  for (WebSocketSession* client : clients_) client->offerText(TextKind::kDaemons, daemons);
}

void Hub::tick() {
  // Once a second the daemons again, with how long ago each was heard: a daemon that went away
  // shows as silent even though nothing new came.
  if (std::chrono::steady_clock::now() - daemons_sent_ >= kTick && !daemons_waiting_) {
    sendDaemons();
  }
  tick_timer_.expires_after(std::chrono::milliseconds(250));
  tick_timer_.async_wait([this](beast::error_code ec) {
    if (!ec) tick();
  });
}

SharedText Hub::helloMessage() const {
  std::string text = "{\"type\":\"hello\",\"map_frame_version\":1";
  if (!options_.hello_members.empty()) text += "," + options_.hello_members;
  text += "}";
  return std::make_shared<const std::string>(std::move(text));
}

SharedText Hub::daemonsMessage() const {
  const std::int64_t now = monotonicNanoseconds();
  std::string text = "{\"type\":\"daemons\",\"daemons\":[";
  bool first = true;
  for (const DaemonHeard& daemon : state_.daemons(now)) {
    char heard[64];
    std::snprintf(heard, sizeof heard, "{\"heard_s_ago\":%.3f,\"status\":",
                  static_cast<double>(now - daemon.heard_ns) / 1e9);
    text += (first ? "" : ",") + std::string(heard) + *daemon.status_json + "}";
    first = false;
  }
  text += "]}";
  return std::make_shared<const std::string>(std::move(text));
}

SharedText Hub::previewsMessage() const {
  // The page learns which cameras have a new preview (and so new pictures) from `utime`.
  nlohmann::ordered_json previews = nlohmann::ordered_json::array();
  for (const auto& p : state_.previews(monotonicNanoseconds())) {
    previews.push_back(nlohmann::ordered_json{{"hostname", p->hostname},
                                              {"camera", p->camera},
                                              {"utime", p->utime},
                                              {"sequence", p->sequence},
                                              {"width", p->width},
                                              {"height", p->height},
                                              {"map_width", p->map_width},
                                              {"map_height", p->map_height}});
  }
  const nlohmann::ordered_json message = {{"type", "previews"}, {"previews", previews}};
  return std::make_shared<const std::string>(
      message.dump(-1, ' ', true, nlohmann::ordered_json::error_handler_t::replace));
}

SharedText Hub::wrapped(const char* type, const SharedText& json) const {
  return std::make_shared<const std::string>(std::string("{\"type\":\"") + type + "\",\"" + type +
                                             "\":" + (json ? *json : "null") + "}");
}

bool Hub::hostAllowed(std::string_view host) const {
  if (!isLoopbackAddress(options_.listen.host) || host.empty()) return true;
  const std::string_view name = hostOnly(host);
  if (equalsIgnoringCase(name, "localhost") || name == "[::1]") return true;
  if (isLoopbackAddress(std::string(name))) return true;
  return std::any_of(options_.allowed_hosts.begin(), options_.allowed_hosts.end(),
                     [&](const std::string& allowed) {
                       return equalsIgnoringCase(name, allowed) ||
                              equalsIgnoringCase(host, allowed);
                     });
}

bool Hub::originAllowed(std::string_view origin, std::string_view host) const {
  if (origin.empty()) return true;
  const std::size_t scheme = origin.find("://");
  return scheme != std::string_view::npos && equalsIgnoringCase(origin.substr(scheme + 3), host);
}

std::string Hub::statusJson() const {
  const std::int64_t now = monotonicNanoseconds();
  std::string text = "[";
  bool first = true;
  for (const DaemonHeard& daemon : state_.daemons(now)) {
    if (now - daemon.heard_ns > kFreshStatusNs) continue;
    text += (first ? "" : ",") + *daemon.status_json;
    first = false;
  }
  return text + "]";
}

std::string Hub::webJson() const {
  const LiveCounters heard = state_.counters();
  nlohmann::ordered_json j = {
      {"maps_heard", heard.maps},
      {"statuses_heard", heard.statuses},
      {"zones_heard", heard.zones},
      {"tracks_heard", heard.tracks},
      {"previews_heard", heard.previews},
      {"refused_messages", heard.refused},
      {"last_refusal", heard.last_refusal},
      {"connections", connections_},
      {"requests", requests},
      {"refused_requests", refused_requests},
      {"refused_connections", refused_connections},
      {"flooding_clients_closed", flooding_clients},
      {"max_clients", options_.max_clients},
  };
  nlohmann::ordered_json& clients = j["clients"] = nlohmann::ordered_json::array();
  std::vector<const WebSocketSession*> sorted(clients_.begin(), clients_.end());
  std::sort(sorted.begin(), sorted.end(),
            [](const WebSocketSession* a, const WebSocketSession* b) { return a->id() < b->id(); });
  for (const WebSocketSession* client : sorted) {
    clients.push_back(nlohmann::ordered_json{
        {"id", client->id()},
        {"connected_s", client->connectedSeconds()},
        {"maps_sent", client->mapsSent()},
        {"maps_skipped", client->mapsSkipped()},
        {"bytes_sent", client->bytesSent()},
        {"writing", client->writing()},
    });
  }
  return j.dump(-1, ' ', true, nlohmann::ordered_json::error_handler_t::replace);
}

void Hub::drawPicture(std::optional<std::int64_t> seq, std::function<void(PictureResult)> done) {
  std::shared_ptr<const HeldMap> map = seq ? state_.recentMap(*seq) : state_.newestMap();
  if (!map) {
    PictureResult none{http::status::not_found, nullptr, 0, ""};
    none.error = seq ? "map " + std::to_string(*seq) + " is not held: the server keeps the last " +
                           std::to_string(LiveState::kRecentMaps) + " maps\n"
                     : "no map heard yet\n";
    done(std::move(none));
    return;
  }
  onPictureThread([this, map] { return pictureOf(map); }, map->seq, std::move(done));
}

void Hub::onPictureThread(std::function<SharedBytes()> draw, std::int64_t seq,
                          std::function<void(PictureResult)> done) {
  if (pictures_waiting_ >= kMaxPicturesWaiting) {
    done({http::status::service_unavailable, nullptr, 0, "busy drawing pictures: try again\n"});
    return;
  }
  ++pictures_waiting_;
  asio::post(pictures_, [this, seq, draw = std::move(draw), done = std::move(done)]() mutable {
    SharedBytes png = draw();
    asio::post(io_, [this, seq, png, done = std::move(done)] {
      --pictures_waiting_;
      if (!png || png->empty()) {
        done({http::status::internal_server_error, nullptr, seq,
              "the picture could not be drawn\n"});
      } else {
        done({http::status::ok, png, seq, ""});
      }
    });
  });
}

void Hub::drawCameraPicture(const CameraPath& path, std::function<void(PictureResult)> done) {
  std::shared_ptr<const HeldPreview> preview = state_.preview(path.hostname, path.camera);
  if (!preview) {
    done({http::status::not_found, nullptr, 0, "no preview of that camera heard\n"});
    return;
  }
  const bool cells = path.picture == CameraPath::Picture::kCells;
  if (cells && preview->coverage.empty()) {
    done({http::status::not_found, nullptr, 0,
          "that camera's cells are not held: its map is larger than this server draws\n"});
    return;
  }
  onPictureThread(
      [this, preview, cells] {
        // Changed pixels: red, two thirds opaque, over the frame. Cells: a light blue, opaque,
        // at the map's size with map row 0 at the bottom (+y up, as /map.png).
        const int width = cells ? preview->map_width : preview->width;
        const int height = cells ? preview->map_height : preview->height;
        const std::vector<std::uint8_t>& bits = cells ? preview->coverage : preview->changed;
        std::vector<std::uint8_t> rgba(
            static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 4, 0);
        for (int y = 0; y < height; ++y) {
          const int source_row = cells ? height - 1 - y : y;
          for (int x = 0; x < width; ++x) {
            const std::size_t from =
                static_cast<std::size_t>(source_row) * static_cast<std::size_t>(width) +
                static_cast<std::size_t>(x);
            if (from >= bits.size() || bits[from] == 0) continue;
            std::uint8_t* to =
                &rgba[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                       static_cast<std::size_t>(x)) *
                      4];
            if (cells) {
              to[0] = 40, to[1] = 170, to[2] = 255, to[3] = 255;
            } else {
              to[0] = 255, to[1] = 30, to[2] = 30, to[3] = 170;
            }
          }
        }
        return std::make_shared<const std::vector<std::uint8_t>>(
            pictures_drawers_.rgba(width, height, rgba));
      },
      preview->sequence, std::move(done));
}

void Hub::drawCoverage(std::function<void(PictureResult)> done) {
  std::vector<std::shared_ptr<const HeldPreview>> previews =
      state_.previews(monotonicNanoseconds());
  // The map's size: the newest map's, or the first preview's before any map; previews of
  // another size (another daemon's map) are left out, and at most 32 cameras drawn.
  int width = 0, height = 0;
  if (const std::shared_ptr<const HeldMap> map = state_.newestMap()) {
    width = map->map.geometry.width;
    height = map->map.geometry.height;
  } else if (!previews.empty()) {
    width = previews.front()->map_width;
    height = previews.front()->map_height;
  }
  // Only previews whose coverage is held (LiveState::kMaxCoverageCells).
  std::erase_if(previews, [&](const auto& p) {
    return p->map_width != width || p->map_height != height || p->coverage.empty();
  });
  if (previews.size() > 32) previews.resize(32);
  if (previews.empty()) {
    done({http::status::not_found, nullptr, 0,
          "no camera preview heard yet (is occmapd running? previews come while a page is "
          "open)\n"});
    return;
  }
  onPictureThread(
      [this, previews, width, height] {
        std::vector<std::uint32_t> seen_by(
            static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0);
        for (std::size_t k = 0; k < previews.size(); ++k) {
          const std::vector<std::uint8_t>& coverage = previews[k]->coverage;
          for (std::size_t cell = 0; cell < seen_by.size() && cell < coverage.size(); ++cell) {
            if (coverage[cell] != 0) seen_by[cell] |= 1u << k;
          }
        }
        return std::make_shared<const std::vector<std::uint8_t>>(
            pictures_drawers_.coverage(width, height, seen_by, previews.size()));
      },
      0, std::move(done));
}

SharedBytes Hub::pictureOf(const std::shared_ptr<const HeldMap>& map) {
  // The picture thread's: many asking for the newest map cost one drawing.
  if (map != pictured_map_ || !pictured_png_) {
    pictured_png_ = std::make_shared<const std::vector<std::uint8_t>>(pictures_drawers_.map(*map));
    pictured_map_ = map;
  }
  return pictured_png_;
}

struct WebServer::Impl {
  Hub hub;
  Impl(LiveState& state, PictureDrawers pictures, WebServerOptions options)
      : hub(state, std::move(pictures), std::move(options)) {}
};

WebServer::WebServer(LiveState& state, PictureDrawers pictures, WebServerOptions options)
    : impl_(std::make_unique<Impl>(state, std::move(pictures), std::move(options))) {}

WebServer::~WebServer() { stop(); }

void WebServer::listen() { impl_->hub.listen(); }
std::uint16_t WebServer::port() const { return impl_->hub.port(); }
void WebServer::start() { impl_->hub.start(); }
void WebServer::stop() { impl_->hub.stop(); }

}  // namespace occmap::web
