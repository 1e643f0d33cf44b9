#include "capture/frame_source.h"

#include <chrono>

namespace occmap {

std::int64_t hostTimeMicroseconds() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace occmap
