#include "web_client.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <functional>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace occmap::testing {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

static_assert(kPolicyErrorCloseCode == static_cast<int>(websocket::close_code::policy_error));

namespace {

tcp::endpoint loopbackEndpoint(std::uint16_t port) {
  return {asio::ip::make_address("127.0.0.1"), port};
}

http::verb verbOf(HttpMethod method) {
  switch (method) {
    case HttpMethod::kHead:
      return http::verb::head;
    case HttpMethod::kPost:
      return http::verb::post;
    case HttpMethod::kDelete:
      return http::verb::delete_;
    case HttpMethod::kGet:
      break;
  }
  return http::verb::get;
}

}  // namespace

HttpAnswer httpRequest(std::uint16_t port, const std::string& target, HttpMethod method,
                       const std::vector<std::pair<std::string, std::string>>& headers,
                       std::chrono::milliseconds timeout) {
  asio::io_context io;
  beast::tcp_stream stream(io);
  HttpAnswer answer;
  http::request<http::string_body> request{verbOf(method), target, 11};
  request.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  for (const auto& [name, value] : headers) request.set(name, value);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(64 << 20);
  if (method == HttpMethod::kHead) parser.skip(true);
  stream.expires_after(timeout);
  stream.async_connect(loopbackEndpoint(port), [&](beast::error_code ec) {
    if (ec) {
      answer.error = "connect: " + ec.message();
      return;
    }
    http::async_write(stream, request, [&](beast::error_code written, std::size_t) {
      if (written) {
        answer.error = "write: " + written.message();
        return;
      }
      http::async_read(stream, buffer, parser, [&](beast::error_code read, std::size_t) {
        if (read) {
          answer.error = "read: " + read.message();
          return;
        }
        const auto& response = parser.get();
        answer.status = static_cast<int>(response.result_int());
        for (const auto& field : response) {
          std::string name(field.name_string());
          std::transform(name.begin(), name.end(), name.begin(),
                         [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
          answer.headers[name] = std::string(field.value());
        }
        answer.body = response.body();
      });
    });
  });
  io.run();
  return answer;
}

std::string rawExchange(std::uint16_t port, const std::string& bytes,
                        std::chrono::milliseconds timeout) {
  asio::io_context io;
  beast::tcp_stream stream(io);
  std::string received;
  std::array<char, 4096> chunk{};
  std::function<void()> readMore = [&] {
    stream.async_read_some(asio::buffer(chunk), [&](beast::error_code ec, std::size_t n) {
      received.append(chunk.data(), n);
      if (!ec) readMore();
    });
  };
  stream.expires_after(timeout);
  stream.async_connect(loopbackEndpoint(port), [&](beast::error_code ec) {
    if (ec) return;
    readMore();
    asio::async_write(stream, asio::buffer(bytes), [](beast::error_code, std::size_t) {});
  });
  io.run();
  return received;
}

struct FeedSocket::State {
  asio::io_context io;
  websocket::stream<beast::tcp_stream> ws{io};
  websocket::response_type response;
  beast::flat_buffer buffer;
  std::string error;

  void run(std::chrono::milliseconds timeout, const bool& done) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    io.restart();
    while (!done && std::chrono::steady_clock::now() < end) {
      io.run_for(std::chrono::milliseconds(20));
      if (io.stopped()) io.restart();
    }
  }
};

FeedSocket::FeedSocket(std::uint16_t port, const std::string& origin, const std::string& target)
    : state_(std::make_unique<State>()) {
  State& s = *state_;
  bool done = false;
  beast::get_lowest_layer(s.ws).expires_after(eventually(std::chrono::seconds(10)));
  beast::get_lowest_layer(s.ws).async_connect(loopbackEndpoint(port), [&](beast::error_code ec) {
    if (ec) {
      s.error = "connect: " + ec.message();
      done = true;
      return;
    }
    beast::get_lowest_layer(s.ws).expires_never();
    s.ws.set_option(websocket::stream_base::timeout::suggested(beast::role_type::client));
    s.ws.set_option(websocket::stream_base::decorator([origin](websocket::request_type& r) {
      if (!origin.empty()) r.set(http::field::origin, origin);
    }));
    s.ws.async_handshake(s.response, "127.0.0.1:" + std::to_string(port), target,
                         [&](beast::error_code shaken) {
                           if (shaken) s.error = "handshake: " + shaken.message();
                           done = true;
                         });
  });
  s.run(eventually(std::chrono::seconds(10)), done);
  if (!done) s.error = "no handshake in time";
}

FeedSocket::~FeedSocket() = default;

bool FeedSocket::connected() const { return state_->error.empty(); }
const std::string& FeedSocket::error() const { return state_->error; }
int FeedSocket::handshakeStatus() const { return static_cast<int>(state_->response.result_int()); }

std::optional<FeedSocket::Message> FeedSocket::read(std::chrono::milliseconds timeout) {
  State& s = *state_;
  bool done = false;
  std::optional<Message> message;
  s.buffer.clear();
  s.ws.async_read(s.buffer, [&](beast::error_code ec, std::size_t) {
    done = true;
    if (ec) {
      s.error = "read: " + ec.message();
      return;
    }
    message = Message{s.ws.got_binary(), beast::buffers_to_string(s.buffer.data())};
  });
  s.run(timeout, done);
  if (!done) {
    s.error = "no message in time";
    beast::get_lowest_layer(s.ws).cancel();
    s.run(std::chrono::seconds(1), done);
  }
  return message;
}

bool FeedSocket::write(const std::string& text, std::chrono::milliseconds timeout) {
  State& s = *state_;
  bool done = false;
  bool written = false;
  s.ws.text(true);
  s.ws.async_write(asio::buffer(text), [&](beast::error_code ec, std::size_t) {
    done = true;
    written = !ec;
    if (ec) s.error = "write: " + ec.message();
  });
  s.run(timeout, done);
  return written;
}

std::optional<FeedSocket::Message> FeedSocket::readMap(std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    std::optional<Message> message = read(timeout);
    if (!message) return std::nullopt;
    if (message->binary) return message;
  }
  return std::nullopt;
}

