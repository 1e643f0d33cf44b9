// The Python example (examples/python/map_subscriber.py), run as a user would with Debian's
// python3: it decodes every map of an LCM log written by LCM's own C++ API (raw and zstd, with
// other channels and a damaged message in between), and every map a live publisher sends over UDP
// multicast, in single datagrams and in fragments (512 x 512 raw maps, which need a larger receive
// buffer than a stock kernel allows, are python_example_raw_test); and the zones and tracks
// published beside the maps, in a log and live.
#include "python_example.h"

#include <cmath>
#include <cstdarg>
#include <map>
#include <sstream>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <occmap/status_t.hpp>

#include "base/format_text.h"
#include "footprint_scenes.h"
#include "map_scenes.h"
#include "transport/footprints_message.h"
#include "transport/map_codec.h"

namespace occmap {
namespace {

using testing::CellShares;
using testing::kPython;
using testing::kScript;
using testing::kTypes;
using testing::missingPython;
using testing::PythonExampleLive;
using testing::runCommand;
using testing::TemporaryFolder;

// What the script printed for one map.
struct PrintedMap {
  std::string line;
  double occupied = -1, free = -1, unseen = -1;
  std::string used;
};

std::map<std::int64_t, PrintedMap> printedMaps(const std::string& out) {
  std::map<std::int64_t, PrintedMap> maps;
  std::istringstream lines(out);
  std::string line;
  while (std::getline(lines, line)) {
    if (!line.starts_with("seq ")) continue;
    PrintedMap printed;
    printed.line = line;
    const auto number = [&](const std::string& label) {
      const std::size_t at = line.find(label);
      return at == std::string::npos ? -1.0 : std::stod(line.substr(at + label.size()));
    };
    printed.occupied = number("occupied ");
    printed.free = number("free ");
    printed.unseen = number("unseen ");
    printed.used = line.substr(line.rfind(": ") + 2);
    maps[std::stoll(line.substr(4))] = printed;
  }
  return maps;
}

// A map the script must have printed with these shares (to its two decimals) and cameras.
void expectPrinted(const std::map<std::int64_t, PrintedMap>& printed, const MapFrame& frame,
                   const std::vector<std::string>& names) {
  const auto found = printed.find(frame.seq);
  ASSERT_NE(found, printed.end()) << "no line for seq " << frame.seq;
  const CellShares shares = testing::cellShares(frame.map.cells);
  EXPECT_NEAR(found->second.occupied, 100 * shares.occupied, 0.0051) << found->second.line;
  EXPECT_NEAR(found->second.free, 100 * shares.free, 0.0051) << found->second.line;
  EXPECT_NEAR(found->second.unseen, 100 * shares.unseen, 0.0051) << found->second.line;
  std::string used;
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (frame.cameras[k].used) used += (used.empty() ? "" : ",") + names[k];
  }
  EXPECT_EQ(found->second.used, used.empty() ? "-" : used) << found->second.line;
}

class LogWriter {
 public:
  explicit LogWriter(const std::filesystem::path& file) : log_(file.string(), "w") {
    EXPECT_TRUE(log_.good()) << "cannot write " << file;
  }
  void write(const std::string& channel, std::span<const std::uint8_t> data) {
    lcm::LogEvent event{};
    event.timestamp = utime_ += 33'333;
    event.channel = channel;
    event.datalen = static_cast<std::int32_t>(data.size());
    event.data = const_cast<std::uint8_t*>(data.data());
    ASSERT_EQ(log_.writeEvent(&event), 0);
  }

