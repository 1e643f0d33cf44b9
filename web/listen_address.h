#pragma once
// Where `occmap web` listens (--listen): "127.0.0.1:8080", "[::1]:8080", "0.0.0.0:8080",
// "localhost:8080"; port 0 takes a free port (the server says which).

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace occmap::web {

struct ListenAddress {
  std::string host;  // an IPv4 or IPv6 address ("localhost" becomes 127.0.0.1)
  std::uint16_t port = 0;
};

// The address of "HOST:PORT", or nothing, with `error` saying what is wrong.
std::optional<ListenAddress> parseListenAddress(std::string_view text, std::string& error);

// Whether `host` (an address as parseListenAddress gives it) is a loopback address: then the
// server answers only requests whose Host header names the loopback (docs/web.md).
bool isLoopbackAddress(const std::string& host);

}  // namespace occmap::web
