#pragma once

#include <atomic>
#include <chrono>
#include <cstdarg>
#include <cstdint>

namespace occmap {

// occmapd's log: one line per event on stderr. Under systemd (stderr connected to the journal, as
// JOURNAL_STREAM says) each line starts with its syslog priority, "<4>", which the journal turns
// into the entry's level; elsewhere it reads "occmapd: warning: ...". Thread-safe: one write(2) per
// line.
enum class LogLevel { kError = 3, kWarning = 4, kNotice = 5, kInfo = 6, kDebug = 7 };

void logLine(LogLevel level, const char* format, ...) __attribute__((format(printf, 2, 3)));

// Lets a repeated warning through at most once per interval and counts what it held back, so a
// camera dropping frames at 60 Hz writes one line every ten seconds, not sixty a second.
// Lock-free: safe to share between threads, cheap enough for the hot path.
class RateLimit {
 public:
  explicit RateLimit(std::chrono::nanoseconds interval) : interval_ns_(interval.count()) {}
  // True when a line may be written now; `suppressed` then holds how many were held back since.
  bool allow(std::uint64_t& suppressed);

 private:
  std::int64_t interval_ns_;
  std::atomic<std::int64_t> next_ns_{0};
  std::atomic<std::uint64_t> held_{0};
};

}  // namespace occmap
