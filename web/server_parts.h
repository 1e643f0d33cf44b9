#pragma once
// The inside of web_server.h, shared by its three files (web_server.cpp: the hub, the listener and
// the threads; http_session.cpp: requests and answers; websocket_session.cpp: the live feed).
// Everything here runs on the network thread unless it says otherwise.

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_set>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/thread_pool.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include "web/camera_path.h"
#include "web/live_state.h"
#include "web/web_server.h"

namespace occmap::web {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

using Request = http::request<http::empty_body>;
using Response = http::response<http::string_body>;

class Hub;
class WebSocketSession;

// One connection counted against WebServerOptions::max_connections while it lives; handed from
// the HTTP session to the WebSocket session on an upgrade.
class ConnectionSlot {
 public:
  explicit ConnectionSlot(std::size_t* count) : count_(count) { ++*count_; }
  ~ConnectionSlot() {
    if (count_ != nullptr) --*count_;
  }
  ConnectionSlot(ConnectionSlot&& other) noexcept : count_(other.count_) { other.count_ = nullptr; }
  ConnectionSlot& operator=(ConnectionSlot&&) = delete;
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;

 private:
  std::size_t* count_;
};

// A drawn picture (/map.png, a camera's overlay, /coverage.png), or why there is none.
struct PictureResult {
  http::status status = http::status::ok;
  SharedBytes png;
  std::int64_t seq = 0;
  std::string error;  // for a status other than 200
};

// The kinds of text message a WebSocket client is sent, each in a slot of its own (the newest
// replaces one not yet written), written in this order before a waiting map.
enum class TextKind : std::size_t { kHello, kDaemons, kZones, kTracks, kPreviews, kCount };

// What every connection shares: the state, the options, the WebSocket clients, the picture
// thread, and the counts of /api/web.
class Hub {
 public:
  Hub(LiveState& state, PictureDrawers pictures, WebServerOptions options);
  ~Hub();
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;

  asio::io_context& io() { return io_; }
  LiveState& state() { return state_; }
  const WebServerOptions& options() const { return options_; }

  void listen();
  std::uint16_t port() const { return port_; }
  void start();  // the network and picture threads
  void stop();

  // Any thread: something in the state changed (at most one wake-up waits at a time).
  void wake();

  // The WebSocket clients. join() sends the newcomer the newest of everything.
  bool roomForClient() const { return clients_.size() < options_.max_clients; }
  void join(WebSocketSession* client);
  void leave(WebSocketSession* client);

  // Whether a request with this Host header is answered (WebServerOptions::allowed_hosts).
  bool hostAllowed(std::string_view host) const;
  // Whether a WebSocket upgrade with this Origin header (a browser's page) may read the feed: none
  // (not a browser), or the page's own server, the very host and port the request went to.
  bool originAllowed(std::string_view origin, std::string_view host) const;

  // The JSON of the API.
  std::string statusJson() const;  // GET /api/status
  std::string webJson() const;     // GET /api/web

  // Draws the map numbered `seq` (the newest without one) on the picture thread; `done` runs on
  // the network thread. A busy picture thread answers 503 at once.
  void drawPicture(std::optional<std::int64_t> seq, std::function<void(PictureResult)> done);
  // A camera's changed pixels (RGBA over its frame) or cells (RGBA at the map's size, +y up), on
  // the picture thread; 404 for a camera whose preview is not held.
  void drawCameraPicture(const CameraPath& path, std::function<void(PictureResult)> done);
  // The coverage picture of every camera's preview, on the picture thread; 404 before any.
  void drawCoverage(std::function<void(PictureResult)> done);

  // Counted for /api/web.
  std::uint64_t requests = 0;
  std::uint64_t refused_requests = 0;  // answered with 4xx or 5xx
  std::uint64_t refused_connections = 0;
  std::uint64_t flooding_clients = 0;  // WebSocket clients closed for sending too much
  std::uint64_t next_client_id = 1;

 private:
  void accept();
  void distribute();
  void sendDaemons();
  void tick();
  SharedText helloMessage() const;
  SharedText daemonsMessage() const;
  SharedText previewsMessage() const;
  // Runs `draw` on the picture thread (503 at once when too many wait) and `done` with its PNG on
  // the network thread (500 when it drew nothing).
  void onPictureThread(std::function<SharedBytes()> draw, std::int64_t seq,
                       std::function<void(PictureResult)> done);
  SharedText wrapped(const char* type, const SharedText& json) const;
  SharedBytes pictureOf(const std::shared_ptr<const HeldMap>& map);

