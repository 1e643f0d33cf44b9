// A merge node's status (issue 16): merge_status_t as the node sends it and as `occmap status`
// decodes and prints it (transport/merge_status_publisher.h, merge_status_message.h,
// status_text.h), in process; and, as MergeStatusLive (CTest's merge_status_live_test), a merge
// node and two camera PCs' daemons, each with a host name of its own, on UDP multicast in a private
// network namespace (tests/network_namespace.h; skips without one): `occmap status` shows the
// merge node's inputs as it shows a camera PC's cameras, and `occmap status --all` lists every
// daemon that answers one request.
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <occmap/merge_status_t.hpp>
#include <occmap/status_t.hpp>
#include <sched.h>
#include <unistd.h>

#include "child_process.h"
#include "command_runner.h"
#include "network_namespace.h"
#include "notify_listener.h"
#include "sim_room_config.h"
#include "timing.h"
#include "transport/memory_bus.h"
#include "transport/merge_status_message.h"
#include "transport/merge_status_publisher.h"
#include "transport/status_text.h"

namespace occmap {
namespace {

using namespace std::chrono_literals;

constexpr std::int64_t kS = 1'000'000'000;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

MergeReport threeInputs() {
  MergeReport report;
  report.hostname = "merge-pc";
  report.config_file = "/etc/occmap/merge.yaml";
  report.map_channel = "OCCMAP_MAP";
  report.state = DaemonState::kRunning;
  report.uptime_s = 61.5;
  report.max_age_s = 0.150;
  report.latency_p50_ms = 0.42;
  report.latency_p99_ms = 1.3;
  report.latency_last_ms = 0.38;
  report.merge_p50_ms = 0.21;
  report.merge_p99_ms = 0.8;
  report.clock_warning_s = 0.010;
  report.inputs.resize(3);
  report.inputs[0].name = "west";
  report.inputs[0].channel = "OCCMAP_MAP_WEST";
  report.inputs[0].state = MergeInputState::kFresh;
  report.inputs[0].age_s = 0.0;
  report.inputs[0].clock_offset_s = 0.0004;
  report.inputs[0].lost = 2;
  report.inputs[0].tiles_lost = 5;
  report.inputs[1].name = "east";
  report.inputs[1].channel = "OCCMAP_MAP_EAST";
  report.inputs[1].state = MergeInputState::kDown;
  report.inputs[1].age_s = 2.4;
  report.inputs[1].clock_offset_s = 0.0123;
  report.inputs[1].refused = 3;
  report.inputs[1].last_error = std::string(300, 'x');  // longer than a status carries
  report.inputs[2].name = "north";
  report.inputs[2].channel = "OCCMAP_MAP_NORTH";
  return report;  // north never heard: no age, no clock offset
}

// What a MergeStatusPublisher sends, as bytes heard on the merge status channel.
class Heard {
 public:
  explicit Heard(MemoryNetwork& network) : bus_(network.connect()) {
    bus_->subscribe("OCCMAP_STATUS_MERGE",
                    [this](const std::uint8_t* data, std::size_t size, std::int64_t) {
                      last_.assign(data, data + size);
                    });
  }
  const std::vector<std::uint8_t>& last() {
    while (bus_->handleTimeout(0) > 0) {
    }
    return last_;
  }

