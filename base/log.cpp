#include "base/log.h"

#include <cstdio>
#include <cstdlib>
#include <ctime>

#include <sys/stat.h>
#include <unistd.h>

namespace occmap {
namespace {

// Whether stderr is the journal's stream: JOURNAL_STREAM holds "device:inode" of that socket.
bool stderrIsJournal() {
  const char* stream = std::getenv("JOURNAL_STREAM");
  if (stream == nullptr) return false;
  struct stat st {};
  if (::fstat(STDERR_FILENO, &st) != 0) return false;
  unsigned long long device = 0, inode = 0;
  if (std::sscanf(stream, "%llu:%llu", &device, &inode) != 2) return false;
  return device == st.st_dev && inode == st.st_ino;
}

const char* levelName(LogLevel level) {
  switch (level) {
    case LogLevel::kError:
      return "error";
    case LogLevel::kWarning:
      return "warning";
    case LogLevel::kNotice:
      return "notice";
    case LogLevel::kInfo:
      return "info";
    case LogLevel::kDebug:
      return "debug";
  }
  return "?";
}

}  // namespace

void logLine(LogLevel level, const char* format, ...) {
  static const bool journal = stderrIsJournal();
  char line[1024];
  int used = journal ? std::snprintf(line, sizeof line, "<%d>", static_cast<int>(level))
                     : std::snprintf(line, sizeof line, "occmapd: %s: ", levelName(level));
  va_list arguments;
  va_start(arguments, format);
  const int message = std::vsnprintf(line + used, sizeof line - static_cast<std::size_t>(used) - 1,
                                     format, arguments);
  va_end(arguments);
  used += message < 0 ? 0 : message;
  if (used > static_cast<int>(sizeof line) - 2) used = static_cast<int>(sizeof line) - 2;
  line[used++] = '\n';
  // One write per line so that threads never interleave inside a line.
  [[maybe_unused]] const ssize_t written =
      ::write(STDERR_FILENO, line, static_cast<std::size_t>(used));
}

}  // namespace occmap
