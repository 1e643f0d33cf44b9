#pragma once
// Status requests (status_request_t on the status channel + "_REQUEST"): anyone on the network may
// send them, so they are only queued as they arrive (a bounded queue: a flood is shed, counted)
// and answered at a bounded rate (a token bucket), so that answering never takes the map's
// bandwidth. Time is an argument: tests drive the rate by hand.
// Threads: the bus's thread only. Allocates nothing after construction.

#include <cstddef>
#include <cstdint>
#include <string>

#include "transport/bus.h"

namespace occmap {

class StatusRequests {
 public:
  StatusRequests(double max_answers_per_s, std::int64_t now_ns);

  // Listens for requests on `bus` (the request channel of `status_channel`). `this` must outlive
  // the bus's handling.
  void subscribe(Bus& bus, const std::string& status_channel);
  // One message from the request channel.
  void take(const std::uint8_t* data, std::size_t size);

  // Calls answer(request_id) for every waiting request the rate allows at `now_ns`, oldest first;
  // the rest wait for the next call.
  template <typename Answer>
  void answer(std::int64_t now_ns, Answer&& answer) {
    refill(now_ns);
    std::size_t answered = 0;
    while (answered < pending_count_ && tokens_ >= 1.0) {
      answer(pending_[answered++]);
      tokens_ -= 1.0;
    }
    for (std::size_t i = answered; i < pending_count_; ++i) pending_[i - answered] = pending_[i];
    pending_count_ -= answered;
  }

  std::size_t waiting() const { return pending_count_; }
  // Malformed requests, and requests shed because the queue was full.
  std::uint64_t ignored() const { return ignored_; }

  static constexpr std::size_t kMaxPending = 16;

 private:
  void refill(std::int64_t now_ns);

  double max_per_s_;
  double tokens_;
  std::int64_t last_refill_ns_;
  std::int64_t pending_[kMaxPending] = {};
  std::size_t pending_count_ = 0;
  std::uint64_t ignored_ = 0;
};

}  // namespace occmap
