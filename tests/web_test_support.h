#pragma once
// What the tests of `occmap web` share (web_server_test, web_browser_test): occmapd on the
// simulated room and `occmap web` as processes in the test's private network, and an HTTP and
// WebSocket client made of Boost.Beast, each operation with a deadline (a server that does not
// answer fails the test, it does not hang it).

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include "child_process.h"
#include "notify_listener.h"
#include "sim_room_config.h"
#include "temporary_folder.h"
#include "timing.h"

namespace occmap::testing {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using namespace std::chrono_literals;

inline const std::string kOccmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
inline const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";
inline const std::string kLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

// The simulated room (tests/sim_room_config.h: four cameras, 256 x 256 cells of 4 cm) on UDP
// multicast, with a zone; `extra_cameras` are more lines of the cameras list.
inline std::string webRoomConfig(const std::string& extra_cameras = "") {
  std::string config = simRoomConfig(kLcmUrl);
  config.insert(config.find("cameras:"),
                "zones: [{name: walkway, polygon_m: [[1, 1], [3, 1], [3, 3], [1, 3]]}]\n");
  return config + extra_cameras;
}

// occmapd started in this process's network (as network_test's RunningDaemon).
struct WebTestDaemon {
  std::optional<NotifyListener> systemd;
  ChildProcess process;
  // `name` names its files in `folder`: the config (unless `config_name` does), its output.
  WebTestDaemon(const TemporaryFolder& folder, const std::string& config, const std::string& name,
                const std::string& config_name = "")
      : systemd(std::in_place, folder / (name + ".notify")),
        process(
            {kOccmapd, "--config",
             folder.write((config_name.empty() ? name : config_name) + ".yaml", config).string()},
            folder / name, {{"NOTIFY_SOCKET", (folder / (name + ".notify")).string()}}) {}
  // Waits for READY=1 (every camera streaming), then stops listening (a notify socket nobody
  // reads would block the daemon's sd_notify).
  bool ready() {
    const bool ready = systemd->collect(eventually(30s), "READY=1");
    systemd.reset();
    return ready;
  }
  int stop() {
    process.signal(SIGTERM);
    return process.waitExit(eventually(5s)).value_or(-100);
  }
};

// `occmap web` started in this process's network, on 127.0.0.1 and the port given (0: any).
struct WebProcess {
  ChildProcess process;
  std::uint16_t port = 0;
  WebProcess(const TemporaryFolder& folder, const std::string& name, std::uint16_t listen_port = 0)
      : process({kOccmap, "web", "--lcm-url", kLcmUrl, "--listen",
                 "127.0.0.1:" + std::to_string(listen_port)},
                folder / name) {}
  // Waits for "serving http://127.0.0.1:PORT/" and takes the port.
  bool serving() {
    const std::string said = "occmap web: serving http://127.0.0.1:";
    if (!process.waitForOutput(said, eventually(10s))) return false;
    const std::string out = process.out();
    port = static_cast<std::uint16_t>(std::stoi(out.substr(out.find(said) + said.size())));
    return port != 0;
  }
  int stop() {
    process.signal(SIGTERM);
    return process.waitExit(eventually(5s)).value_or(-100);
  }
};

// A process's resident memory, KiB (0 when it cannot be read).
inline long residentKiB(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.starts_with("VmRSS:")) return std::atol(line.c_str() + 6);
  }
  return 0;
}

inline tcp::endpoint loopback(std::uint16_t port) {
  return {asio::ip::make_address("127.0.0.1"), port};
}

struct HttpAnswer {
  int status = 0;  // 0: no answer (then `error` says why)
  std::string error;
  std::map<std::string, std::string> headers;  // names in lower case
  std::string body;

  std::string header(const std::string& name) const {
    const auto found = headers.find(name);
    return found == headers.end() ? "" : found->second;
  }
};

