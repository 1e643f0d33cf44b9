#pragma once
// A merge node's status (merge_status_t, lcmtypes/merge_status_t.lcm) as it travels: the channel it
// goes on, and the decoder that `occmap status` reads it with. Anyone on the network segment can
// publish it, so it is walked field by field and every count and string checked against the bytes
// received before LCM's generated decoder (which trusts them) sees it, as status_message.h does
// for status_t. No exception leaves.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include <occmap/merge_status_t.hpp>

namespace occmap {

// Where a merge node publishes merge_status_t: the status channel's name + "_MERGE"
// (OCCMAP_STATUS_MERGE by default). It answers the status_request_t of the status channel's name +
// "_REQUEST", as a camera PC's occmapd does with a status_t on the status channel itself.
std::string mergeStatusChannel(const std::string& status_channel);

// A merge_status_t, or nothing when the bytes are not exactly one (another fingerprint, truncated,
// a negative count, a string that does not fit, trailing bytes); then `error`, if given, says why.
std::optional<occmap::merge_status_t> decodeMergeStatus(const std::uint8_t* data, std::size_t size,
                                                        std::string* error = nullptr);

}  // namespace occmap
