#pragma once
// The two clocks occmap reads. Policies never call these: they take `now` as an argument (core/),
// so that tests drive time by hand; only the threads that run them read the clock.

#include <cstdint>

namespace occmap {

// The host's wall clock in microseconds since the Unix epoch, as LCM's utime has it.
std::int64_t hostTimeMicroseconds();
// CLOCK_MONOTONIC in nanoseconds: for waits and ages, which must not jump with the wall clock.
// std::chrono::steady_clock is the same clock on Linux (libstdc++).
std::int64_t monotonicNanoseconds();
// Sleeps until CLOCK_MONOTONIC reaches `monotonic_ns` (through signals).
void sleepUntil(std::int64_t monotonic_ns);

}  // namespace occmap
