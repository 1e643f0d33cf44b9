#include "base/rate_limit.h"

#include "base/clock.h"

namespace occmap {

bool RateLimit::allow(std::int64_t now, std::uint64_t& suppressed) {
  std::int64_t next = next_ns_.load(std::memory_order_relaxed);
  if (now < next ||
      !next_ns_.compare_exchange_strong(next, now + interval_ns_, std::memory_order_relaxed)) {
    held_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  suppressed = held_.exchange(0, std::memory_order_relaxed);
  return true;
}

bool RateLimit::allow(std::uint64_t& suppressed) {
  return allow(monotonicNanoseconds(), suppressed);
}

}  // namespace occmap