 private:
  std::unique_ptr<MemoryBus> bus_;
  std::vector<std::uint8_t> last_;
};

TEST(MergeStatus, GoesOnTheStatusChannelPlusMergeAndComesBackFieldForField) {
  EXPECT_EQ(mergeStatusChannel("OCCMAP_STATUS"), "OCCMAP_STATUS_MERGE");
  MemoryNetwork network;
  const std::unique_ptr<MemoryBus> bus = network.connect();
  Heard heard(network);
  MergeStatusPublisher publisher("OCCMAP_STATUS", 3, 0);
  EXPECT_EQ(publisher.channel(), "OCCMAP_STATUS_MERGE");
  MergeReport report = threeInputs();
  // One second in: 30 merged maps, 30 maps from west and 15 from east.
  report.maps_published = 30;
  report.inputs[0].maps = 30;
  report.inputs[1].maps = 15;
  publisher.publish(*bus, report, -1, 1 * kS);
  // An answer half a second later, over the same window (an answer does not move it on).
  report.maps_published = 45;
  report.publish_errors = 1;
  report.inputs[0].maps = 45;
  report.inputs[1].maps = 15;
  publisher.publish(*bus, report, 77, kS + kS / 2);
  const std::vector<std::uint8_t> bytes = heard.last();

  std::string error;
  const std::optional<occmap::merge_status_t> status =
      decodeMergeStatus(bytes.data(), bytes.size(), &error);
  ASSERT_TRUE(status) << error;
  EXPECT_EQ(status->request_id, 77);
  EXPECT_GT(status->utime, 1'600'000'000'000'000) << "the wall clock, us since the epoch";
  EXPECT_EQ(status->hostname, "merge-pc");
  EXPECT_EQ(status->config_file, "/etc/occmap/merge.yaml");
  EXPECT_EQ(status->map_channel, "OCCMAP_MAP");
  EXPECT_EQ(status->state, occmap::status_t::STATE_RUNNING);
  EXPECT_EQ(status->uptime_s, 61.5);
  EXPECT_EQ(status->maps_published, 45);
  EXPECT_EQ(status->publish_errors, 1);
  EXPECT_DOUBLE_EQ(status->maps_per_s, 30.0) << "45 maps in 1.5 s";
  EXPECT_DOUBLE_EQ(status->max_age_ms, 150.0);
  EXPECT_EQ(status->latency_p50_ms, 0.42);
  EXPECT_EQ(status->latency_p99_ms, 1.3);
  EXPECT_EQ(status->latency_last_ms, 0.38);
  EXPECT_EQ(status->merge_p50_ms, 0.21);
  EXPECT_EQ(status->merge_p99_ms, 0.8);
  EXPECT_DOUBLE_EQ(status->clock_warning_ms, 10.0);
  ASSERT_EQ(status->num_inputs, 3);
  ASSERT_EQ(status->inputs.size(), 3u);
  const occmap::merge_input_status_t& west = status->inputs[0];
  EXPECT_EQ(west.name, "west");
  EXPECT_EQ(west.channel, "OCCMAP_MAP_WEST");
  EXPECT_EQ(west.state, occmap::merge_input_status_t::STATE_FRESH);
  EXPECT_EQ(west.maps, 45);
  EXPECT_DOUBLE_EQ(west.maps_per_s, 30.0);
  EXPECT_EQ(west.age_ms, 0.0);
  EXPECT_EQ(west.lost_maps, 2);
  EXPECT_EQ(west.tiles_lost, 5);
  EXPECT_EQ(west.refused, 0);
  EXPECT_DOUBLE_EQ(west.clock_offset_ms, 0.4);
  EXPECT_EQ(west.last_error, "");
  const occmap::merge_input_status_t& east = status->inputs[1];
  EXPECT_EQ(east.state, occmap::merge_input_status_t::STATE_DOWN);
  EXPECT_DOUBLE_EQ(east.maps_per_s, 10.0) << "15 maps in 1.5 s";
  EXPECT_DOUBLE_EQ(east.age_ms, 2400.0);
  EXPECT_DOUBLE_EQ(east.clock_offset_ms, 12.3);
  EXPECT_EQ(east.refused, 3);
  EXPECT_EQ(east.last_error, std::string(kMaxErrorText, 'x')) << "cut to what a status carries";
  const occmap::merge_input_status_t& north = status->inputs[2];
  EXPECT_EQ(north.state, occmap::merge_input_status_t::STATE_NEVER_HEARD);
  EXPECT_EQ(north.maps, 0);
  EXPECT_TRUE(std::isnan(north.age_ms)) << "no age before its first map";
  EXPECT_TRUE(std::isnan(north.clock_offset_ms)) << "no clock offset before its first map";

  // The next periodic status, two seconds on: the window has moved past the start.
  report.maps_published = 105;
  report.inputs[0].maps = 105;
  publisher.publish(*bus, report, -1, 3 * kS);
  const std::optional<occmap::merge_status_t> later =
      decodeMergeStatus(heard.last().data(), heard.last().size(), &error);
  ASSERT_TRUE(later) << error;
  EXPECT_EQ(later->request_id, -1);
  EXPECT_DOUBLE_EQ(later->maps_per_s, 35.0) << "105 maps in 3 s: the window starts at the start";
}

// Anyone on the network segment can publish on the merge status channel: a message is decoded only
// when it is exactly one merge_status_t, and refused with a reason otherwise, never an exception.
TEST(MergeStatus, TheDecoderRefusesWhatIsNotExactlyOneWithAReason) {
  occmap::merge_status_t sent{};
  sent.hostname = "merge-pc";
  sent.config_file = "merge.yaml";
  sent.map_channel = "OCCMAP_MAP";
  sent.inputs.resize(2);
  sent.inputs[0].name = "west";
  sent.inputs[0].channel = "OCCMAP_MAP_WEST";
  sent.inputs[1].name = "east";
  sent.inputs[1].channel = "OCCMAP_MAP_EAST";
  sent.inputs[1].last_error = "zstd: corrupt frame";
  sent.num_inputs = 2;
  std::vector<std::uint8_t> data(static_cast<std::size_t>(sent.getEncodedSize()));
  sent.encode(data.data(), 0, static_cast<int>(data.size()));
  std::string error;
  ASSERT_TRUE(decodeMergeStatus(data.data(), data.size(), &error)) << error;

  const auto refused = [](std::vector<std::uint8_t> bytes, const std::string& why) {
    std::string reason;
    EXPECT_FALSE(decodeMergeStatus(bytes.data(), bytes.size(), &reason)) << why;
    EXPECT_NE(reason.find(why), std::string::npos) << "'" << reason << "' for " << why;
  };
  for (std::size_t size = 0; size < data.size(); ++size) {
    std::string reason;
    EXPECT_FALSE(decodeMergeStatus(data.data(), size, &reason)) << "cut to " << size << " bytes";
    EXPECT_FALSE(reason.empty()) << "cut to " << size << " bytes: refused without a reason";
  }
  refused({data.begin(), data.end() - 1}, "an input's last_error is not a string that fits");
  std::vector<std::uint8_t> longer = data;
  longer.push_back(0);
  refused(longer, "bytes left over");
  std::vector<std::uint8_t> other = data;
  other[0] ^= 0xFF;
  refused(other, "not an occmap.merge_status_t (fingerprint)");
  // A status_t is not a merge_status_t.
  occmap::status_t camera_pc{};
  std::vector<std::uint8_t> status(static_cast<std::size_t>(camera_pc.getEncodedSize()));
  camera_pc.encode(status.data(), 0, static_cast<int>(status.size()));
  refused(status, "fingerprint");
  // The hostname's length (after the fingerprint, utime and request_id) as large as it goes.
  std::vector<std::uint8_t> long_name = data;
  long_name[24] = 0x7F;
  refused(long_name, "hostname, config_file or map_channel is not a string that fits");
  // num_inputs after the three strings and the node's figures (an int8 and eleven doubles),
  // made negative.
  std::vector<std::uint8_t> negative = data;
  const std::size_t count_at = 24 + (4 + sent.hostname.size() + 1) +
                               (4 + sent.config_file.size() + 1) +
                               (4 + sent.map_channel.size() + 1) + 1 + 11 * 8;
  negative[count_at] = 0xFF;
  negative[count_at + 1] = 0xFE;
  refused(negative, "num_inputs is negative");
}

occmap::merge_status_t threeInputsAsSent() {
  MemoryNetwork network;
  const std::unique_ptr<MemoryBus> bus = network.connect();
  Heard heard(network);
  MergeStatusPublisher publisher("OCCMAP_STATUS", 3, 0);
  MergeReport report = threeInputs();
  report.maps_published = 1234;
  report.inputs[0].maps = 1230;
  report.inputs[1].maps = 900;
  report.inputs[1].tiles_lost = 4;
  report.inputs[1].last_error = "bad\x1b[2Jframe";  // an escape sequence from the network
  publisher.publish(*bus, report, -1, 41 * kS);
  return *decodeMergeStatus(heard.last().data(), heard.last().size());
}

// `occmap status` shows a merge node as it shows a camera PC: a few lines on the daemon, then one
// row per input (its state, maps/s, how far behind, lost maps, clock offset), and below the table
// what is wrong: a clock past 10 ms, refused messages and the last error, safe on a terminal.
TEST(MergeStatusText, ShowsTheNodeThenARowPerInputThenWhatIsWrong) {
  const occmap::merge_status_t status = threeInputsAsSent();
  const std::string text = formatMergeStatusTable(status);
  const std::string expected =
      "occmapd merge node on merge-pc (config /etc/occmap/merge.yaml)\n"
      "  state running, up 0:01:01\n"
      "  merged maps published 1234 (30.1 maps/s) on OCCMAP_MAP, publish errors 0\n"
      "  inputs fresh: 1 of 3 (within 150 ms of the newest input's capture)\n"
      "  latency from the newest input's arrival to publish: p50 0.42 ms, p99 1.30 ms, last "
      "0.38 ms\n"
      "  merge per input map: p50 0.21 ms, p99 0.80 ms\n"
      "\n"
      "input  channel           state            maps  maps/s    behind    lost      clock\n"
      "west   OCCMAP_MAP_WEST   fresh            1230    30.0      0 ms       2    +0.4 ms\n"
      "east   OCCMAP_MAP_EAST   down              900    22.0     2.4 s       0   +12.3 ms\n"
      "north  OCCMAP_MAP_NORTH  never heard         0     0.0         -       0          ?\n"
      "west: 5 tiles of its maps lost on the way (their cells unseen)\n"
      "east: CLOCK 12.3 ms off the others' (more than 10 ms): its maps are judged that much too "
      "old or too new, and its cells shown at another moment than theirs (docs/merge.md: chrony "
      "or PTP)\n"
      "east: 4 tiles of its maps lost on the way (their cells unseen)\n"
      "east: 3 messages refused, last error: bad?[2Jframe\n";
  EXPECT_EQ(text, expected);

  // With what was heard beside the maps: the zones, and that no tracks came and what may be why.
  occmap::zones_t zones{};
  zones.hostname = "merge-pc";
  occmap::zone_t door{};
  door.name = "door";
  door.state = occmap::zone_t::FREE;
  door.state_s = 2.5;
  door.cells = 900;
  zones.zones = {door};
  zones.num_zones = 1;
  ZonesAndTracks heard;
  heard.zones = &zones;
  heard.listened_s = 0.3;
  const std::string with_zones = formatMergeStatusTable(status, &heard);
  const std::string no_tracks =
      "no tracks_t heard in 0.3 s (do the camera PCs send theirs? footprints: enabled: false "
      "there?)\n";
  EXPECT_EQ(with_zones,
            expected + "\nzone door  free for 2.5 s (0 of 900 cells occupied)\n" + no_tracks);
  heard.zones = nullptr;
  occmap::tracks_t tracks{};
  tracks.seq = 1205;
  heard.tracks = &tracks;
  EXPECT_EQ(formatMergeStatusTable(status, &heard),
            expected + "\nno zones_t heard in 0.3 s (are there zones: in the config?)\n" +
                "nothing tracked; 0 footprints on map 1205\n");
}

TEST(MergeStatusText, TheJsonHoldsEveryFieldAndUnknownsAsNull) {
  const occmap::merge_status_t status = threeInputsAsSent();
  const std::string text = formatMergeStatusJson(status);
  EXPECT_EQ(text.find('\n'), std::string::npos) << "one line";
  EXPECT_TRUE(std::all_of(text.begin(), text.end(), [](char c) { return c >= 0x20 && c < 0x7f; }))
      << "printable ASCII only: " << text;
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  ASSERT_TRUE(j.is_object()) << text;
  const std::vector<std::string> keys = {
      "utime",        "request_id",   "hostname",         "config_file",    "map_channel",
      "state",        "state_name",   "uptime_s",         "maps_published", "publish_errors",
      "maps_per_s",   "max_age_ms",   "latency_p50_ms",   "latency_p99_ms", "latency_last_ms",
      "merge_p50_ms", "merge_p99_ms", "clock_warning_ms", "inputs"};
  std::vector<std::string> got;
  for (auto it = j.begin(); it != j.end(); ++it) got.push_back(it.key());
  std::vector<std::string> sorted_keys = keys;
  std::sort(sorted_keys.begin(), sorted_keys.end());
  EXPECT_EQ(got, sorted_keys) << text;  // nlohmann::json sorts its keys
  EXPECT_EQ(j["state_name"], "running");
  EXPECT_EQ(j["maps_published"], 1234);
  EXPECT_EQ(j["latency_p99_ms"], 1.3);
  ASSERT_EQ(j["inputs"].size(), 3u) << text;
  EXPECT_EQ(j["inputs"][0]["name"], "west");
  EXPECT_EQ(j["inputs"][0]["state_name"], "fresh");
  EXPECT_EQ(j["inputs"][0]["lost_maps"], 2);
  EXPECT_DOUBLE_EQ(j["inputs"][1]["clock_offset_ms"].get<double>(), 12.3);
  EXPECT_EQ(j["inputs"][1]["state_name"], "down");
  EXPECT_EQ(j["inputs"][1]["last_error"], "bad\x1b[2Jframe") << "as sent, escaped in the text";
  EXPECT_NE(text.find("bad\\u001b[2Jframe"), std::string::npos) << text;
  EXPECT_EQ(j["inputs"][2]["state_name"], "never heard");
  EXPECT_TRUE(j["inputs"][2]["age_ms"].is_null()) << text;
  EXPECT_TRUE(j["inputs"][2]["clock_offset_ms"].is_null()) << text;
  EXPECT_EQ(mergeInputStateName(7), "state 7");
  EXPECT_FALSE(j.contains("zones")) << "only with what was heard beside the maps";
  occmap::merge_status_t odd = status;
  odd.inputs[0].age_ms = std::numeric_limits<double>::infinity();
  odd.inputs[0].clock_offset_ms = kNaN;
  const std::string odd_text = formatMergeStatusTable(odd);
  EXPECT_NE(odd_text.find("west   OCCMAP_MAP_WEST   fresh            1230    30.0         -       "
                          "2          ?\n"),
            std::string::npos)
      << odd_text;
}

// --- A merge node and two camera PCs on a network of their own ---

const std::string kOccmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";
const std::string kUrl = "udpm://239.255.76.67:7667?ttl=0";

// This thread, and every process it starts from now on, in a UTS namespace of its own named
// `name`: each daemon on a host of its own, as on a real site (a daemon's messages name its host).
// "" or why not.
std::string becomeHost(const std::string& name) {
  if (::unshare(CLONE_NEWUTS) != 0) {
    return std::string(
               "cannot make a UTS namespace for a host name of its own "
               "(unshare(CLONE_NEWUTS): ") +
           std::strerror(errno) + "); run the test as root or with CAP_SYS_ADMIN";
  }
  if (::sethostname(name.data(), name.size()) != 0) {
    return std::string("sethostname: ") + std::strerror(errno);
  }
  return "";
}

// A camera PC: the simulated room with one camera, its maps on a channel of its own, its status on
// the shared status channel (OCCMAP_STATUS), as every daemon's must be for `--all` to reach it.
std::string cameraPc(const std::string& name, const std::string& camera) {
  std::string config = testing::simRoomConfig(kUrl);
  config = config.substr(0, config.find("cameras:\n"));
  config.replace(config.find("transport: {"), 12,
                 "transport: {map_channel: OCCMAP_MAP_" + name + ", ");
  return config + "cameras:\n  - {name: " + camera + ", source: \"sim://room/" + camera + "\"}\n";
}

std::string mergeNode() {
  return "map: {origin_m: [-0.62, -1.87], cell_size_m: 0.04, width: 256, height: 256}\n"
         "transport: {lcm_url: \"" +
         kUrl +
         "\"}\n"
         "merge:\n"
         "  max_age_ms: 150\n"
         "  inputs:\n"
         "    - {name: west, channel: OCCMAP_MAP_WEST}\n"
         "    - {name: east, channel: OCCMAP_MAP_EAST}\n";
}

struct Daemon {
  std::optional<testing::NotifyListener> systemd;
  testing::ChildProcess process;
  Daemon(const testing::TemporaryFolder& folder, const std::string& name, const std::string& config)
      : systemd(std::in_place, folder / (name + ".notify")),
        process({kOccmapd, "--config", folder.write(name + ".yaml", config).string()},
                folder / name, {{"NOTIFY_SOCKET", (folder / (name + ".notify")).string()}}) {}
  bool ready() {
    const bool ready = systemd->collect(testing::eventually(30s), "READY=1");
    systemd.reset();  // a socket nobody reads would fill and block the daemon's sd_notify
    return ready;
  }
};

// `occmap status --all --json` as objects, one per daemon that answered.
std::vector<nlohmann::json> everyDaemon(const std::string& timeout = "1") {
  const testing::CommandResult result =
      testing::runCommand({kOccmap, "status", "--all", "--json", "--timeout", timeout});
  std::vector<nlohmann::json> daemons;
  std::istringstream lines(result.out);
  for (std::string line; std::getline(lines, line);) {
    daemons.push_back(nlohmann::json::parse(line, nullptr, false));
  }
  return daemons;
}

// The merge node's object among them, or null.
nlohmann::json mergeNodeOf(const std::vector<nlohmann::json>& daemons) {
  for (const nlohmann::json& daemon : daemons) {
    if (daemon.is_object() && daemon.contains("inputs")) return daemon;
  }
  return nullptr;
}

// The input states of the merge node as `--all --json` has them, e.g. "fresh fresh".
std::string inputStates(const nlohmann::json& node) {
  std::string states;
  if (!node.is_object()) return "no merge node";
  for (const nlohmann::json& input : node["inputs"]) {
    states += (states.empty() ? "" : " ") + input["state_name"].get<std::string>();
  }
  return states;
}

// Polls `occmap status --all --json` until the merge node's inputs are in `states`.
bool inputsBecome(const std::string& states, std::chrono::milliseconds deadline,
                  std::string& last) {
  const auto end = std::chrono::steady_clock::now() + deadline;
  while (std::chrono::steady_clock::now() < end) {
    last = inputStates(mergeNodeOf(everyDaemon()));
    if (last == states) return true;
  }
  return false;
}

std::size_t occurrences(const std::string& text, const std::string& part) {
  std::size_t count = 0;
  for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) {
    ++count;
  }
  return count;
}

TEST(MergeStatusLive, StatusShowsTheMergeNodesInputsAndAllListsEveryDaemon) {
  if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
    GTEST_SKIP() << problem;
  }
  testing::TemporaryFolder folder;
  if (const std::string problem = becomeHost("merge-pc"); !problem.empty()) GTEST_SKIP() << problem;
  Daemon merge(folder, "merge", mergeNode());
  ASSERT_TRUE(merge.ready()) << merge.process.err();

