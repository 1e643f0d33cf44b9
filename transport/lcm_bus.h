#pragma once
// The one LCM handle of a program, for one URL: publish raw bytes, subscribe to raw bytes.
// Messages are encoded and decoded by the caller (map_codec.h, or the lcm-gen types), so that the
// publisher encodes into one reused buffer and a receiver checks what it decodes.
//
// Threads: an LcmBus is used from ONE thread only, the one that publishes, calls handleTimeout()
// and so runs the handlers (occmapd's publisher thread; the main thread of `occmap view`). LCM's
// own receive thread (udpm) only queues messages; nothing here is safe to call from two threads.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace lcm {
class LCM;
}

namespace occmap {

// Where status requests go: the status channel's name + "_REQUEST" (lcmtypes/status_request_t.lcm).
std::string statusRequestChannel(const std::string& status_channel);

class LcmBus {
 public:
  // A received message: the bytes as published, and when LCM received them (us since the Unix
  // epoch; for udpm the kernel's receive time of the first datagram). The bytes are valid during
  // the call only.
  using Handler =
      std::function<void(const std::uint8_t* data, std::size_t size, std::int64_t recv_utime)>;

  // Opens LCM for `url` ("udpm://239.255.76.67:7667?ttl=0", "file:///tmp/log?mode=w", "memq://";
  // "" is LCM's default: $LCM_DEFAULT_URL, else udpm://239.255.76.67:7667?ttl=0). Check good().
  explicit LcmBus(const std::string& url);
  ~LcmBus();
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  // Whether LCM could be opened for the URL (a bad URL, a socket that cannot be made: false).
  bool good() const;
  const std::string& url() const { return url_; }

  // Sends one message; false on any error, which the caller counts (a full socket buffer, no
  // route). Allocates nothing: for the publisher's hot path.
  bool publish(const std::string& channel, std::span<const std::uint8_t> message);

  // Calls `handler` for every message on `channel` (LCM matches it as a regular expression over
  // the whole channel name; a plain name matches itself). Handlers run inside handleTimeout().
  bool subscribe(const std::string& channel, Handler handler);

  // A file descriptor that becomes readable when a message is waiting (for poll()), or -1.
  int fileno();
  // Waits up to `timeout_ms` for a message and dispatches it: > 0 handled, 0 timed out, < 0 error.
  int handleTimeout(int timeout_ms);

 private:
  std::string url_;
  // LCM holds pointers to these; declared before lcm_, so destroyed after it.
  std::vector<std::unique_ptr<Handler>> handlers_;
  std::unique_ptr<lcm::LCM> lcm_;
};

}  // namespace occmap
