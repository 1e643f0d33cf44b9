// control_status: a control_status_t as `occmap status` reads it (published with each status_t,
// by the daemon or by anyone on the network segment who saw the request's id) and prints it, as
// the control section of the table and as the control fields of the JSON.
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <occmap/control_status_t.hpp>
#include <occmap/status_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/status_message.h"
#include "transport/status_text.h"

namespace occmap::fuzz {

bool fuzzControlStatus(Input input) {
  // As tools/status_command.cpp decodes it.
  std::string error;
  const std::optional<occmap::control_status_t> decoded =
      decodeControlStatus(input.data(), input.size(), &error);
  if (!decoded) {
    require(!error.empty(), "a refused control status says why");
    return false;  // ignored: the status is printed without it
  }
  const occmap::control_status_t& control = *decoded;
  require(control.num_cameras >= 0 &&
              control.camera_name.size() == static_cast<std::size_t>(control.num_cameras) &&
              control.camera_threshold.size() == control.camera_name.size() &&
              control.camera_background_utime.size() == control.camera_name.size(),
          "an accepted control status has num_cameras of each per-camera field");
  // Accepted means exactly one control_status_t: encoded again, it is the same bytes.
  std::vector<std::uint8_t> again(static_cast<std::size_t>(control.getEncodedSize()));
  require(control.encode(again.data(), 0, static_cast<int>(again.size())) ==
                  static_cast<int>(again.size()) &&
              std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted control status encodes back to the bytes received");

  // Printed after a status (here an empty one) whose answer it came with. The table goes to the
  // user's terminal: no escape sequences, no carriage returns.
  const occmap::status_t status{};
  const std::string section = formatControlStatusTable(control);
  for (const char c : section) {
    const auto byte = static_cast<unsigned char>(c);
    require(c == '\n' || (byte >= 0x20 && byte != 0x7f),
            "the control section holds no control characters but line ends");
  }
  require(!section.empty() && section.back() == '\n', "the control section ends with a newline");
  // The counters' line, then (control enabled) a line per camera: a line cut short would run
  // into the next one.
  const auto lines = static_cast<std::size_t>(std::count(section.begin(), section.end(), '\n'));
  require(lines == 1 + (control.control_enabled ? control.camera_name.size() : 0),
          "the control section has a line for each camera");
  const std::string table = formatStatusTable(status, &control);
  require(table.size() > section.size() &&
              table.compare(table.size() - section.size(), section.size(), section) == 0,
          "the status table ends with the control section");
  // What --json prints is read by programs (nlohmann's parser is as strict as RFC 8259: UTF-8,
  // no raw control characters in strings) and may be printed on a terminal: printable ASCII only.
  const std::string json = formatStatusJson(status, &control);
  require(nlohmann::json::accept(json),
          "occmap status --json prints valid JSON with a control status");
  require(std::all_of(json.begin(), json.end(), [](char c) { return c >= 0x20 && c < 0x7f; }),
          "occmap status --json prints printable ASCII only");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzControlStatus)
