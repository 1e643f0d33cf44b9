#pragma once

#include <cstdarg>

#include "base/rate_limit.h"  // what every caller of logLine uses with it

namespace occmap {

// occmapd's log: one line per event on stderr. Under systemd (stderr connected to the journal, as
// JOURNAL_STREAM says) each line starts with its syslog priority, "<4>", which the journal turns
// into the entry's level; elsewhere it reads "occmapd: warning: ...". Thread-safe: one write(2) per
// line.
enum class LogLevel { kError = 3, kWarning = 4, kNotice = 5, kInfo = 6, kDebug = 7 };

void logLine(LogLevel level, const char* format, ...) __attribute__((format(printf, 2, 3)));

}  // namespace occmap