 private:
  lcm::LogFile log_;
  std::int64_t utime_ = 1'700'000'000'000'000;
};

TEST(PythonExample, DecodesEveryMapOfAnLcmLog) {
  if (const std::string why = missingPython(); !why.empty()) GTEST_SKIP() << why;
  ASSERT_TRUE(std::filesystem::exists(kTypes + "/occmap/map_frame_t.py"))
      << "the build did not make the Python types in " << kTypes;
  TemporaryFolder folder;
  const auto log_file = folder / "maps.lcmlog";
  std::vector<MapFrame> frames;
  std::vector<std::vector<std::string>> names;
  {
    LogWriter log(log_file);
    const auto add = [&](const MapGeometry& geometry, std::size_t cameras, MapEncoding encoding,
                         std::int64_t seq) {
      names.push_back(testing::sceneCameraNames(cameras));
      frames.emplace_back(geometry, cameras);
      frames.back().utime = 1'700'000'000'000'000 + seq;
      testing::fillScene(frames.back(), seq);
      MapEncoder encoder(geometry, names.back(), encoding);
      log.write("OCCMAP_MAP", encoder.encode(frames.back()));
    };
    for (std::int64_t seq = 0; seq < 4; ++seq) add({0, 0, 0.05, 64, 48}, 2, MapEncoding::kRaw, seq);
    occmap::status_t status{};
    status.request_id = -1;
    status.hostname = "somewhere";
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(status.getEncodedSize()));
    status.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    log.write("OCCMAP_STATUS", bytes);
    for (std::int64_t seq = 4; seq < 8; ++seq) {
      add({-0.5, -1.5, 0.02, 512, 512}, 4, MapEncoding::kZstd, seq);
    }
    // A map cut short: the script must say so and go on.
    MapEncoder encoder({0, 0, 0.05, 64, 48}, testing::sceneCameraNames(2), MapEncoding::kZstd);
    MapFrame cut({0, 0, 0.05, 64, 48}, 2);
    const auto whole = encoder.encode(cut);
    log.write("OCCMAP_MAP", whole.first(whole.size() - 5));
    // seq 8 never came.
    for (std::int64_t seq = 9; seq < 11; ++seq) {
      add({1, 2, 0.1, 100, 80}, 3, MapEncoding::kZstd, seq);
    }
  }
  const std::string summary = "maps 10, lost 1 (seq gaps), undecodable 1, other channels 1";
  // The types given with --types ...
  auto result = runCommand({kPython, kScript, "--types", kTypes, "--log", log_file.string()});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find(summary), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("undecodable message"), std::string::npos) << result.out;
  const auto printed = printedMaps(result.out);
  EXPECT_EQ(printed.size(), frames.size()) << result.out;
  for (std::size_t i = 0; i < frames.size(); ++i) expectPrinted(printed, frames[i], names[i]);
  EXPECT_NE(printed.at(0).line.find("64x48 raw"), std::string::npos) << printed.at(0).line;
  EXPECT_NE(printed.at(5).line.find("512x512 zstd"), std::string::npos) << printed.at(5).line;

  // ... or found on PYTHONPATH.
  result = runCommand(
      {"/usr/bin/env", "PYTHONPATH=" + kTypes, kPython, kScript, "--log", log_file.string()});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find(summary), std::string::npos) << result.out;
  // --count stops early.
  result =
      runCommand({kPython, kScript, "--types", kTypes, "--log", log_file.string(), "--count", "3"});
  EXPECT_EQ(printedMaps(result.out).size(), 3u) << result.out;

  // Without the types it says where to get them.
  result = runCommand(
      {"/usr/bin/env", "-u", "PYTHONPATH", kPython, kScript, "--log", log_file.string()});
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
  EXPECT_NE(result.err.find("give --types build/lcmtypes/python or put that folder on PYTHONPATH"),
            std::string::npos)
      << result.err;
  // A log without maps: exit 3.
  {
    LogWriter empty(folder / "empty.lcmlog");
    const std::vector<std::uint8_t> bytes = {1, 2, 3};
    empty.write("OTHER", bytes);
  }
  result = runCommand(
      {kPython, kScript, "--types", kTypes, "--log", (folder / "empty.lcmlog").string()});
  EXPECT_EQ(result.exit_code, 3) << result.out << result.err;
}

// Single datagrams (zstd, 512 x 512) and fragments (raw 256 x 256: 65 669 bytes, two fragments).
TEST_F(PythonExampleLive, ReceivesMapsInDatagramsAndFragments) {
  const std::string out = receive("udpm://239.255.76.67:7667?ttl=0", 20,
                                  {{"--count", "10", "--rate", "30"},
                                   {"--count", "10", "--rate", "20", "--encoding", "raw", "--width",
                                    "256", "--height", "256", "--first-seq", "10"}});
  std::printf("%s", out.substr(0, out.find('\n') + 1).c_str());  // which receiver it used
  EXPECT_NE(out.find("maps 20, lost 0 (seq gaps), undecodable 0"), std::string::npos) << out;
  const auto printed = printedMaps(out);
  for (std::int64_t seq = 0; seq < 20; ++seq) {
    MapFrame frame(MapGeometry{-0.5, -1.5, 0.02, seq < 10 ? 512 : 256, seq < 10 ? 512 : 256}, 4);
    testing::fillScene(frame, seq);
    expectPrinted(printed, frame, testing::sceneCameraNames(4));
  }
}

