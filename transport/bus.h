#pragma once
// The message bus a program publishes on and listens to (after Drake's DrakeLcmInterface): raw
// bytes on named channels. Two implementations: LcmBus (transport/lcm_bus.h), the real one, and
// MemoryBus (transport/memory_bus.h), in memory, for tests that need no network and want to put
// faults in between. Messages are encoded and decoded by the caller (map_codec.h, the lcm-gen
// types), so that a publisher encodes into one reused buffer and a receiver checks what it decodes.
//
// Threads: a Bus is used from ONE thread, the one that publishes, calls handleTimeout() and so
// runs the handlers.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <utility>

namespace occmap {

class Bus {
 public:
  // A received message: the bytes as published, and when they were received (us since the Unix
  // epoch). The bytes are valid during the call only.
  using Handler =
      std::function<void(const std::uint8_t* data, std::size_t size, std::int64_t recv_utime)>;

  Bus() = default;
  virtual ~Bus() = default;
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  // Sends one message; false on any error, which the caller counts (a full socket buffer, no
  // route). Allocates nothing once warm: for the publisher's hot path.
  virtual bool publish(const std::string& channel, std::span<const std::uint8_t> message) = 0;
  // Calls `handler` for every message on `channel`; handlers run inside handleTimeout().
  virtual bool subscribe(const std::string& channel, Handler handler) = 0;
  // As subscribe(), for messages that come in bursts (a tiled map's tiles, back to back): up to
  // `queue_depth` of them wait for handleTimeout() before any is dropped. LCM's default depth, 30,
  // is fewer than one 2048 x 2048 map's 81 tiles, and LCM drops the rest without a word. A bus
  // that keeps no such queue subscribes as subscribe() does.
  virtual bool subscribeBursts(const std::string& channel, std::size_t queue_depth,
                               Handler handler) {
    (void)queue_depth;
    return subscribe(channel, std::move(handler));
  }
  // A file descriptor that becomes readable when a message is waiting (for poll()), or -1.
  virtual int fileno() = 0;
  // Waits up to `timeout_ms` for a message and dispatches it: > 0 handled, 0 timed out, < 0 error.
  virtual int handleTimeout(int timeout_ms) = 0;
};

// Where status requests go: the status channel's name + "_REQUEST" (lcmtypes/status_request_t.lcm).
std::string statusRequestChannel(const std::string& status_channel);
// Where occmapd publishes lighting_status_t, with each status_t: the status channel's name +
// "_LIGHTING" (OCCMAP_STATUS_LIGHTING by default).
std::string lightingStatusChannel(const std::string& status_channel);
// Where occmapd publishes view_status_t, with each status_t: the status channel's name + "_VIEW"
// (OCCMAP_STATUS_VIEW by default).
std::string viewStatusChannel(const std::string& status_channel);

}  // namespace occmap
