// merge_status: a merge node's merge_status_t as `occmap status` reads it (the answer to its
// request, on the status channel's name + "_MERGE", from the merge node or from anyone on the
// network segment who saw the request's id) and prints it, as the table (with the zones and tracks
// heard beside it, here none) and as --json, which `occmap web` serves too.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <occmap/merge_status_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/merge_status_message.h"
#include "transport/status_text.h"

namespace occmap::fuzz {
namespace {

// Text for the user's terminal: no escape sequences, no carriage returns.
void requirePrintable(const std::string& text, const std::string& promise) {
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    require(c == '\n' || (byte >= 0x20 && byte != 0x7f), promise);
  }
}

std::size_t lineCount(const std::string& text) {
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

}  // namespace

bool fuzzMergeStatus(Input input) {
  // As tools/status_command.cpp and web/bus_feed.cpp decode it.
  std::string error;
  const std::optional<occmap::merge_status_t> decoded =
      decodeMergeStatus(input.data(), input.size(), &error);
  if (!decoded) {
    require(!error.empty(), "a refused merge status says why");
    return false;  // counted as undecodable
  }
  const occmap::merge_status_t& status = *decoded;
  require(
      status.num_inputs >= 0 && status.inputs.size() == static_cast<std::size_t>(status.num_inputs),
      "an accepted merge status has num_inputs inputs");
  // Accepted means exactly one merge_status_t: encoded again, it is the same bytes.
  std::vector<std::uint8_t> again(static_cast<std::size_t>(status.getEncodedSize()));
  require(status.encode(again.data(), 0, static_cast<int>(again.size())) ==
                  static_cast<int>(again.size()) &&
              std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted merge status encodes back to the bytes received");

  // The table: six lines on the node, a blank line, the header, a row per input (or "(no
  // inputs)"), then a line per note: an input's clock more than clock_warning_ms off, its tiles
  // lost, its messages refused (or its last error). A row cut short would run into the next one.
  const std::string table = formatMergeStatusTable(status);
  requirePrintable(table, "the merge status table holds no control characters but line ends");
  require(!table.empty() && table.back() == '\n', "the merge status table ends with a newline");
  std::size_t notes = 0;
  for (const occmap::merge_input_status_t& in : status.inputs) {
    const bool clock_off = std::isfinite(in.clock_offset_ms) && status.clock_warning_ms > 0 &&
                           std::fabs(in.clock_offset_ms) > status.clock_warning_ms;
    notes += (clock_off ? 1 : 0) + (in.tiles_lost != 0 ? 1 : 0) +
             (in.refused != 0 || !in.last_error.empty() ? 1 : 0);
  }
  require(lineCount(table) == 8 + std::max<std::size_t>(status.inputs.size(), 1) + notes,
          "the merge status table has a line for each input and each note");
  // As `occmap status` prints it: with the zones and tracks heard beside it (here none in 0.5 s),
  // a blank line and a line for each after the table.
  const ZonesAndTracks heard{nullptr, nullptr, 0.5};
  const std::string with_heard = formatMergeStatusTable(status, &heard);
  requirePrintable(with_heard, "the merge status table holds no control characters but line ends");
  require(with_heard.size() > table.size() && with_heard.compare(0, table.size(), table) == 0 &&
              lineCount(with_heard) == lineCount(table) + 3 && with_heard.back() == '\n',
          "the zones' and tracks' lines follow the merge status table");

  // What --json prints is read by programs (nlohmann's parser is as strict as RFC 8259: UTF-8,
  // no raw control characters in strings) and may be printed on a terminal: printable ASCII only.
  for (const ZonesAndTracks* beside : {static_cast<const ZonesAndTracks*>(nullptr), &heard}) {
    const std::string json = formatMergeStatusJson(status, beside);
    require(nlohmann::json::accept(json), "occmap status --json prints a merge status as JSON");
    require(std::all_of(json.begin(), json.end(), [](char c) { return c >= 0x20 && c < 0x7f; }),
            "occmap status --json prints printable ASCII only");
    const nlohmann::json parsed = nlohmann::json::parse(json);
    require(parsed.at("inputs").is_array() && parsed.at("inputs").size() == status.inputs.size(),
            "the JSON's \"inputs\" holds every input");
    require(beside == nullptr ? !parsed.contains("zones") && !parsed.contains("tracks")
                              : parsed.at("zones").is_null() && parsed.at("tracks").is_null(),
            "the JSON's \"zones\" and \"tracks\" are there, null, when none were heard");
  }
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzMergeStatus)