// The line the script prints for a zones_t, from its fields: "zones seq S: " and, per zone, its
// name, state and for how long, with its occupied or unseen cells.
std::string zonesLine(const occmap::zones_t& zones) {
  const char* states[] = {"free", "occupied", "unseen"};
  std::string line = formatText("zones seq %lld: ", static_cast<long long>(zones.seq));
  for (std::size_t k = 0; k < zones.zones.size(); ++k) {
    const occmap::zone_t& zone = zones.zones[k];
    line += formatText("%s%s %s for %.1f s", k == 0 ? "" : ", ", zone.name.c_str(),
                       states[zone.state], zone.state_s);
    if (zone.occupied_cells != 0) {
      line += formatText(" (%d of %d cells occupied)", zone.occupied_cells, zone.cells);
    } else if (zone.unseen_cells != 0) {
      line += formatText(" (%d of %d cells unseen)", zone.unseen_cells, zone.cells);
    }
  }
  return line + "\n";
}

// The line for a tracks_t: "tracks seq S: N tracked: #ID at (X, Y) m moving V m/s, ...; F
// footprints".
std::string tracksLine(const occmap::tracks_t& tracks) {
  std::string line = formatText("tracks seq %lld: ", static_cast<long long>(tracks.seq));
  if (tracks.tracks.empty()) line += "none tracked";
  for (std::size_t k = 0; k < tracks.tracks.size(); ++k) {
    const occmap::track_t& t = tracks.tracks[k];
    if (k == 0) line += formatText("%zu tracked: ", tracks.tracks.size());
    line += formatText("%s#%d at (%.2f, %.2f) m moving %.2f m/s", k == 0 ? "" : ", ", t.id, t.x_m,
                       t.y_m, std::hypot(t.vx_m_s, t.vy_m_s));
  }
  const std::size_t found = tracks.footprints.size();
  return line + formatText("; %zu footprint%s\n", found, found == 1 ? "" : "s");
}

std::size_t countLines(const std::string& out, const std::string& start) {
  std::size_t lines = 0;
  for (std::size_t at = out.find("\n" + start); at != std::string::npos;
       at = out.find("\n" + start, at + 1)) {
    ++lines;
  }
  return lines;
}