// One request on a connection of its own.
inline HttpAnswer httpRequest(std::uint16_t port, const std::string& target,
                              http::verb method = http::verb::get,
                              const std::vector<std::pair<std::string, std::string>>& headers = {},
                              std::chrono::milliseconds timeout = eventually(10s)) {
  asio::io_context io;
  beast::tcp_stream stream(io);
  HttpAnswer answer;
  http::request<http::string_body> request{method, target, 11};
  request.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  for (const auto& [name, value] : headers) request.set(name, value);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(64 << 20);
  if (method == http::verb::head) parser.skip(true);
  stream.expires_after(timeout);
  stream.async_connect(loopback(port), [&](beast::error_code ec) {
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

// Sends `bytes` as they are and returns what came back before the server closed the connection
// (or the timeout passed).
inline std::string rawExchange(std::uint16_t port, const std::string& bytes,
                               std::chrono::milliseconds timeout = eventually(10s)) {
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
  stream.async_connect(loopback(port), [&](beast::error_code ec) {
    if (ec) return;
    readMore();
    asio::async_write(stream, asio::buffer(bytes), [](beast::error_code, std::size_t) {});
  });
  io.run();
  return received;
}

// A WebSocket client, one operation at a time, each with a deadline: of the feed (/ws), or of
// Chromium's DevTools.
class FeedSocket {
 public:
  struct Message {
    bool binary = false;
    std::string data;
  };

  explicit FeedSocket(std::uint16_t port, const std::string& origin = "",
                      const std::string& target = "/ws")
      : ws_(io_) {
    bool done = false;
    beast::get_lowest_layer(ws_).expires_after(eventually(10s));
    beast::get_lowest_layer(ws_).async_connect(loopback(port), [&](beast::error_code ec) {
      if (ec) {
        error_ = "connect: " + ec.message();
        done = true;
        return;
      }
      beast::get_lowest_layer(ws_).expires_never();
      ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::client));
      ws_.set_option(websocket::stream_base::decorator([origin](websocket::request_type& r) {
        if (!origin.empty()) r.set(http::field::origin, origin);
      }));
      ws_.async_handshake(response_, "127.0.0.1:" + std::to_string(port), target,
                          [&](beast::error_code shaken) {
                            if (shaken) error_ = "handshake: " + shaken.message();
                            done = true;
                          });
    });
    run(eventually(10s), done);
    if (!done) error_ = "no handshake in time";
  }

  bool connected() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  // The upgrade's answer (101, or the refusal's status).
  int handshakeStatus() const { return static_cast<int>(response_.result_int()); }
  websocket::stream<beast::tcp_stream>& ws() { return ws_; }
  asio::io_context& io() { return io_; }

  // The next message, or nothing (closed, failed, or none within `timeout`: error() says).
  std::optional<Message> read(std::chrono::milliseconds timeout = eventually(5s)) {
    bool done = false;
    std::optional<Message> message;
    buffer_.clear();
    ws_.async_read(buffer_, [&](beast::error_code ec, std::size_t) {
      done = true;
      if (ec) {
        error_ = "read: " + ec.message();
        return;
      }
      message = Message{ws_.got_binary(), beast::buffers_to_string(buffer_.data())};
    });
    run(timeout, done);
    if (!done) {
      error_ = "no message in time";
      beast::get_lowest_layer(ws_).cancel();
      run(1s, done);
    }
    return message;
  }

  // Sends a text message; false (error() says why) when it could not.
  bool write(const std::string& text, std::chrono::milliseconds timeout = eventually(5s)) {
    bool done = false;
    bool written = false;
    ws_.text(true);
    ws_.async_write(asio::buffer(text), [&](beast::error_code ec, std::size_t) {
      done = true;
      written = !ec;
      if (ec) error_ = "write: " + ec.message();
    });
    run(timeout, done);
    return written;
  }

  // The next binary message (a map), skipping text.
  std::optional<Message> readMap(std::chrono::milliseconds timeout = eventually(5s)) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      std::optional<Message> message = read(timeout);
      if (!message) return std::nullopt;
      if (message->binary) return message;
    }
    return std::nullopt;
  }

 private:
  void run(std::chrono::milliseconds timeout, const bool& done) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    io_.restart();
    while (!done && std::chrono::steady_clock::now() < end) {
      io_.run_for(std::chrono::milliseconds(20));
      if (io_.stopped()) io_.restart();
    }
  }

  asio::io_context io_;
  websocket::stream<beast::tcp_stream> ws_;
  websocket::response_type response_;
  beast::flat_buffer buffer_;
  std::string error_;
};

}  // namespace occmap::testing
