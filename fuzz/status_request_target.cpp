// status_request: a status_request_t as occmapd's LCM thread reads it from the request channel
// (transport/status_message.h, decodeStatusRequest; the daemon answers with the request's id).
#include <algorithm>
#include <vector>

#include <occmap/status_request_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/status_message.h"

namespace occmap::fuzz {

bool fuzzStatusRequest(Input input) {
  const std::optional<std::int64_t> request_id = decodeStatusRequest(input.data(), input.size());
  if (!request_id) return false;  // ignored and counted by the daemon
  // Accepted means exactly one status_request_t: encoded again, it is the same bytes.
  occmap::status_request_t request{};
  require(request.decode(input.data(), 0, static_cast<int>(input.size())) ==
              static_cast<int>(input.size()),
          "an accepted request is one whole status_request_t");
  require(request.request_id == *request_id, "the id answered is the request's");
  std::vector<std::uint8_t> again(static_cast<std::size_t>(request.getEncodedSize()));
  request.encode(again.data(), 0, static_cast<int>(again.size()));
  require(std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted request encodes back to the bytes received");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzStatusRequest)
