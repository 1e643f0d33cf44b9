// HTTP: requests read one after another on a connection, each answered from the hub, or refused
// with the status that says why; a WebSocket upgrade on /ws hands the connection over.
#include <charconv>
#include <utility>

#include "web/page_assets.h"
#include "web/server_parts.h"

namespace occmap::web {
namespace {

// The page's own files and nothing else: no inline script or style, no other origin, no frames.
// 'self' in connect-src covers the page's WebSocket (ws:// and wss:// of the same host).
constexpr const char* kContentSecurityPolicy =
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

// A response with the headers every answer carries.
Response makeResponse(http::status status, unsigned version, bool keep_alive,
                      std::string_view content_type, std::string body,
                      std::string_view cache_control = "no-store") {
  Response response{status, version};
  response.set(http::field::server, "occmap-web");
  response.set(http::field::content_type,
               beast::string_view(content_type.data(), content_type.size()));
  response.set(http::field::cache_control,
               beast::string_view(cache_control.data(), cache_control.size()));
  response.set("X-Content-Type-Options", "nosniff");
  response.set("Content-Security-Policy", kContentSecurityPolicy);
  response.set("X-Frame-Options", "DENY");
  response.set("Referrer-Policy", "no-referrer");
  response.keep_alive(keep_alive);
  response.body() = std::move(body);
  response.prepare_payload();
  return response;
}

// The query's seq=N, or nothing (with `bad` set when there is a query that is not that).
std::optional<std::int64_t> seqOfQuery(std::string_view query, bool& bad) {
  bad = false;
  if (query.empty()) return std::nullopt;
  constexpr std::string_view kSeq = "seq=";
  if (!query.starts_with(kSeq)) {
    bad = true;
    return std::nullopt;
  }
  const std::string_view digits = query.substr(kSeq.size());
  std::int64_t seq = 0;
  const auto [end, problem] = std::from_chars(digits.data(), digits.data() + digits.size(), seq);
  if (digits.empty() || problem != std::errc() || end != digits.data() + digits.size()) {
    bad = true;
    return std::nullopt;
  }
  return seq;
}

std::string_view toStringView(beast::string_view text) { return {text.data(), text.size()}; }

}  // namespace

HttpSession::HttpSession(tcp::socket&& socket, Hub& hub, ConnectionSlot slot)
    : stream_(std::move(socket)), hub_(hub), slot_(std::move(slot)) {}

void HttpSession::read() {
  parser_.emplace();
  parser_->header_limit(kHeaderLimit);
  parser_->body_limit(0);
  // A client that sends its request slowly (or not at all) is let go: no connection is held open
  // by one that does nothing.
  stream_.expires_after(kReadTimeout);
  http::async_read(
      stream_, buffer_, *parser_,
      [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onRead(ec); });
}

void HttpSession::onRead(beast::error_code ec) {
  if (ec == http::error::end_of_stream || ec == beast::error::timeout ||
      ec == asio::error::operation_aborted) {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
    return;
  }
  if (ec == http::error::header_limit) {
    refuse(http::status::request_header_fields_too_large,
           "the request's head is larger than " + std::to_string(kHeaderLimit / 1024) + " KiB\n",
           11, false);
    return;
  }
  if (ec == http::error::body_limit || ec == http::error::unexpected_body) {
    refuse(http::status::payload_too_large, "requests here carry no body\n", 11, false);
    return;
  }
  if (ec && ec.category() == http::make_error_code(http::error::bad_method).category()) {
    refuse(http::status::bad_request, "not an HTTP request this server understands\n", 11, false);
    return;
  }
  if (ec) {  // the connection failed (reset, …): nothing to answer
    beast::error_code ignored;
    stream_.socket().close(ignored);
    return;
  }
  ++hub_.requests;
  Request request = parser_->release();
  if (!hub_.hostAllowed(toStringView(request[http::field::host]))) {
    refuse(http::status::forbidden,
           "this server listens on the loopback and answers requests to localhost, 127.0.0.1 "
           "or [::1] only (occmap web --allow-host NAME answers NAME too)\n",
           request.version(), false);
    return;
  }
  if (websocket::is_upgrade(request)) {
    upgrade(std::move(request));
    return;
  }
  answer(request);
}

void HttpSession::answer(const Request& request) {
  const unsigned version = request.version();
  const bool keep_alive = request.keep_alive();
  if (request.method() != http::verb::get && request.method() != http::verb::head) {
    Response refused =
        makeResponse(http::status::method_not_allowed, version, keep_alive,
                     "text/plain; charset=utf-8", "this server is read-only: GET and HEAD only\n");
    refused.set(http::field::allow, "GET, HEAD");
    ++hub_.refused_requests;
    send(std::move(refused), !keep_alive);
    return;
  }
  const bool head = request.method() == http::verb::head;
  const std::string_view target = toStringView(request.target());
  const std::size_t question = target.find('?');
  const std::string_view path = target.substr(0, question);
  const std::string_view query =
      question == std::string_view::npos ? std::string_view() : target.substr(question + 1);
  const auto reply = [&](Response&& response) {
    if (response.result_int() >= 400) ++hub_.refused_requests;
    if (head) {
      // HEAD: the headers GET would have, Content-Length included, and no body.
      const std::size_t length = response.body().size();
      response.body().clear();
      response.content_length(length);
    }
    send(std::move(response), !keep_alive);
  };
  const auto json = [&](std::string body) {
    reply(makeResponse(http::status::ok, version, keep_alive, "application/json", std::move(body)));
  };
  if (path == "/api/status") return json(hub_.statusJson());
  if (path == "/api/tracks") {
    const SharedText tracks = hub_.state().tracks();
    return json(tracks ? *tracks : "null");
  }
  if (path == "/api/zones") {
    const SharedText zones = hub_.state().zones();
    return json(zones ? *zones : "null");
  }
  if (path == "/api/web") return json(hub_.webJson());
  if (path == "/map.png") {
    bool bad = false;
    const std::optional<std::int64_t> seq = seqOfQuery(query, bad);
    if (bad) {
      return reply(makeResponse(http::status::bad_request, version, keep_alive,
                                "text/plain; charset=utf-8",
                                "/map.png takes one parameter, seq=N (a map's number)\n"));
    }
    hub_.drawPicture(seq, pictureAnswer(version, keep_alive, head, true));
    return;
  }
  if (path == "/coverage.png") {
    hub_.drawCoverage(pictureAnswer(version, keep_alive, head, false));
    return;
  }
  if (path.starts_with("/camera/")) {
    CameraPathError error = CameraPathError::kNotACameraPath;
    const std::optional<CameraPath> camera = parseCameraPath(path, error);
    if (!camera) {
      return reply(makeResponse(
          error == CameraPathError::kBadName ? http::status::bad_request : http::status::not_found,
          version, keep_alive, "text/plain; charset=utf-8",
          "a camera's pictures are /camera/HOST/CAMERA.jpg, /camera/HOST/CAMERA/changed.png and "
          "/camera/HOST/CAMERA/cells.png, each name percent-encoded\n"));
    }
    if (camera->picture != CameraPath::Picture::kFrame) {
      hub_.drawCameraPicture(*camera, pictureAnswer(version, keep_alive, head, false));
      return;
    }
    // The frame: the daemon's JPEG as it came.
    const auto preview = hub_.state().preview(camera->hostname, camera->camera);
    if (!preview) {
      return reply(makeResponse(http::status::not_found, version, keep_alive,
                                "text/plain; charset=utf-8", "no preview of that camera heard\n"));
    }
    Response response = makeResponse(http::status::ok, version, keep_alive, "image/jpeg",
                                     std::string(preview->jpeg.begin(), preview->jpeg.end()));
    response.set("X-Preview-Utime", std::to_string(preview->utime));
    return reply(std::move(response));
  }
  if (path == "/ws") {
    return reply(makeResponse(http::status::upgrade_required, version, keep_alive,
                              "text/plain; charset=utf-8",
                              "/ws is the page's WebSocket: connect with a WebSocket client\n"));
  }
  if (const PageAsset* asset = findPageAsset(path)) {
    // The page may change with a new occmap: the browser asks again each time (no-cache).
    return reply(makeResponse(http::status::ok, version, keep_alive, asset->content_type,
                              std::string(asset->bytes.begin(), asset->bytes.end()), "no-cache"));
  }
  reply(makeResponse(http::status::not_found, version, keep_alive, "text/plain; charset=utf-8",
                     "no such page: try /, /api/status, /api/tracks, /api/zones, /api/web, "
                     "/map.png, /coverage.png or /camera/HOST/CAMERA.jpg\n"));
}

void HttpSession::upgrade(Request&& request) {
  const unsigned version = request.version();
  if (toStringView(request.target()) != "/ws") {
    refuse(http::status::not_found, "the WebSocket is /ws\n", version, false);
    return;
  }
  // A page on another site may open a WebSocket to this one (browsers let it: WebSocket has no
  // same-origin rule), and would read the live map: the browser's Origin must be this server.
  if (!hub_.originAllowed(toStringView(request[http::field::origin]),
                          toStringView(request[http::field::host]))) {
    refuse(http::status::forbidden, "a page of another origin may not read this server's feed\n",
           version, false);
    return;
  }
  if (!hub_.roomForClient()) {
    refuse(http::status::service_unavailable,
           "too many clients (occmap web --max-clients): try again later\n", version, false);
    return;
  }
  stream_.expires_never();  // the WebSocket keeps its own timeouts
  std::make_shared<WebSocketSession>(std::move(stream_), hub_, std::move(slot_))
      ->start(std::move(request));
}

std::function<void(PictureResult)> HttpSession::pictureAnswer(unsigned version, bool keep_alive,
                                                              bool head, bool map_seq) {
  return [self = shared_from_this(), version, keep_alive, head, map_seq](PictureResult picture) {
    Response response = picture.status == http::status::ok
                            ? makeResponse(http::status::ok, version, keep_alive, "image/png",
                                           std::string(picture.png->begin(), picture.png->end()))
                            : makeResponse(picture.status, version, keep_alive,
                                           "text/plain; charset=utf-8", std::move(picture.error));
    if (picture.status != http::status::ok) {
      ++self->hub_.refused_requests;
    } else if (map_seq) {
      response.set("X-Map-Seq", std::to_string(picture.seq));
    }
    if (head) {
      const std::size_t length = response.body().size();
      response.body().clear();
      response.content_length(length);
    }
    self->send(std::move(response), !keep_alive);
  };
}

void HttpSession::send(Response&& response, bool close) {
  response_ = std::make_shared<Response>(std::move(response));
  // A client that does not read its answer is let go as one that does not send its request.
  stream_.expires_after(kReadTimeout);
  http::async_write(stream_, *response_,
                    [self = shared_from_this(), close](beast::error_code ec, std::size_t) {
                      self->response_.reset();
                      if (ec) return;
                      if (close) {
                        beast::error_code ignored;
                        self->stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
                        self->drainThenClose();
                        return;
                      }
                      self->read();
                    });
}

void HttpSession::refuse(http::status status, std::string why, unsigned version, bool keep_alive) {
  ++hub_.refused_requests;
  send(makeResponse(status, version, keep_alive, "text/plain; charset=utf-8", std::move(why)),
       !keep_alive);
}

void HttpSession::drainThenClose() {
  // What the client still sends after a refusal (the rest of a huge head) is read and dropped for
  // a moment before the socket closes: closing with unread bytes would reset the connection, and
  // the client could lose the answer that says what was wrong.
  if (drained_ == 0) stream_.expires_after(std::chrono::seconds(2));
  stream_.async_read_some(asio::buffer(drain_),
                          [self = shared_from_this()](beast::error_code ec, std::size_t bytes) {
                            self->drained_ += bytes;
                            if (ec || self->drained_ > kMaxDrained) {
                              beast::error_code ignored;
                              self->stream_.socket().close(ignored);
                              return;
                            }
                            self->drainThenClose();
                          });
}

}  // namespace occmap::web
