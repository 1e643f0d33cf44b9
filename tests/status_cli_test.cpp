// `occmap status` as a user runs it, against a stand-in for occmapd in the test's own process, over
// LCM's UDP multicast in a private network namespace (tests/network_namespace.h; skips without
// one): while it waits for the daemon's answer it hears the zones and tracks published beside the
// maps, and prints the answering daemon's, in the table and in --json, or says that none came
// without waiting for them any longer.
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <occmap/control_status_t.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/status_t.hpp>
#include <occmap/tracks_t.hpp>
#include <occmap/view_status_t.hpp>
#include <occmap/zones_t.hpp>

#include "base/format_text.h"
#include "command_runner.h"
#include "network_namespace.h"
#include "timing.h"
#include "transport/control_message.h"
#include "transport/footprints_message.h"
#include "transport/lcm_bus.h"
#include "transport/status_message.h"

namespace occmap {
namespace {

using namespace std::chrono_literals;
using testing::runCommand;

const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";
const std::string kUrl = "udpm://239.255.76.67:7667?ttl=0";
const std::string kStatusChannel = "OCCMAP_STATUS";
const std::string kHostname = "cell-3";

template <typename Message>
std::vector<std::uint8_t> encoded(const Message& message) {
  std::vector<std::uint8_t> data(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(data.data(), 0, static_cast<int>(data.size()));
  return data;
}

occmap::zone_t zone(const std::string& name, std::int8_t state, double state_s, int cells,
                    int occupied, int unseen) {
  occmap::zone_t z{};
  z.name = name;
  z.state = state;
  z.state_s = state_s;
  z.cells = cells;
  z.occupied_cells = occupied;
  z.unseen_cells = unseen;
  z.corner_x_m = {0.0, 1.5, 1.5, 0.0};
  z.corner_y_m = {-1.0, -1.0, 0.25, 0.25};
  z.num_corners = 4;
  return z;
}

occmap::track_t track(int id, double x, double y, double vx, double vy, double age_s) {
  occmap::track_t t{};
  t.id = id;
  t.x_m = x;
  t.y_m = y;
  t.vx_m_s = vx;
  t.vy_m_s = vy;
  t.area_m2 = 0.19;
  t.age_s = age_s;
  t.unseen_s = 0;
  return t;
}

// What occmapd's LCM side sends, from a thread of the test: the answer to each status request
// (status_t and its control, lighting and view companions, as the daemon sends them), and, 30
// times a second as if after each map, its zones_t and (when `tracks` is on) its tracks_t on the
// channels named after `map_channel`. Another host's zones and tracks go out on the same channels:
// only the answering daemon's may be shown.
class DaemonStandIn {
 public:
  DaemonStandIn(std::string map_channel, bool tracks)
      : map_channel_(std::move(map_channel)), send_tracks_(tracks) {
    zones_.hostname = kHostname;
    zones_.zones = {zone("robot-cell", occmap::zone_t::OCCUPIED, 3.24, 2500, 41, 0),
                    zone("door", occmap::zone_t::FREE, 754.0, 900, 0, 0),
                    zone("desk", occmap::zone_t::UNSEEN, 0.5, 400, 0, 120)};
    zones_.num_zones = static_cast<std::int16_t>(zones_.zones.size());
    tracks_.hostname = kHostname;
    tracks_.footprints = {
        {1.2, 0.35, 0.19, 0.6, 1.75}, {-0.4, 2.1, 0.2, 0.4, 1.75}, {3.0, 0.2, 0.05, 0.61, 0.5}};
    tracks_.num_footprints = static_cast<std::int16_t>(tracks_.footprints.size());
    tracks_.tracks = {track(4, 1.204, 0.347, 0.62, -0.5, 12.5), track(7, -0.4, 2.1, 0, 0.02, 3.0)};
    tracks_.num_tracks = static_cast<std::int16_t>(tracks_.tracks.size());
    stranger_zones_ = zones_;
    stranger_zones_.hostname = "someone-else";
    stranger_zones_.zones = {zone("strangers-zone", occmap::zone_t::FREE, 1, 10, 0, 0)};
    stranger_zones_.num_zones = 1;
    stranger_tracks_ = tracks_;
    stranger_tracks_.hostname = "someone-else";
    stranger_tracks_.tracks = {track(99, 9, 9, 0, 0, 1)};
    stranger_tracks_.num_tracks = 1;
    thread_ = std::thread([this] { run(); });
    while (!listening_.load()) std::this_thread::sleep_for(1ms);
  }
  ~DaemonStandIn() {
    stop_.store(true);
    thread_.join();
  }
  DaemonStandIn(const DaemonStandIn&) = delete;
  DaemonStandIn& operator=(const DaemonStandIn&) = delete;

  bool good() const { return good_.load(); }
  // As sent (but for seq and utime, which go up with each map).
  const occmap::zones_t& zones() const { return zones_; }
  const occmap::tracks_t& tracks() const { return tracks_; }
  // The seq of the last map whose zones went out.
  std::int64_t lastSeq() const { return last_seq_.load(); }

 private:
  void run() {
    LcmBus bus(kUrl);
    good_.store(bus.good());
    bus.subscribe(statusRequestChannel(kStatusChannel),
                  [&bus](const std::uint8_t* data, std::size_t size, std::int64_t) {
                    const std::optional<std::int64_t> id = decodeStatusRequest(data, size);
                    if (id) answer(bus, *id);
                  });
    listening_.store(true);
    auto next = std::chrono::steady_clock::now();
    std::int64_t seq = 1000;
    while (!stop_.load()) {
      if (std::chrono::steady_clock::now() >= next) {
        zones_.seq = stranger_zones_.seq = ++seq;
        zones_.utime = stranger_zones_.utime = 1'700'000'000'000'000 + seq * 33'333;
        bus.publish(zonesChannel(map_channel_), encoded(zones_));
        bus.publish(zonesChannel(map_channel_), encoded(stranger_zones_));
        last_seq_.store(seq);
        if (send_tracks_) {
          // As the daemon's: the detector's result on the map before, right after these zones.
          tracks_.seq = stranger_tracks_.seq = seq - 1;
          tracks_.utime = stranger_tracks_.utime = zones_.utime - 33'333;
          bus.publish(tracksChannel(map_channel_), encoded(tracks_));
          bus.publish(tracksChannel(map_channel_), encoded(stranger_tracks_));
        }
        next += 33ms;
      }
      bus.handleTimeout(5);
    }
  }

  static void answer(LcmBus& bus, std::int64_t request_id) {
    occmap::status_t status{};
    status.utime = 1'700'000'000'000'000;
    status.request_id = request_id;
    status.hostname = kHostname;
    status.state = occmap::status_t::STATE_RUNNING;
    status.maps_per_s = 30;
    bus.publish(kStatusChannel, encoded(status));
    occmap::control_status_t control{};
    control.utime = status.utime;
    control.request_id = request_id;
    control.hostname = kHostname;
    bus.publish(controlStatusChannel(kStatusChannel), encoded(control));
    occmap::lighting_status_t lighting{};
    lighting.utime = status.utime;
    lighting.request_id = request_id;
    lighting.hostname = kHostname;
    bus.publish(lightingStatusChannel(kStatusChannel), encoded(lighting));
    occmap::view_status_t view{};
    view.utime = status.utime;
    view.request_id = request_id;
    view.hostname = kHostname;
    bus.publish(viewStatusChannel(kStatusChannel), encoded(view));
  }

  std::string map_channel_;
  bool send_tracks_;
  occmap::zones_t zones_{};
  occmap::tracks_t tracks_{};
  occmap::zones_t stranger_zones_{};
  occmap::tracks_t stranger_tracks_{};
  std::atomic<bool> good_{false}, listening_{false}, stop_{false};
  std::atomic<std::int64_t> last_seq_{0};
  std::thread thread_;
};

class StatusOfTheMap : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string& problem = testing::enterPrivateNetwork();
    if (!problem.empty()) GTEST_SKIP() << problem;
  }
};

// The line the table should hold for zone `z` of `zones`, from its fields: the name (as wide as
// the longest), the state, for how long (as an uptime from a minute on), its cells.
std::string zoneLine(const occmap::zones_t& zones, std::size_t z) {
  int width = 0;
  for (const occmap::zone_t& other : zones.zones) {
    width = std::max(width, static_cast<int>(other.name.size()));
  }
  const occmap::zone_t& zone = zones.zones.at(z);
  const char* states[] = {"free", "occupied", "unseen"};
  const auto seconds = static_cast<int>(zone.state_s);
  const std::string how_long = zone.state_s < 59.95 ? formatText("%.1f s", zone.state_s)
                                                    : formatText("%d:%02d:%02d", seconds / 3600,
                                                                 seconds / 60 % 60, seconds % 60);
  std::string line =
      formatText("zone %-*s  %s for %s (%d of %d cells occupied", width, zone.name.c_str(),
                 states[zone.state], how_long.c_str(), zone.occupied_cells, zone.cells);
  if (zone.unseen_cells != 0) line += formatText(", %d unseen", zone.unseen_cells);
  if (zone.state == occmap::zone_t::UNSEEN && zone.occupied_cells > 0) {
    line += ", all floor hidden behind people found";
  }
  return line + ")\n";
}

TEST_F(StatusOfTheMap, TheTableAndTheJsonHoldTheAnsweringDaemonsZonesAndTracks) {
  DaemonStandIn daemon("OCCMAP_MAP", true);
  ASSERT_TRUE(daemon.good()) << "cannot open LCM at " << kUrl;
  auto result = runCommand({kOccmap, "status", "--timeout", "5"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  const std::string& table = result.out;
  EXPECT_NE(table.find("occmapd on " + kHostname), std::string::npos) << table;
  for (std::size_t z = 0; z < daemon.zones().zones.size(); ++z) {
    const std::string line = zoneLine(daemon.zones(), z);
    EXPECT_NE(table.find("\n" + line), std::string::npos) << "no line '" << line << "' in\n"
                                                          << table;
  }
  const auto& tracks = daemon.tracks().tracks;
  std::string tracked = formatText("%zu tracked: ", tracks.size());
  for (std::size_t k = 0; k < tracks.size(); ++k) {
    tracked +=
        formatText("%s#%d at (%.2f, %.2f) m moving %.1f m/s", k == 0 ? "" : ", ", tracks[k].id,
                   tracks[k].x_m, tracks[k].y_m, std::hypot(tracks[k].vx_m_s, tracks[k].vy_m_s));
  }
  tracked += formatText("; %zu footprints on map ", daemon.tracks().footprints.size());
  const std::size_t at = table.find(tracked);
  ASSERT_NE(at, std::string::npos) << "no '" << tracked << "' in\n" << table;
  const std::int64_t seq = std::stoll(table.substr(at + tracked.size()));
  EXPECT_GE(seq, 1000) << "the seq of a map the stand-in sent";
  EXPECT_LT(seq, daemon.lastSeq()) << "tracks name the map before the newest zones";
  EXPECT_EQ(table.find("strangers-zone"), std::string::npos) << "another host's zones:\n" << table;
  EXPECT_EQ(table.find("#99"), std::string::npos) << "another host's tracks:\n" << table;
  EXPECT_EQ(table.find("no tracks_t heard"), std::string::npos) << table;

  result = runCommand({kOccmap, "status", "--timeout", "5", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_EQ(std::count(result.out.begin(), result.out.end(), '\n'), 1) << result.out;
  const nlohmann::json status = nlohmann::json::parse(result.out, nullptr, false);
  ASSERT_TRUE(status.is_object()) << "not one JSON object: " << result.out;
  EXPECT_EQ(status["hostname"], kHostname);
  const nlohmann::json& zones = status["zones"];
  ASSERT_TRUE(zones.is_array()) << result.out;
  ASSERT_EQ(zones.size(), daemon.zones().zones.size()) << result.out;
  for (std::size_t k = 0; k < zones.size(); ++k) {
    const occmap::zone_t& sent = daemon.zones().zones[k];
    EXPECT_EQ(zones[k]["name"], sent.name);
    EXPECT_EQ(zones[k]["state"], sent.state);
    EXPECT_EQ(zones[k]["state_s"], sent.state_s);
    EXPECT_EQ(zones[k]["cells"], sent.cells);
    EXPECT_EQ(zones[k]["occupied_cells"], sent.occupied_cells);
    EXPECT_EQ(zones[k]["unseen_cells"], sent.unseen_cells);
    EXPECT_EQ(zones[k]["corner_x_m"], sent.corner_x_m);
    EXPECT_EQ(zones[k]["corner_y_m"], sent.corner_y_m);
  }
  EXPECT_EQ(zones[0]["state_name"], "occupied");
  const nlohmann::json& heard = status["tracks"];
  ASSERT_TRUE(heard.is_object()) << result.out;
  EXPECT_EQ(heard["hostname"], kHostname);
  EXPECT_GE(heard["seq"].get<std::int64_t>(), 1000) << result.out;
  EXPECT_EQ(heard["utime"].get<std::int64_t>(),
            1'700'000'000'000'000 + heard["seq"].get<std::int64_t>() * 33'333)
      << "the utime sent with that seq";
  ASSERT_EQ(heard["footprints"].size(), daemon.tracks().footprints.size()) << result.out;
  EXPECT_EQ(heard["footprints"][1]["y_m"], daemon.tracks().footprints[1].y_m);
  EXPECT_EQ(heard["footprints"][2]["score"], daemon.tracks().footprints[2].score);
  EXPECT_EQ(heard["footprints"][2]["height_m"], daemon.tracks().footprints[2].height_m);
  ASSERT_EQ(heard["tracks"].size(), tracks.size()) << result.out;
  for (std::size_t k = 0; k < tracks.size(); ++k) {
    EXPECT_EQ(heard["tracks"][k]["id"], tracks[k].id);
    EXPECT_EQ(heard["tracks"][k]["x_m"], tracks[k].x_m);
    EXPECT_EQ(heard["tracks"][k]["y_m"], tracks[k].y_m);
    EXPECT_EQ(heard["tracks"][k]["vx_m_s"], tracks[k].vx_m_s);
    EXPECT_EQ(heard["tracks"][k]["vy_m_s"], tracks[k].vy_m_s);
    EXPECT_EQ(heard["tracks"][k]["area_m2"], tracks[k].area_m2);
    EXPECT_EQ(heard["tracks"][k]["age_s"], tracks[k].age_s);
    EXPECT_EQ(heard["tracks"][k]["unseen_s"], tracks[k].unseen_s);
  }
}

// A daemon whose detector is off sends zones but no tracks: status says so, and waits for them no
// longer than a moment after the answer, not its whole --timeout. The map channel is the option's.
TEST_F(StatusOfTheMap, WithoutTracksItSaysSoSoonAndListensOnTheMapChannelGiven) {
  DaemonStandIn daemon("HALL_MAP", false);
  ASSERT_TRUE(daemon.good()) << "cannot open LCM at " << kUrl;
  const auto start = std::chrono::steady_clock::now();
  auto result = runCommand({kOccmap, "status", "--timeout", "10", "--map-channel", "HALL_MAP"});
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find("\n" + zoneLine(daemon.zones(), 0)), std::string::npos) << result.out;
  const std::string none = "\nno tracks_t heard in ";
  const std::size_t at = result.out.find(none);
  ASSERT_NE(at, std::string::npos) << result.out;
  const std::string rest = result.out.substr(at + none.size());
  EXPECT_TRUE(rest.find(" s (is footprints: enabled: false?)\n") < rest.find('\n')) << result.out;
  const double listened = std::stod(rest);
  EXPECT_GT(listened, 0.0) << result.out;
  EXPECT_LE(listened, seconds + 0.05) << result.out;
  if (!testing::kSanitized) {
    EXPECT_LT(seconds, 2.0) << "status waited for tracks that never come";
  }
  result =
      runCommand({kOccmap, "status", "--timeout", "10", "--map-channel", "HALL_MAP", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  const nlohmann::json status = nlohmann::json::parse(result.out, nullptr, false);
  ASSERT_TRUE(status.is_object()) << result.out;
  EXPECT_EQ(status["zones"].size(), daemon.zones().zones.size()) << result.out;
  EXPECT_TRUE(status["tracks"].is_null()) << result.out;

  // On the default map channel (OCCMAP_MAP) nothing of this daemon's is heard.
  result = runCommand({kOccmap, "status", "--timeout", "10"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find("\nno zones_t heard in "), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("\nno tracks_t heard in "), std::string::npos) << result.out;
  EXPECT_EQ(result.out.find("robot-cell"), std::string::npos) << result.out;
}

}  // namespace
}  // namespace occmap