template <typename Message>
std::vector<std::uint8_t> encoded(const Message& message) {
  std::vector<std::uint8_t> data(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(data.data(), 0, static_cast<int>(data.size()));
  return data;
}

// Three seconds of maps with their zones and tracks, as occmapd logs them (lcm-logger): every
// zones_t and tracks_t printed with --every 0; by default the first, then one a second of their
// time, and the zones whenever one changes state; damaged ones said and counted.
TEST(PythonExample, PrintsTheZonesAndTracksBesideTheMapsOfAnLcmLog) {
  if (const std::string why = missingPython(); !why.empty()) GTEST_SKIP() << why;
  TemporaryFolder folder;
  const auto log_file = folder / "maps.lcmlog";
  constexpr std::int64_t kMaps = 90;
  constexpr std::int64_t kFirstUtime = 1'700'000'000'000'000;
  std::vector<occmap::zones_t> zones;
  std::vector<occmap::tracks_t> tracks;
  {
    LogWriter log(log_file);
    const MapGeometry geometry{0, 0, 0.05, 64, 48};
    MapEncoder encoder(geometry, testing::sceneCameraNames(2), MapEncoding::kRaw);
    for (std::int64_t seq = 0; seq < kMaps; ++seq) {
      MapFrame frame(geometry, 2);
      frame.seq = seq;
      frame.utime = kFirstUtime + seq * 33'333;
      testing::fillScene(frame, seq);
      log.write("OCCMAP_MAP", encoder.encode(frame));
      zones.push_back(testing::sceneZones(seq, frame.utime));
      log.write(zonesChannel("OCCMAP_MAP"), encoded(zones.back()));
      tracks.push_back(testing::sceneTracks(seq, frame.utime));
      log.write(tracksChannel("OCCMAP_MAP"), encoded(tracks.back()));
    }
    // Damaged: a zones_t cut short, one with a byte too many, a tracks_t with a negative count.
    const std::vector<std::uint8_t> whole = encoded(zones.front());
    log.write("OCCMAP_MAP_ZONES", std::span(whole).first(whole.size() - 3));
    std::vector<std::uint8_t> longer = whole;
    longer.push_back(0);
    log.write("OCCMAP_MAP_ZONES", longer);
    std::vector<std::uint8_t> negative = encoded(tracks.front());
    const std::size_t count_at = 8 + 8 + 8 + 4 + tracks.front().hostname.size() + 1;
    negative[count_at] = 0xFF;
    negative[count_at + 1] = 0xFF;
    log.write("OCCMAP_MAP_TRACKS", negative);
  }
  auto result =
      runCommand({kPython, kScript, "--types", kTypes, "--log", log_file.string(), "--every", "0"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find("maps 90, lost 0 (seq gaps), undecodable 3, other channels 0, "
                            "zones_t 90, tracks_t 90"),
            std::string::npos)
      << result.out;
  for (std::int64_t seq = 0; seq < kMaps; ++seq) {
    const std::string& zone_line = zonesLine(zones[static_cast<std::size_t>(seq)]);
    EXPECT_NE(result.out.find("\n" + zone_line), std::string::npos)
        << "no line '" << zone_line << "' in\n"
        << result.out;
    const std::string& track_line = tracksLine(tracks[static_cast<std::size_t>(seq)]);
    EXPECT_NE(result.out.find("\n" + track_line), std::string::npos)
        << "no line '" << track_line << "' in\n"
        << result.out;
  }
  EXPECT_EQ(countLines(result.out, "zones seq "), static_cast<std::size_t>(kMaps)) << result.out;
  EXPECT_EQ(countLines(result.out, "undecodable zones_t ("), 2u) << result.out;
  EXPECT_EQ(countLines(result.out, "undecodable tracks_t ("), 1u) << result.out;

  // Once a second of the messages' own time (and the zones on each change of state): these.
  std::vector<std::int64_t> zone_seqs, track_seqs;
  std::int64_t zones_printed_at = -1, tracks_printed_at = -1;
  for (std::int64_t seq = 0; seq < kMaps; ++seq) {
    const std::size_t k = static_cast<std::size_t>(seq);
    const bool changed =
        zone_seqs.empty() ||
        zones[k].zones[0].state != zones[static_cast<std::size_t>(zone_seqs.back())].zones[0].state;
    if (changed || zones[k].utime >= zones_printed_at + 1'000'000) {
      zone_seqs.push_back(seq);
      zones_printed_at = zones[k].utime;
    }
    if (track_seqs.empty() || tracks[k].utime >= tracks_printed_at + 1'000'000) {
      track_seqs.push_back(seq);
      tracks_printed_at = tracks[k].utime;
    }
  }
  result = runCommand({kPython, kScript, "--types", kTypes, "--log", log_file.string()});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  for (const std::int64_t seq : zone_seqs) {
    EXPECT_NE(result.out.find("\n" + zonesLine(zones[static_cast<std::size_t>(seq)])),
              std::string::npos)
        << "no line for the zones of seq " << seq << " in\n"
        << result.out;
  }
  for (const std::int64_t seq : track_seqs) {
    EXPECT_NE(result.out.find("\n" + tracksLine(tracks[static_cast<std::size_t>(seq)])),
              std::string::npos)
        << "no line for the tracks of seq " << seq << " in\n"
        << result.out;
  }
  EXPECT_EQ(countLines(result.out, "zones seq "), zone_seqs.size()) << result.out;
  EXPECT_EQ(countLines(result.out, "tracks seq "), track_seqs.size()) << result.out;
  EXPECT_EQ(track_seqs.size(), 3u) << "about one a second over three seconds";
  EXPECT_GT(zone_seqs.size(), track_seqs.size()) << "the zones' changes of state too";
}

// Live: each map's zones and tracks, printed with --every 0 as they come.
TEST_F(PythonExampleLive, ReceivesTheZonesAndTracksPublishedWithTheMaps) {
  const std::string out =
      receive("udpm://239.255.76.67:7667?ttl=0", 10,
              {{"--count", "10", "--rate", "30", "--zones-and-tracks"}}, {"--every", "0"});
  EXPECT_NE(out.find("maps 10, lost 0 (seq gaps), undecodable 0"), std::string::npos) << out;
  // The script stops at the tenth map, before that map's zones and tracks arrive.
  for (std::int64_t seq = 0; seq < 9; ++seq) {
    const std::string zone_line = zonesLine(testing::sceneZones(seq, 0));
    EXPECT_NE(out.find("\n" + zone_line), std::string::npos) << "no line '" << zone_line << "' in\n"
                                                             << out;
    const std::string track_line = tracksLine(testing::sceneTracks(seq, 0));
    EXPECT_NE(out.find("\n" + track_line), std::string::npos)
        << "no line '" << track_line << "' in\n"
        << out;
  }
}

}  // namespace
}  // namespace occmap
