#pragma once

// The exit codes of occmapd and occmap, documented for users and for the unit's
// RestartPreventExitStatus= (restarting cannot fix a bad config, so systemd must not try).
namespace occmap {

inline constexpr int kExitOk = 0;
// Something failed at run time (a device, the network, a file system); a restart may help.
inline constexpr int kExitFailure = 1;
// The config or a calibration file is invalid (InputError): the message names the file and line.
inline constexpr int kExitInvalidInput = 2;
// The run ended without producing what was asked (for example no map frame, or no status answer).
inline constexpr int kExitNoResult = 3;

}  // namespace occmap
