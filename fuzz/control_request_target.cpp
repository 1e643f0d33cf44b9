// control_request: a control_request_t as occmapd's LCM thread reads it from the control channel
// (daemon/remote_control.cpp): the layout walked (transport/control_message.h), the mac checked
// under a key (the seeds are signed with controlFuzzKey()), the replay window asked.
#include <algorithm>
#include <cstring>
#include <vector>

#include <occmap/control_request_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/control_message.h"
#include "transport/replay_window.h"

namespace occmap::fuzz {

bool fuzzControlRequest(Input input) {
  const char* why = nullptr;
  const std::optional<ControlRequestFields> fields =
      parseControlRequest(input.data(), input.size(), &why);
  if (!fields) {
    require(why != nullptr && *why != '\0', "a refused request says why");
    return false;  // ignored and counted as malformed by the daemon
  }
  require(input.size() <= kMaxControlRequestBytes, "an accepted request is not oversized");
  require(fields->command.size() <= kMaxControlCommandLength &&
              fields->camera.size() <= kMaxControlCameraLength,
          "an accepted request's texts are within their bounds");
  require(std::memchr(fields->camera.data(), 0, fields->camera.size()) == nullptr,
          "an accepted camera name holds no NUL");
  // Accepted means exactly one control_request_t, read as LCM's own decoder reads it.
  occmap::control_request_t request{};
  require(request.decode(input.data(), 0, static_cast<int>(input.size())) ==
              static_cast<int>(input.size()),
          "an accepted request is one whole control_request_t");
  require(request.request_id == fields->request_id && request.utime == fields->utime &&
              request.nonce == fields->nonce && request.command == fields->command &&
              request.camera == fields->camera && request.value == fields->value,
          "the fields read are LCM's");
  // The mac covers every byte before it: signed again under the same key, a request whose mac
  // held is the same bytes, and one whose mac did not hold is not.
  const bool authentic = controlMacMatches(controlFuzzKey(), input.data(), input.size());
  const std::vector<std::uint8_t> signed_again = encodeControlRequest(controlFuzzKey(), request);
  require(
      authentic == std::equal(signed_again.begin(), signed_again.end(), input.begin(), input.end()),
      "the mac holds exactly for the bytes the key signs");
  // The replay window takes a request once, whatever its utime and nonce (no overflow either).
  ReplayWindow window(30'000'000, 4);
  const ReplayWindow::Verdict first = window.admit(fields->utime, fields->nonce, fields->utime);
  require(first == ReplayWindow::Verdict::kFresh, "a request made now is fresh");
  require(
      window.admit(fields->utime, fields->nonce, fields->utime) == ReplayWindow::Verdict::kReplayed,
      "the same request again is a replay");
  const std::int64_t now = 1'700'000'000'000'000;
  const ReplayWindow::Verdict there = window.admit(fields->utime, fields->nonce, now);
  require(there != ReplayWindow::Verdict::kFresh ||
              (fields->utime >= now - 30'000'000 && fields->utime <= now + 30'000'000),
          "only a utime within the window is fresh");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzControlRequest)
