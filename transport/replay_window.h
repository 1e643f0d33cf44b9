#pragma once
// The replay window of control requests (docs/control.md): a request is taken only when its
// sender's clock (utime) is within +-window of the daemon's, and only once: the (utime, nonce)
// pairs seen are kept until they leave the window, after which a copy is refused by its utime
// alone. The memory is a fixed number of pairs, reserved up front; when every one is still in the
// window a new request is refused rather than an old pair forgotten (which would let its copy
// through). One thread only (occmapd's LCM thread); allocates nothing after construction.

#include <climits>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace occmap {

class ReplayWindow {
 public:
  enum class Verdict { kFresh, kOutsideWindow, kReplayed, kFull };

  ReplayWindow(std::int64_t window_us, std::size_t capacity) : window_us_(window_us) {
    seen_.reserve(capacity);
  }

  // Whether a request made at `utime` (the sender's clock) with `nonce` may be taken now
  // (`now_us`, the daemon's clock); a fresh one is remembered.
  Verdict admit(std::int64_t utime, std::int64_t nonce, std::int64_t now_us) {
    // utime comes from the network: compared, never subtracted; the bounds saturate.
    std::int64_t earliest = 0, latest = 0;
    if (__builtin_sub_overflow(now_us, window_us_, &earliest)) earliest = INT64_MIN;
    if (__builtin_add_overflow(now_us, window_us_, &latest)) latest = INT64_MAX;
    if (utime < earliest || utime > latest) return Verdict::kOutsideWindow;
    for (std::size_t i = 0; i < seen_.size();) {
      if (seen_[i].utime < earliest) {
        // Out of the window: its copy would be refused by its utime, so it can go.
        seen_[i] = seen_.back();
        seen_.pop_back();
        continue;
      }
      if (seen_[i].utime == utime && seen_[i].nonce == nonce) return Verdict::kReplayed;
      ++i;
    }
    if (seen_.size() == seen_.capacity()) return Verdict::kFull;
    seen_.push_back({utime, nonce});
    return Verdict::kFresh;
  }

  std::size_t remembered() const { return seen_.size(); }

 private:
  struct Seen {
    std::int64_t utime;
    std::int64_t nonce;
  };
  std::int64_t window_us_;
  std::vector<Seen> seen_;
};

}  // namespace occmap
