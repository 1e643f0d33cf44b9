// status: a status_t as `occmap status` reads it (the answer to its request, from anyone on the
// network segment who saw the request's id) and prints it, as a table or as JSON.
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <occmap/status_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/status_message.h"
#include "transport/status_text.h"

namespace occmap::fuzz {

bool fuzzStatus(Input input) {
  // As tools/status_command.cpp decodes an answer.
  std::string error;
  const std::optional<occmap::status_t> decoded = decodeStatus(input.data(), input.size(), &error);
  if (!decoded) {
    require(!error.empty(), "a refused status says why");
    return false;  // counted as undecodable
  }
  const occmap::status_t& status = *decoded;
  // Accepted means exactly one status_t: encoded again, it is the same bytes.
  std::vector<std::uint8_t> again(static_cast<std::size_t>(status.getEncodedSize()));
  require(status.encode(again.data(), 0, static_cast<int>(again.size())) ==
                  static_cast<int>(again.size()) &&
              std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted status encodes back to the bytes received");

  // What the table prints goes to the user's terminal: no escape sequences, no carriage returns.
  const std::string table = formatStatusTable(status);
  for (const char c : table) {
    const auto byte = static_cast<unsigned char>(c);
    require(c == '\n' || (byte >= 0x20 && byte != 0x7f),
            "the status table holds no control characters but line ends");
  }
  require(!table.empty() && table.back() == '\n', "the status table ends with a newline");
  // Four lines on the daemon, a blank line, the header, a row per camera (or "(no cameras)"): a
  // row cut short would run into the next one.
  const auto lines = static_cast<std::size_t>(std::count(table.begin(), table.end(), '\n'));
  require(lines >= 6 + std::max<std::size_t>(status.cameras.size(), 1),
          "the status table has a line for each camera");
  // What --json prints is read by programs (nlohmann's parser is as strict as RFC 8259: UTF-8,
  // no raw control characters in strings) and may be printed on a terminal: printable ASCII only.
  const std::string json = formatStatusJson(status);
  require(nlohmann::json::accept(json), "occmap status --json prints valid JSON");
  require(std::all_of(json.begin(), json.end(), [](char c) { return c >= 0x20 && c < 0x7f; }),
          "occmap status --json prints printable ASCII only");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzStatus)
