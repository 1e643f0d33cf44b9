#include "transport/merge_status_message.h"

#include "transport/wire_reader.h"

namespace occmap {
namespace {

// Fields of the given types, in order; false as soon as one does not fit. (Named apart from
// status_message.cpp's helpers: the folder is built as one unit.)
template <typename... T>
bool skipMergeFields(WireReader& in) {
  const auto skip = [&in](auto ignored) { return in.read(ignored); };
  return (skip(T{}) && ...);
}

bool skipMergeStrings(WireReader& in, int count) {
  for (int k = 0; k < count; ++k) {
    const char* text = nullptr;
    std::size_t length = 0;
    if (!in.readString(text, length)) return false;
  }
  return true;
}

// Why the bytes are not one merge_status_t, or "" when every count agrees with the size (in the
// order of lcmtypes/merge_status_t.lcm and merge_input_status_t.lcm).
const char* mergeStatusLayoutError(const std::uint8_t* data, std::size_t size) {
  WireReader in(data, size);
  std::int64_t fingerprint = 0;
  if (!in.read(fingerprint)) return "too short for an LCM message";
  if (fingerprint != occmap::merge_status_t::getHash()) {
    return "not an occmap.merge_status_t (fingerprint)";
  }
  if (!skipMergeFields<std::int64_t, std::int64_t>(in)) return "truncated in utime or request_id";
  if (!skipMergeStrings(in, 3)) {
    return "hostname, config_file or map_channel is not a string that fits";
  }
  // state, uptime_s, maps_published, publish_errors, maps_per_s, max_age_ms, the latency's p50,
  // p99 and last, the merge time's p50 and p99, clock_warning_ms.
  if (!skipMergeFields<std::int8_t, double, std::int64_t, std::int64_t, double, double, double,
                       double, double, double, double, double>(in)) {
    return "truncated in the node's figures";
  }
  std::int16_t inputs = 0;
  if (!in.read(inputs)) return "truncated before num_inputs";
  if (inputs < 0) return "num_inputs is negative";
  for (int k = 0; k < inputs; ++k) {
    if (!skipMergeStrings(in, 2)) return "an input's name or channel is not a string that fits";
    // state, maps, maps_per_s, age_ms, lost_maps, tiles_lost, refused, clock_offset_ms.
    if (!skipMergeFields<std::int8_t, std::int64_t, double, double, std::int64_t, std::int64_t,
                         std::int64_t, double>(in)) {
      return "truncated in an input's figures";
    }
    if (!skipMergeStrings(in, 1)) return "an input's last_error is not a string that fits";
  }
  if (in.remaining() != 0) return "bytes left over: the counts do not add up to the size";
  return "";
}

}  // namespace

std::string mergeStatusChannel(const std::string& status_channel) {
  return status_channel + "_MERGE";
}

std::optional<occmap::merge_status_t> decodeMergeStatus(const std::uint8_t* data, std::size_t size,
                                                        std::string* error) {
  return decodeWalked<occmap::merge_status_t>(data, size, error, mergeStatusLayoutError);
}

}  // namespace occmap
