#pragma once
// A short text that one thread writes on its rare error paths and others read (a camera's last
// error, for the status): a fixed buffer under a mutex, so neither side ever allocates. Longer
// texts are cut at the capacity.

#include <algorithm>
#include <cstdarg>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <string>
#include <string_view>

namespace occmap {

template <std::size_t Capacity>
class SharedText {
 public:
  void set(std::string_view text) {
    const std::lock_guard lock(mutex_);
    size_ = std::min(text.size(), Capacity);
    std::memcpy(text_, text.data(), size_);
  }
  // printf-style, cut at the capacity.
  void format(const char* format, ...) __attribute__((format(printf, 2, 3))) {
    char line[Capacity + 1];
    va_list arguments;
    va_start(arguments, format);
    const int written = std::vsnprintf(line, sizeof line, format, arguments);
    va_end(arguments);
    set(std::string_view(line,
                         written < 0 ? 0 : std::min(static_cast<std::size_t>(written), Capacity)));
  }
  // Into `out`, which allocates nothing once its capacity reaches Capacity (reserve it once).
  void copyTo(std::string& out) const {
    const std::lock_guard lock(mutex_);
    out.assign(text_, size_);
  }

 private:
  mutable std::mutex mutex_;
  char text_[Capacity] = {};
  std::size_t size_ = 0;
};

}  // namespace occmap
