#pragma once
// What the tracks and zones targets both hold `occmap status` to once a message is accepted: the
// zones' and tracks' lines at the end of the table are `lines` lines of printable text (they go to
// the user's terminal: no escape sequences, no carriage returns), and --json is valid, printable
// ASCII (read by programs, and printed on terminals too). Returns the JSON, parsed.
#include <algorithm>
#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>
#include <occmap/status_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/status_text.h"

namespace occmap::fuzz {

inline nlohmann::json checkZonesAndTracksPrinted(const ZonesAndTracks& heard, std::size_t lines) {
  const std::string section = formatZonesAndTracks(heard);
  for (const char c : section) {
    const auto byte = static_cast<unsigned char>(c);
    require(c == '\n' || (byte >= 0x20 && byte != 0x7f),
            "the zones' and tracks' lines hold no control characters but line ends");
  }
  require(static_cast<std::size_t>(std::count(section.begin(), section.end(), '\n')) == lines &&
              section.back() == '\n',
          "a line for each zone (or one for none heard) and one for the tracks");
  const occmap::status_t status{};  // an empty one: the section comes after any table
  const std::string table = formatStatusTable(status, nullptr, nullptr, nullptr, &heard);
  require(table.size() >= section.size() &&
              table.compare(table.size() - section.size(), section.size(), section) == 0,
          "the status table ends with the zones' and tracks' lines");
  // Numbers that are not finite come out as null.
  const std::string json = formatStatusJson(status, nullptr, nullptr, nullptr, &heard);
  require(nlohmann::json::accept(json), "occmap status --json prints valid JSON");
  require(std::all_of(json.begin(), json.end(), [](char c) { return c >= 0x20 && c < 0x7f; }),
          "occmap status --json prints printable ASCII only");
  return nlohmann::json::parse(json);
}

}  // namespace occmap::fuzz
