// One browser's live feed: the newest map as a binary message, statuses, tracks and zones as JSON
// text messages; one write at a time, and what waits is only the newest of each kind.
#include <algorithm>
#include <utility>

#include "web/server_parts.h"

namespace occmap::web {
namespace {

// A client that does not answer the server's pings within this long (a browser answers them by
// itself) is closed: a browser gone without closing, or a client that reads nothing.
constexpr std::chrono::seconds kIdleTimeout{20};
constexpr std::chrono::seconds kHandshakeTimeout{10};
// The kernel's send buffer of a client's socket. Left to itself Linux grows it to 4 MiB, where a
// browser on a slow link would queue a minute of maps at 64 KiB each: "the newest map" would be
// old when it arrives. 256 KiB holds a few maps (2 MB/s per browser at 30 maps of 512 x 512 cells
// a second, on links of up to 100 ms round trip); what does not fit waits in the client's one
// slot, replaced by the next map.
constexpr int kSendBufferBytes = 256 * 1024;

}  // namespace

WebSocketSession::WebSocketSession(beast::tcp_stream&& stream, Hub& hub, ConnectionSlot slot)
    : ws_(std::move(stream)),
      hub_(hub),
      slot_(std::move(slot)),
      id_(hub.next_client_id++),
      connected_(std::chrono::steady_clock::now()),
      tokens_at_(connected_) {}

WebSocketSession::~WebSocketSession() {
  if (joined_) hub_.leave(this);
}

double WebSocketSession::connectedSeconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - connected_).count();
}

void WebSocketSession::start(Request&& request) {
  websocket::stream_base::timeout timeouts{};
  timeouts.handshake_timeout = kHandshakeTimeout;
  timeouts.idle_timeout = kIdleTimeout;
  timeouts.keep_alive_pings = true;
  ws_.set_option(timeouts);
  ws_.set_option(websocket::stream_base::decorator(
      [](websocket::response_type& response) { response.set(http::field::server, "occmap-web"); }));
  ws_.read_message_max(kMaxMessage);
  // A map in one frame: it is written as it is, not cut into the default 4 KiB fragments.
  ws_.auto_fragment(false);
  beast::error_code ignored;
  tcp::socket& socket = beast::get_lowest_layer(ws_).socket();
  socket.set_option(tcp::no_delay(true), ignored);
  socket.set_option(asio::socket_base::send_buffer_size(kSendBufferBytes), ignored);
  ws_.async_accept(request, [self = shared_from_this()](beast::error_code ec) {
    if (ec) return;
    self->joined_ = true;
    self->hub_.join(self.get());
    self->read();
  });
}

void WebSocketSession::offerMap(const SharedBytes& frame) {
  if (!frame || closing_) return;
  if (pending_map_) ++maps_skipped_;  // not yet written: the newer one takes its place
  pending_map_ = frame;
  writeNext();
}

void WebSocketSession::offerText(TextKind kind, const SharedText& text) {
  if (!text || closing_) return;
  pending_text_[static_cast<std::size_t>(kind)] = text;
  writeNext();
}

void WebSocketSession::writeNext() {
  if (writing_ || closing_ || !joined_) return;
  for (SharedText& text : pending_text_) {
    if (!text) continue;
    const SharedText message = std::move(text);
    text.reset();
    writing_ = message;
    ws_.text(true);
    ws_.async_write(asio::buffer(*message),
                    [self = shared_from_this()](beast::error_code ec, std::size_t bytes) {
                      self->onWrite(ec, bytes, false);
                    });
    return;
  }
  if (pending_map_) {
    const SharedBytes map = std::move(pending_map_);
    pending_map_.reset();
    writing_ = map;
    ws_.binary(true);
    ws_.async_write(asio::buffer(*map),
                    [self = shared_from_this()](beast::error_code ec, std::size_t bytes) {
                      self->onWrite(ec, bytes, true);
                    });
  }
}

void WebSocketSession::onWrite(beast::error_code ec, std::size_t bytes, bool map) {
  writing_.reset();
  if (ec) {
    // Gone, or closed by the idle timeout: nothing more is written; the read ends the session.
    closing_ = true;
    pending_map_.reset();
    for (SharedText& text : pending_text_) text.reset();
    return;
  }
  bytes_sent_ += bytes;
  if (map) ++maps_sent_;
  writeNext();
}

void WebSocketSession::read() {
  ws_.async_read(read_buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
    self->onRead(ec);
  });
}

void WebSocketSession::onRead(beast::error_code ec) {
  if (ec) {  // closed, timed out, too large (Beast has sent the close frame): the session ends
    closing_ = true;
    return;
  }
  read_buffer_.consume(read_buffer_.size());
  // The page sends nothing; a client that floods the server is closed without harm to others.
  const auto now = std::chrono::steady_clock::now();
  tokens_ = std::min(
      kBurst, tokens_ + std::chrono::duration<double>(now - tokens_at_).count() * kPerSecond);
  tokens_at_ = now;
  if (tokens_ < 1.0) {
    closeForFlood();
    return;
  }
  tokens_ -= 1.0;
  read();
}

void WebSocketSession::closeForFlood() {
  ++hub_.flooding_clients;
  closing_ = true;
  pending_map_.reset();
  for (SharedText& text : pending_text_) text.reset();
  // The close frame waits for a write under way; the handshake timeout bounds the wait.
  ws_.async_close(websocket::close_reason(websocket::close_code::policy_error,
                                          "too many messages: this feed is read-only"),
                  [self = shared_from_this()](beast::error_code) {});
}

}  // namespace occmap::web
