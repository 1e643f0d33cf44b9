#pragma once

#include "config/config.h"

namespace occmap {

// occmapd as a merge node (a config with `merge:` instead of `cameras:`, docs/merge.md): the
// MergeNode on the config's LCM bus until SIGTERM or SIGINT (exit 0), with sd_notify READY=1 once
// subscribed, WATCHDOG=1 while the loop runs, STATUS= lines naming each input's state, and a
// warning in the log when an input's clock drifts more than 10 ms from the others'. `signal_fd`
// delivers SIGTERM, SIGINT and SIGHUP (a reload is not done by a merge node: it says so).
int runMergeDaemon(const Config& config, int signal_fd);

}  // namespace occmap
