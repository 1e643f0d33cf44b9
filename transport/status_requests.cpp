#include "transport/status_requests.h"

#include <algorithm>
#include <optional>

#include "transport/status_message.h"

namespace occmap {

StatusRequests::StatusRequests(double max_answers_per_s, std::int64_t now_ns)
    : max_per_s_(max_answers_per_s), tokens_(max_answers_per_s), last_refill_ns_(now_ns) {}

void StatusRequests::subscribe(Bus& bus, const std::string& status_channel) {
  bus.subscribe(
      statusRequestChannel(status_channel),
      [this](const std::uint8_t* data, std::size_t size, std::int64_t) { take(data, size); });
}

void StatusRequests::take(const std::uint8_t* data, std::size_t size) {
  // The same checked decode the status_request fuzz target runs.
  const std::optional<std::int64_t> request_id = decodeStatusRequest(data, size);
  if (!request_id || pending_count_ == kMaxPending) {
    ++ignored_;
    return;
  }
  pending_[pending_count_++] = *request_id;
}

void StatusRequests::refill(std::int64_t now_ns) {
  tokens_ = std::min(max_per_s_,
                     tokens_ + static_cast<double>(now_ns - last_refill_ns_) / 1e9 * max_per_s_);
  last_refill_ns_ = now_ns;
}

}  // namespace occmap
