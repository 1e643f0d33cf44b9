#include "base/format_text.h"

#include <cstdarg>
#include <cstdio>

namespace occmap {

std::string formatText(const char* pattern, ...) {
  char text[512];
  va_list arguments;
  va_start(arguments, pattern);
  va_list again;
  va_copy(again, arguments);
  const int length = std::vsnprintf(text, sizeof text, pattern, arguments);
  va_end(arguments);
  std::string result;
  if (length >= static_cast<int>(sizeof text)) {
    result.resize(static_cast<std::size_t>(length) + 1);
    std::vsnprintf(result.data(), result.size(), pattern, again);
    result.resize(static_cast<std::size_t>(length));
  } else if (length > 0) {
    result.assign(text, static_cast<std::size_t>(length));
  }
  va_end(again);
  return result;
}

}  // namespace occmap
