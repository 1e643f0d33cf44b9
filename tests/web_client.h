#pragma once
// The HTTP and WebSocket client of the tests of `occmap web` (web_server_test, web_browser_test),
// each operation with a deadline (a server that does not answer fails the test, it does not hang
// it). Made of Boost.Beast in web_client.cpp, compiled once into occmap_web_test_client: this
// header names no Boost type, so that Beast's templates are instantiated in one object instead of
// in each test (CPU to compile in the plain build: web_server_test.cpp 47 s and
// web_browser_test.cpp 36 s with the client in a header; now 10 s and 9 s, and web_client.cpp 33
// s).

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "timing.h"

namespace occmap::testing {

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

enum class HttpMethod { kGet, kHead, kPost, kDelete };

// One request to 127.0.0.1:`port` on a connection of its own.
HttpAnswer httpRequest(std::uint16_t port, const std::string& target,
                       HttpMethod method = HttpMethod::kGet,
                       const std::vector<std::pair<std::string, std::string>>& headers = {},
                       std::chrono::milliseconds timeout = eventually(std::chrono::seconds(10)));

// Sends `bytes` as they are and returns what came back before the server closed the connection
// (or the timeout passed).
std::string rawExchange(std::uint16_t port, const std::string& bytes,
                        std::chrono::milliseconds timeout = eventually(std::chrono::seconds(10)));

// WebSocket's close code for a policy violation (RFC 6455, 7.4.1).
inline constexpr int kPolicyErrorCloseCode = 1008;

// A WebSocket client, one operation at a time, each with a deadline: of the feed (/ws), or of
// Chromium's DevTools.
class FeedSocket {
 public:
  struct Message {
    bool binary = false;
    std::string data;
  };

  explicit FeedSocket(std::uint16_t port, const std::string& origin = "",
                      const std::string& target = "/ws");
  ~FeedSocket();
  FeedSocket(const FeedSocket&) = delete;
  FeedSocket& operator=(const FeedSocket&) = delete;

  bool connected() const;
  const std::string& error() const;
  // The upgrade's answer (101, or the refusal's status).
  int handshakeStatus() const;

  // The next message, or nothing (closed, failed, or none within `timeout`: error() says).
  std::optional<Message> read(
      std::chrono::milliseconds timeout = eventually(std::chrono::seconds(5)));
  // Sends a text message; false (error() says why) when it could not.
  bool write(const std::string& text,
             std::chrono::milliseconds timeout = eventually(std::chrono::seconds(5)));
  // The next binary message (a map), skipping text.
  std::optional<Message> readMap(
      std::chrono::milliseconds timeout = eventually(std::chrono::seconds(5)));

  // What flood() saw.
  struct Flood {
    int sent = 0;               // messages written before the connection failed or the end
    bool write_failed = false;  // a write failed
    bool closed = false;        // the server closed the WebSocket (a close frame came)
    int close_code = 0;         // its close code, when closed
    std::string read_error;     // why reading ended ("" when it did not)
  };
  // Writes `message` (text) back to back, up to `at_most` times, while reading whatever comes,
  // for at most `duration`.
  Flood flood(const std::string& message, int at_most, std::chrono::milliseconds duration);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// `count` clients of the feed (/ws) on 127.0.0.1:`port`, served by one thread (the caller's, in
// runFor), each counting the binary messages (maps) it reads; the first never reads, and its
// socket takes almost nothing in (a 4 KiB receive buffer), so that the server's writes to it stop
// within a second and everything after waits in the server.
class FeedReaders {
 public:
  FeedReaders(std::uint16_t port, int count);
  ~FeedReaders();
  FeedReaders(const FeedReaders&) = delete;
  FeedReaders& operator=(const FeedReaders&) = delete;

  // Connects (the first call), reads and counts, for `duration`.
  void runFor(std::chrono::milliseconds duration);
  std::size_t size() const;
  bool connected(std::size_t k) const;
  long maps(std::size_t k) const;
  const std::string& error(std::size_t k) const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace occmap::testing
