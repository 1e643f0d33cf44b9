// The Python example (examples/python/map_subscriber.py) reads maps sent in tiles (map_tile_t on
// the map channel + _TILES) as well as whole ones: from an LCM log written by LCM's own C++ API
// (tiles out of order, a copy, a tile lost, a damaged tile, a whole map in between), each map's
// shares printed as the C++ MapTileAssembler puts the map together, lost tiles unseen and counted;
// and live over UDP multicast from the test publisher, a tile left out.
#include <map>
#include <random>
#include <sstream>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "map_scenes.h"
#include "python_example.h"
#include "transport/map_codec.h"
#include "transport/map_tiles.h"

namespace occmap {
namespace {

using testing::kPython;
using testing::kScript;
using testing::kTypes;
using testing::missingPython;
using testing::runCommand;
using testing::TemporaryFolder;

using Bytes = std::vector<std::uint8_t>;

// The line the script printed for map `seq`, or "".
std::string lineOf(const std::string& out, std::int64_t seq) {
  std::istringstream lines(out);
  std::string line;
  const std::string start = "seq " + std::to_string(seq) + " ";
  while (std::getline(lines, line)) {
    if (line.starts_with(start)) return line;
  }
  return "";
}

double numberAfter(const std::string& line, const std::string& label) {
  const std::size_t at = line.find(label);
  return at == std::string::npos ? -1.0 : std::stod(line.substr(at + label.size()));
}

// The script's line for `map` (as the C++ assembler gave it out) shows its shares, its tiles and
// how many were lost.
void expectPrinted(const std::string& out, const DecodedMap& map, const MapTiles& tiles) {
  const std::string line = lineOf(out, map.seq);
  ASSERT_NE(line, "") << "no line for seq " << map.seq << ":\n" << out;
  std::vector<CellState> cells(map.cells.size());
  for (std::size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<CellState>(map.cells[i]);
  const testing::CellShares shares = testing::cellShares(cells);
  EXPECT_NEAR(numberAfter(line, "occupied "), 100 * shares.occupied, 0.0051) << line;
  EXPECT_NEAR(numberAfter(line, "free "), 100 * shares.free, 0.0051) << line;
  EXPECT_NEAR(numberAfter(line, "unseen "), 100 * shares.unseen, 0.0051) << line;
  const std::string how =
      " in " + std::to_string(tiles.count) + " tiles (" + std::to_string(tiles.missing) + " lost) ";
  EXPECT_NE(line.find(how), std::string::npos) << "expected '" << how << "' in " << line;
}

class LogWriter {
 public:
  explicit LogWriter(const std::filesystem::path& file) : log_(file.string(), "w") {
    EXPECT_TRUE(log_.good()) << "cannot write " << file;
  }
  void write(const std::string& channel, std::span<const std::uint8_t> data) {
    lcm::LogEvent event{};
    event.timestamp = utime_ += 1'000;
    event.channel = channel;
    event.datalen = static_cast<std::int32_t>(data.size());
    event.data = const_cast<std::uint8_t*>(data.data());
    ASSERT_EQ(log_.writeEvent(&event), 0);
  }

 private:
  lcm::LogFile log_;
  std::int64_t utime_ = 1'700'000'000'000'000;
};

TEST(PythonExampleTiles, PutsTiledMapsOfAnLcmLogTogether) {
  if (const std::string why = missingPython(); !why.empty()) GTEST_SKIP() << why;
  ASSERT_TRUE(std::filesystem::exists(kTypes + "/occmap/map_tile_t.py"))
      << "the build did not make the Python type map_tile_t in " << kTypes;
  TemporaryFolder folder;
  const auto log_file = folder / "tiles.lcmlog";
  const MapGeometry geometry{-0.5, -1.5, 0.02, 700, 500};  // 3 x 3 tiles
  const auto names = testing::sceneCameraNames(3);
  // What the C++ assembler makes of the same messages, to compare the script's lines with.
  std::vector<std::pair<DecodedMap, MapTiles>> expected;
  MapTileAssembler assembler([&expected](const DecodedMap& map, const MapTiles& tiles) {
    expected.push_back({map, tiles});
  });
  {
    LogWriter log(log_file);
    const auto write = [&](const std::string& channel, std::span<const std::uint8_t> bytes) {
      log.write(channel, bytes);
      if (channel == "OCCMAP_MAP_TILES") assembler.take(bytes.data(), bytes.size());
    };
    std::mt19937 rng(3);
    for (const MapEncoding encoding : {MapEncoding::kZstd, MapEncoding::kRaw}) {
      MapTileEncoder encoder(geometry, names, encoding);
      for (std::int64_t n = 0; n < 3; ++n) {
        const std::int64_t seq = (encoding == MapEncoding::kZstd ? 0 : 3) + n;
        MapFrame frame(geometry, names.size());
        frame.utime = 1'700'000'000'000'000 + seq * 33'333;
        testing::fillScene(frame, seq);
        std::vector<Bytes> tiles;
        for (int index = 0; index < encoder.tileCount(); ++index) {
          const auto message = encoder.encode(frame, index);
          tiles.emplace_back(message.begin(), message.end());
        }
        if (seq == 1) tiles.erase(tiles.begin() + 4);  // lost: the middle of the room
        if (seq == 4) tiles.erase(tiles.begin() + 8);  // lost: the last, a small one
        std::shuffle(tiles.begin(), tiles.end(), rng);
        tiles.push_back(tiles[2]);  // a copy
        if (seq == 2) {
          Bytes damaged = tiles[0];
          damaged[damaged.size() / 2] ^= 0x5a;
          damaged.resize(damaged.size() - 1);
          write("OCCMAP_MAP_TILES", damaged);
        }
        for (const Bytes& tile : tiles) write("OCCMAP_MAP_TILES", tile);
      }
    }
    // A whole map after them, as a daemon restarted without tiles would send.
    MapEncoder whole(geometry, names, MapEncoding::kZstd);
    MapFrame frame(geometry, names.size());
    frame.utime = 1'700'000'000'000'000 + 6 * 33'333;
    testing::fillScene(frame, 6);
    log.write("OCCMAP_MAP", whole.encode(frame));
  }
  assembler.flush();
  ASSERT_EQ(expected.size(), 6u);
  const auto result =
      runCommand({kPython, kScript, "--types", kTypes, "--log", log_file.string(), "--every", "0"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  for (const auto& [map, tiles] : expected) {
    SCOPED_TRACE("seq " + std::to_string(map.seq));
    expectPrinted(result.out, map, tiles);
  }
  EXPECT_NE(lineOf(result.out, 6).find("700x500 zstd "), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("undecodable map_tile_t ("), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("maps 7, lost 0 (seq gaps), undecodable 1, other channels 0"),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find(", tiles lost 2\n"), std::string::npos) << result.out;
}

class PythonExampleTilesLive : public testing::PythonExampleLive {};

TEST_F(PythonExampleTilesLive, ReadsTiledMapsOverUdpMulticast) {
  const std::string out =
      receive("udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304", 6,
              {{"--tiles", "--count", "6", "--rate", "10", "--width", "2048", "--height", "2048",
                "--drop-tile", "2:40", "--drop-tile", "2:41", "--drop-tile", "4:80"}});
  for (std::int64_t seq = 0; seq < 6; ++seq) {
    const std::string line = lineOf(out, seq);
    const std::string lost = seq == 2 ? "(2 lost)" : seq == 4 ? "(1 lost)" : "(0 lost)";
    EXPECT_NE(line.find("2048x2048 zstd in 81 tiles " + lost), std::string::npos)
        << "seq " << seq << ":\n"
        << out;
  }
  EXPECT_NE(out.find("maps 6, lost 0 (seq gaps), undecodable 0"), std::string::npos) << out;
  EXPECT_NE(out.find(", tiles lost 3\n"), std::string::npos) << out;
}

}  // namespace
}  // namespace occmap