  LiveState& state_;
  PictureDrawers pictures_drawers_;
  WebServerOptions options_;
  std::uint16_t port_ = 0;
  std::size_t connections_ = 0;
  std::unordered_set<WebSocketSession*> clients_;
  LiveGenerations seen_;
  std::atomic<bool> wake_pending_{false};
  std::chrono::steady_clock::time_point daemons_sent_{};
  bool daemons_waiting_ = false;
  std::size_t pictures_waiting_ = 0;
  // The picture thread's own: the newest picture drawn, for whoever asks for it again.
  std::shared_ptr<const HeldMap> pictured_map_;
  SharedBytes pictured_png_;
  std::thread network_thread_;
  // Destroyed before the members above: its handlers own the sessions, whose destructors leave()
  // the hub. The timers and the acceptor go before it.
  asio::io_context io_{1};
  tcp::acceptor acceptor_{io_};
  asio::steady_timer daemons_timer_{io_};
  asio::steady_timer tick_timer_{io_};
  asio::steady_timer accept_timer_{io_};
  // Destroyed first: a picture asked for but not drawn when the server stops holds its answer,
  // which owns its session, whose socket is io_'s. Destroyed after io_ (as it was), the session
  // closed its socket in a freed service (TSan: heap-use-after-free at `occmap web`'s exit, with a
  // picture request pending, web_browser_test's server restart).
  asio::thread_pool pictures_{1};
};

// One HTTP connection: requests read one after another (keep-alive), each answered; a WebSocket
// upgrade on /ws hands the connection to a WebSocketSession.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, Hub& hub, ConnectionSlot slot);
  void start() { read(); }

  // Header limits: a request's head (request line and headers) larger than this is answered 431.
  static constexpr std::uint32_t kHeaderLimit = 16 * 1024;
  static constexpr std::chrono::seconds kReadTimeout{10};

 private:
  void read();
  void onRead(beast::error_code ec);
  void answer(const Request& request);
  void upgrade(Request&& request);
  void send(Response&& response, bool close);
  // Answers with a PNG drawn on the picture thread (or its error); `map_seq`: with X-Map-Seq.
  std::function<void(PictureResult)> pictureAnswer(unsigned version, bool keep_alive, bool head,
                                                   bool map_seq);
  void refuse(http::status status, std::string why, unsigned version, bool keep_alive);
  void drainThenClose();

  static constexpr std::size_t kMaxDrained = 1 << 20;

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::empty_body>> parser_;
  std::shared_ptr<Response> response_;
  Hub& hub_;
  ConnectionSlot slot_;
  std::array<char, 4096> drain_{};
  std::size_t drained_ = 0;
};

// One browser's live feed.
class WebSocketSession : public std::enable_shared_from_this<WebSocketSession> {
 public:
  WebSocketSession(beast::tcp_stream&& stream, Hub& hub, ConnectionSlot slot);
  ~WebSocketSession();
  void start(Request&& request);

  void offerMap(const SharedBytes& frame);
  void offerText(TextKind kind, const SharedText& text);

  // For /api/web.
  std::uint64_t id() const { return id_; }
  std::uint64_t mapsSent() const { return maps_sent_; }
  std::uint64_t mapsSkipped() const { return maps_skipped_; }
  std::uint64_t bytesSent() const { return bytes_sent_; }
  bool writing() const { return writing_ != nullptr; }
  double connectedSeconds() const;

  // Messages a client may send (the page sends none): a burst of kBurst, then kPerSecond; past
  // that it is closed (1008, policy violation). Larger than kMaxMessage: closed (1009).
  static constexpr double kBurst = 50;
  static constexpr double kPerSecond = 10;
  static constexpr std::size_t kMaxMessage = 4096;

 private:
  void read();
  void onRead(beast::error_code ec);
  void writeNext();
  void onWrite(beast::error_code ec, std::size_t bytes, bool map);
  void closeForFlood();

  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer read_buffer_;
  Hub& hub_;
  ConnectionSlot slot_;
  std::uint64_t id_;
  bool joined_ = false;
  bool closing_ = false;
  std::chrono::steady_clock::time_point connected_;
  SharedBytes pending_map_;
  std::array<SharedText, static_cast<std::size_t>(TextKind::kCount)> pending_text_;
  std::shared_ptr<const void> writing_;  // the buffer being written
  std::uint64_t maps_sent_ = 0;
  std::uint64_t maps_skipped_ = 0;
  std::uint64_t bytes_sent_ = 0;
  double tokens_ = kBurst;
  std::chrono::steady_clock::time_point tokens_at_;
};

}  // namespace occmap::web
