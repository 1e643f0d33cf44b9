#pragma once
// The fusion's maps onto the bus: each numbered as it is sent (so a gap a subscriber sees is a map
// lost on the way), encoded into one reused buffer (map_codec.h) and published; what failed is
// counted and said now and then. On the publisher thread's hot path: allocates nothing.

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "base/rate_limit.h"
#include "base/time_histogram.h"
#include "core/map_frame.h"
#include "transport/bus.h"
#include "transport/map_codec.h"

namespace occmap {

class MapPublisher {
 public:
  // `where` names the bus in warnings (the LCM URL).
  MapPublisher(const MapGeometry& geometry, const std::vector<std::string>& camera_names,
               MapEncoding encoding, std::string channel, std::string where);

  // Numbers, encodes and sends `map`. False when it could not be encoded or sent (counted in
  // errors(), said at most every ten seconds).
  bool publish(Bus& bus, MapFrame& map);

  // Any thread.
  std::uint64_t published() const { return published_.load(std::memory_order_relaxed); }
  std::uint64_t errors() const { return errors_.load(std::memory_order_relaxed); }
  // From the arrival of a map's newest frame to the return of its publish: what the daemon adds
  // to a frame's way to the network.
  const TimeHistogram& latency() const { return latency_; }

 private:
  MapEncoder encoder_;
  std::string channel_;
  std::string where_;
  std::int64_t next_seq_ = 0;
  RateLimit warnings_{std::chrono::seconds(10)};
  TimeHistogram latency_;
  std::atomic<std::uint64_t> published_{0};
  std::atomic<std::uint64_t> errors_{0};
};

}  // namespace occmap