FeedSocket::Flood FeedSocket::flood(const std::string& message, int at_most,
                                    std::chrono::milliseconds duration) {
  State& s = *state_;
  Flood result;
  beast::error_code read_error;
  beast::flat_buffer buffer;
  s.ws.text(true);
  std::function<void()> writeMore = [&] {
    s.ws.async_write(asio::buffer(message), [&](beast::error_code ec, std::size_t) {
      if (ec) {
        result.write_failed = true;
        return;
      }
      if (++result.sent < at_most) writeMore();
    });
  };
  std::function<void()> readMore = [&] {
    s.ws.async_read(buffer, [&](beast::error_code ec, std::size_t) {
      buffer.clear();
      if (ec) {
        read_error = ec;
        return;
      }
      readMore();
    });
  };
  writeMore();
  readMore();
  s.io.restart();
  s.io.run_for(duration);
  if (read_error) result.read_error = read_error.message();
  result.closed = read_error == websocket::error::closed;
  if (result.closed) result.close_code = static_cast<int>(s.ws.reason().code);
  return result;
}

namespace {

// One client of FeedReaders.
struct FeedReader {
  websocket::stream<beast::tcp_stream> ws;
  beast::flat_buffer buffer;
  bool reading = true;
  bool connected = false;
  long maps = 0;
  std::string error;
  explicit FeedReader(asio::io_context& io) : ws(io) {}
};

}  // namespace

struct FeedReaders::State {
  asio::io_context io;
  std::vector<std::unique_ptr<FeedReader>> readers;
  std::function<void(FeedReader&)> read_on;
};

FeedReaders::FeedReaders(std::uint16_t port, int count) : state_(std::make_unique<State>()) {
  State& s = *state_;
  for (int k = 0; k < count; ++k) s.readers.push_back(std::make_unique<FeedReader>(s.io));
  FeedReader& stalled = *s.readers.front();
  stalled.reading = false;
  beast::error_code ignored;
  tcp::socket& stalled_socket = beast::get_lowest_layer(stalled.ws).socket();
  stalled_socket.open(tcp::v4(), ignored);
  stalled_socket.set_option(asio::socket_base::receive_buffer_size(4096), ignored);
  s.read_on = [&s](FeedReader& r) {
    r.ws.async_read(r.buffer, [&s, &r](beast::error_code ec, std::size_t) {
      if (ec) {
        r.error = ec.message();
        return;
      }
      if (r.ws.got_binary()) ++r.maps;
      r.buffer.clear();
      s.read_on(r);
    });
  };
  for (auto& reader : s.readers) {
    FeedReader& r = *reader;
    beast::get_lowest_layer(r.ws).async_connect(
        loopbackEndpoint(port), [&s, &r, port](beast::error_code ec) {
          if (ec) {
            r.error = ec.message();
            return;
          }
          r.ws.async_handshake("127.0.0.1:" + std::to_string(port), "/ws",
                               [&s, &r](beast::error_code shaken) {
                                 if (shaken) {
                                   r.error = shaken.message();
                                   return;
                                 }
                                 r.connected = true;
                                 if (r.reading) s.read_on(r);
                               });
        });
  }
}

FeedReaders::~FeedReaders() = default;

void FeedReaders::runFor(std::chrono::milliseconds duration) { state_->io.run_for(duration); }
std::size_t FeedReaders::size() const { return state_->readers.size(); }
bool FeedReaders::connected(std::size_t k) const { return state_->readers[k]->connected; }
long FeedReaders::maps(std::size_t k) const { return state_->readers[k]->maps; }
const std::string& FeedReaders::error(std::size_t k) const { return state_->readers[k]->error; }

}  // namespace occmap::testing
