// lighting_status: a lighting_status_t as `occmap status` reads it (published with each status_t,
// by the daemon or by anyone on the network segment who saw the request's id) and prints it, as
// the light's lines of the table and as the lighting fields of the JSON.
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/status_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/status_message.h"
#include "transport/status_text.h"

namespace occmap::fuzz {

bool fuzzLightingStatus(Input input) {
  // As tools/status_command.cpp decodes it.
  std::string error;
  const std::optional<occmap::lighting_status_t> decoded =
      decodeLightingStatus(input.data(), input.size(), &error);
  if (!decoded) {
    require(!error.empty(), "a refused lighting status says why");
    return false;  // ignored: the status is printed without it
  }
  const occmap::lighting_status_t& lighting = *decoded;
  const std::size_t cameras = lighting.camera_name.size();
  require(lighting.num_cameras >= 0 && cameras == static_cast<std::size_t>(lighting.num_cameras) &&
              lighting.adapt.size() == cameras && lighting.gain.size() == cameras &&
              lighting.agreement.size() == cameras && lighting.explained.size() == cameras &&
              lighting.unexplained_frames.size() == cameras,
          "an accepted lighting status has num_cameras of each per-camera field");
  // Accepted means exactly one lighting_status_t: encoded again, it is the same bytes.
  std::vector<std::uint8_t> again(static_cast<std::size_t>(lighting.getEncodedSize()));
  require(lighting.encode(again.data(), 0, static_cast<int>(again.size())) ==
                  static_cast<int>(again.size()) &&
              std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted lighting status encodes back to the bytes received");

  // Printed after a status (here an empty one). The table goes to the user's terminal: no escape
  // sequences, no carriage returns; a line per camera whose model is on.
  const occmap::status_t status{};
  const std::string section = formatLightingStatusTable(lighting);
  for (const char c : section) {
    const auto byte = static_cast<unsigned char>(c);
    require(c == '\n' || (byte >= 0x20 && byte != 0x7f),
            "the lighting lines hold no control characters but line ends");
  }
  const auto on = static_cast<std::size_t>(
      std::count_if(lighting.adapt.begin(), lighting.adapt.end(), [](std::int8_t a) { return a; }));
  require(static_cast<std::size_t>(std::count(section.begin(), section.end(), '\n')) == on,
          "a lighting line for each camera whose model is on");
  const std::string table = formatStatusTable(status, nullptr, &lighting);
  require(table.size() >= section.size() &&
              table.compare(table.size() - section.size(), section.size(), section) == 0,
          "the status table ends with the lighting lines");
  // What --json prints is read by programs and may be printed on a terminal: valid JSON,
  // printable ASCII only (gains that are not finite come out as null).
  const std::string json = formatStatusJson(status, nullptr, &lighting);
  require(nlohmann::json::accept(json),
          "occmap status --json prints valid JSON with a lighting status");
  require(std::all_of(json.begin(), json.end(), [](char c) { return c >= 0x20 && c < 0x7f; }),
          "occmap status --json prints printable ASCII only");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzLightingStatus)
