#pragma once
// The one LCM handle of a program, for one URL: the real Bus (transport/bus.h).
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

#include "transport/bus.h"

namespace lcm {
class LCM;
}

namespace occmap {

class LcmBus final : public Bus {
 public:
  // recv_utime: for udpm the kernel's receive time of the first datagram.
  using Handler = Bus::Handler;

  // Opens LCM for `url` ("udpm://239.255.76.67:7667?ttl=0", "file:///tmp/log?mode=w", "memq://";
  // "" is LCM's default: $LCM_DEFAULT_URL, else udpm://239.255.76.67:7667?ttl=0). Check good().
  explicit LcmBus(const std::string& url);
  ~LcmBus() override;
  // Opened and good, or std::runtime_error saying what to check: for a program that can do
  // nothing without its bus (occmapd, the benchmarks).
  static std::unique_ptr<LcmBus> open(const std::string& url);

  // Whether LCM could be opened for the URL (a bad URL, a socket that cannot be made: false).
  bool good() const;
  const std::string& url() const { return url_; }

  // Sends one message; false on any error, which the caller counts (a full socket buffer, no
  // route). Allocates nothing: for the publisher's hot path.
  bool publish(const std::string& channel, std::span<const std::uint8_t> message) override;

  // Calls `handler` for every message on `channel` (LCM matches it as a regular expression over
  // the whole channel name; a plain name matches itself). Handlers run inside handleTimeout().
  bool subscribe(const std::string& channel, Handler handler) override;
  bool subscribeBursts(const std::string& channel, std::size_t queue_depth,
                       Handler handler) override;

  // A file descriptor that becomes readable when a message is waiting (for poll()), or -1.
  int fileno() override;
  // Waits up to `timeout_ms` for a message and dispatches it: > 0 handled, 0 timed out, < 0 error.
  int handleTimeout(int timeout_ms) override;

 private:
  std::string url_;
  // LCM holds pointers to these; declared before lcm_, so destroyed after it.
  std::vector<std::unique_ptr<Handler>> handlers_;
  std::unique_ptr<lcm::LCM> lcm_;
};

}  // namespace occmap