  // Alone on the bus, before any camera PC: its inputs never heard.
  testing::CommandResult result = testing::runCommand({kOccmap, "status", "--timeout", "5"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_EQ(result.out.find("occmapd merge node on merge-pc (config "), 0u) << result.out;
  EXPECT_NE(result.out.find("\nwest   OCCMAP_MAP_WEST  never heard         0     0.0         -  "),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("\neast   OCCMAP_MAP_EAST  never heard "), std::string::npos)
      << result.out;
  std::printf("occmap status, the merge node alone:\n%s\n", result.out.c_str());

  ASSERT_EQ(becomeHost("west-pc"), "");
  auto west = std::make_unique<Daemon>(folder, "west", cameraPc("WEST", "c0"));
  ASSERT_EQ(becomeHost("east-pc"), "");
  Daemon east(folder, "east", cameraPc("EAST", "c2"));
  ASSERT_TRUE(west->ready()) << west->process.err();
  ASSERT_TRUE(east.ready()) << east.process.err();
  std::string states;
  ASSERT_TRUE(inputsBecome("fresh fresh", testing::eventually(15s), states)) << states << "\n"
                                                                             << merge.process.err();
  // A few periodic statuses, so that the rates are measured over seconds of maps.
  std::this_thread::sleep_for(2s);

  // One request: every daemon, each as it is shown alone, by host.
  // Under a sanitizer on a busy machine the merge node falls seconds behind its inputs' maps,
  // and the request waits behind them in its socket (seen under TSan): it is given longer.
  const std::string timeout = testing::kSanitized ? "6" : "1.5";
  const auto asked = std::chrono::steady_clock::now();
  result = testing::runCommand({kOccmap, "status", "--all", "--timeout", timeout});
  const double waited_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - asked).count();
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  const std::string& all = result.out;
  std::printf("occmap status --all:\n%s\n", all.c_str());
  EXPECT_GE(waited_s, 1.5) << "--all waits the whole --timeout";
  const std::size_t east_at = all.find("occmapd on east-pc (config ");
  const std::size_t merge_at = all.find("\n\noccmapd merge node on merge-pc (config ");
  const std::size_t west_at = all.find("\n\noccmapd on west-pc (config ");
  EXPECT_EQ(east_at, 0u) << all;
  ASSERT_NE(merge_at, std::string::npos) << all;
  ASSERT_NE(west_at, std::string::npos) << all;
  EXPECT_LT(merge_at, west_at) << "sorted by host:\n" << all;
  EXPECT_EQ(occurrences(all, "occmapd on "), 2u) << "each camera PC once:\n" << all;
  EXPECT_EQ(occurrences(all, "occmapd merge node on "), 1u) << all;
  const std::string merge_table = all.substr(merge_at, west_at - merge_at);
  EXPECT_NE(merge_table.find("\nwest   OCCMAP_MAP_WEST  fresh  "), std::string::npos)
      << merge_table;
  EXPECT_NE(merge_table.find("\neast   OCCMAP_MAP_EAST  fresh  "), std::string::npos)
      << merge_table;
  EXPECT_NE(merge_table.find("\n  inputs fresh: 2 of 2 (within 150 ms of the newest input's "
                             "capture)\n"),
            std::string::npos)
      << merge_table;
  EXPECT_NE(merge_table.find("\n  latency from the newest input's arrival to publish: p50 "),
            std::string::npos)
      << merge_table;
  EXPECT_NE(all.substr(0, merge_at).find("\nc2 "), std::string::npos) << "east's camera:\n" << all;
  EXPECT_NE(all.substr(west_at).find("\nc0 "), std::string::npos) << "west's camera:\n" << all;

  // Without --all, the first daemon to answer, and a word on stderr that others answered too.
  result = testing::runCommand({kOccmap, "status", "--timeout", "5"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_EQ(occurrences(result.out, "occmapd "), 1u) << result.out;
  if (!testing::kSanitized) {
    EXPECT_NE(result.err.find(" answered on OCCMAP_STATUS_REQUEST (the first is shown): --all "
                              "lists them all\n"),
              std::string::npos)
        << result.err;
  }

  // The same as JSON, one object a line; the merge node's figures are the node's own.
  const std::vector<nlohmann::json> daemons = everyDaemon(timeout);
  ASSERT_EQ(daemons.size(), 3u);
  std::vector<std::string> hosts;
  for (const nlohmann::json& daemon : daemons) {
    ASSERT_TRUE(daemon.is_object());
    hosts.push_back(daemon["hostname"].get<std::string>());
  }
  EXPECT_EQ(hosts, (std::vector<std::string>{"east-pc", "merge-pc", "west-pc"}));
  const nlohmann::json& node = daemons[1];
  ASSERT_TRUE(node.contains("inputs")) << node.dump();
  EXPECT_EQ(node["state_name"], "running");
  EXPECT_EQ(node["map_channel"], "OCCMAP_MAP");
  EXPECT_GT(node["maps_published"].get<std::int64_t>(), 0) << node.dump();
  EXPECT_GT(node["maps_per_s"].get<double>(), 0.0) << node.dump();
  EXPECT_GT(node["latency_last_ms"].get<double>(), 0.0) << node.dump();
  EXPECT_GE(node["latency_p99_ms"].get<double>(), node["latency_p50_ms"].get<double>());
  EXPECT_GT(node["merge_p99_ms"].get<double>(), 0.0) << node.dump();
  EXPECT_EQ(node["clock_warning_ms"], 10.0);
  for (const nlohmann::json& input : node["inputs"]) {
    EXPECT_EQ(input["state_name"], "fresh") << node.dump();
    EXPECT_GT(input["maps"].get<std::int64_t>(), 0) << node.dump();
    EXPECT_GT(input["maps_per_s"].get<double>(), 0.0) << node.dump();
    EXPECT_TRUE(input["age_ms"].is_number()) << node.dump();
    EXPECT_TRUE(input["clock_offset_ms"].is_number()) << "known once heard: " << node.dump();
    EXPECT_EQ(input["refused"], 0) << node.dump();
  }
  EXPECT_TRUE(daemons[0].contains("cameras") && !daemons[0].contains("inputs"));

  // West gone: the merge node says it is down, and --all no longer lists west-pc.
  west->process.signal(SIGKILL);
  west.reset();
  ASSERT_TRUE(inputsBecome("down fresh", testing::eventually(10s), states)) << states;
  result = testing::runCommand({kOccmap, "status", "--all", "--timeout", "1"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_EQ(result.out.find("occmapd on west-pc"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("\nwest   OCCMAP_MAP_WEST  down   "), std::string::npos) << result.out;
  std::printf("occmap status --all, west killed:\n%s\n", result.out.c_str());

  merge.process.signal(SIGTERM);
  EXPECT_EQ(merge.process.waitExit(testing::eventually(5s)).value_or(-100), 0)
      << merge.process.err();
  EXPECT_NE(merge.process.err().find("status on OCCMAP_STATUS_MERGE"), std::string::npos)
      << merge.process.err();
}

// Nobody on the bus: --all says so and exits 3, as `occmap status` alone does.
TEST(MergeStatusLive, AllWithNoDaemonIsNoResult) {
  if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
    GTEST_SKIP() << problem;
  }
  const testing::CommandResult result =
      testing::runCommand({kOccmap, "status", "--all", "--timeout", "0.5"});
  EXPECT_EQ(result.exit_code, 3) << result.out << result.err;
  EXPECT_EQ(result.out, "");
  EXPECT_NE(result.err.find("no occmapd answered within 0.5 s (1 request on OCCMAP_STATUS_REQUEST"),
            std::string::npos)
      << result.err;
}

}  // namespace
}  // namespace occmap
