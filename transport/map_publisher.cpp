#include "transport/map_publisher.h"

#include <cerrno>
#include <cstring>

#include "base/clock.h"
#include "base/log.h"

namespace occmap {

MapPublisher::MapPublisher(const MapGeometry& geometry,
                           const std::vector<std::string>& camera_names, MapEncoding encoding,
                           std::string channel, std::string where)
    : encoder_(geometry, camera_names, encoding),
      channel_(std::move(channel)),
      where_(std::move(where)) {}

bool MapPublisher::publish(Bus& bus, MapFrame& map) {
  map.seq = next_seq_++;
  const std::span<const std::uint8_t> message = encoder_.encode(map);
  if (!message.empty() && bus.publish(channel_, message)) {
    // Measured when the send has returned: the daemon's whole part of the frame's way.
    if (map.newest_arrival_ns != 0) latency_.record(monotonicNanoseconds() - map.newest_arrival_ns);
    published_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }
  const int error = errno;  // what the send left
  errors_.fetch_add(1, std::memory_order_relaxed);
  std::uint64_t suppressed = 0;
  if (warnings_.allow(suppressed)) {
    logLine(LogLevel::kWarning,
            "a map could not be sent on %s (%s; %llu more failures since): is the network "
            "down? Maps go out again as soon as it is back",
            where_.c_str(), message.empty() ? encoder_.lastError() : std::strerror(error),
            static_cast<unsigned long long>(suppressed));
  }
  return false;
}

}  // namespace occmap
