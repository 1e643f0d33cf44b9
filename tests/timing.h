#pragma once
// What a test may promise about time. In the plain build a rate or a deadline is itself the
// promise a user relies on (30 maps a second, a stop within a second). Under a sanitizer the same
// code runs 5 to 20 times slower, more on a busy two-core machine, so there the tests check
// behaviour (order, content, states, nothing lost that was sent) and wait for what must happen
// eventually with deadlines stretched by kSlowdown; rates belong to the plain build and the
// benchmarks.
#include <chrono>

namespace occmap::testing {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kSanitized = true;
inline constexpr int kSlowdown = 6;
#else
inline constexpr bool kSanitized = false;
inline constexpr int kSlowdown = 1;
#endif


// A deadline for something that must happen eventually: as given in the plain build, kSlowdown
// times longer under a sanitizer.
template <typename Rep, typename Period>
constexpr auto eventually(std::chrono::duration<Rep, Period> plain) {
  return plain * kSlowdown;
}

}  // namespace occmap::testing
