#pragma once
// When occmapd may tell systemd's watchdog that it is alive: only when fusion made a map AND the
// publisher thread went round since the last look. A stalled fusion or a publisher stuck in a call
// stops the pings, and systemd restarts the service after WatchdogSec=. (A network that is down is
// not a stall: publishing goes on failing, counted, and the pings go on.)

#include <cstdint>

namespace occmap {

class Liveness {
 public:
  // The counters as they are now; true when both moved since the last time this said true.
  bool alive(std::uint64_t maps_fused, std::uint64_t publisher_rounds) {
    if (maps_fused == last_maps_ || publisher_rounds == last_rounds_) return false;
    last_maps_ = maps_fused;
    last_rounds_ = publisher_rounds;
    return true;
  }

 private:
  std::uint64_t last_maps_ = 0;
  std::uint64_t last_rounds_ = 0;
};

}  // namespace occmap
