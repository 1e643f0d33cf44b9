// view_status: a view_status_t as `occmap status` reads it (published with each status_t, by the
// daemon or by anyone on the network segment who saw the request's id) and prints it: in the
// light's lines of the table (whether a degraded camera was moved, how far it turned, its
// re-poses) and as the view fields of the JSON.
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/status_t.hpp>
#include <occmap/view_status_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/status_message.h"
#include "transport/status_text.h"

namespace occmap::fuzz {

bool fuzzViewStatus(Input input) {
  // As tools/status_command.cpp decodes it.
  std::string error;
  const std::optional<occmap::view_status_t> decoded =
      decodeViewStatus(input.data(), input.size(), &error);
  if (!decoded) {
    require(!error.empty(), "a refused view status says why");
    return false;  // ignored: the status is printed without it
  }
  const occmap::view_status_t& view = *decoded;
  const std::size_t cameras = view.camera_name.size();
  require(view.num_cameras >= 0 && cameras == static_cast<std::size_t>(view.num_cameras) &&
              view.view.size() == cameras && view.shift_x_px.size() == cameras &&
              view.shift_y_px.size() == cameras && view.turn_deg.size() == cameras &&
              view.residual_px.size() == cameras && view.checked_utime.size() == cameras &&
              view.reposes.size() == cameras && view.reposed_turn_deg.size() == cameras &&
              view.reposed_utime.size() == cameras,
          "an accepted view status has num_cameras of each per-camera field");
  // Accepted means exactly one view_status_t: encoded again, it is the same bytes.
  std::vector<std::uint8_t> again(static_cast<std::size_t>(view.getEncodedSize()));
  require(view.encode(again.data(), 0, static_cast<int>(again.size())) ==
                  static_cast<int>(again.size()) &&
              std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted view status encodes back to the bytes received");

  // Printed with the lighting status of the same cameras, every one degraded (where the view says
  // most), after a status (here an empty one).
  occmap::lighting_status_t lighting{};
  lighting.camera_name = view.camera_name;
  lighting.num_cameras = view.num_cameras;
  lighting.adapt.assign(cameras, 1);
  lighting.gain.assign(cameras, 1.0);
  lighting.agreement.assign(cameras, 0.2);
  lighting.explained.assign(cameras, 0);
  lighting.unexplained_frames.assign(cameras, 30);
  const std::string section = formatLightingStatusTable(lighting, &view);
  for (const char c : section) {
    const auto byte = static_cast<unsigned char>(c);
    require(c == '\n' || (byte >= 0x20 && byte != 0x7f),
            "the lighting lines hold no control characters but line ends");
  }
  require(static_cast<std::size_t>(std::count(section.begin(), section.end(), '\n')) == cameras,
          "a lighting line for each camera");
  const occmap::status_t status{};
  const std::string json = formatStatusJson(status, nullptr, &lighting, &view);
  require(nlohmann::json::accept(json), "occmap status --json prints valid JSON with a view status");
  require(std::all_of(json.begin(), json.end(), [](char c) { return c >= 0x20 && c < 0x7f; }),
          "occmap status --json prints printable ASCII only");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzViewStatus)
