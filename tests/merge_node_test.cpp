// A merge node (daemon/merge_node.h) between camera PCs' daemons and its subscribers, on an
// in-memory bus: what it publishes is the rule's merge of the fresh inputs' maps, an input that
// stops counts as down (its cells unseen) once stale and is merged again with its next map, and
// inputs of another geometry are resampled.
#include "daemon/merge_node.h"

#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "config/config.h"
#include "config/input_error.h"
#include "config/rig.h"
#include "transport/footprints_message.h"
#include "transport/footprints_publisher.h"
#include "transport/map_codec.h"
#include "transport/map_publisher.h"
#include "transport/map_receiver.h"
#include "transport/memory_bus.h"

namespace occmap {
namespace {

constexpr CellState F = CellState::kFree;
constexpr CellState O = CellState::kOccupied;
constexpr CellState U = CellState::kUnseen;

MapGeometry strip(double origin_x, double cell, int width) {
  return MapGeometry{origin_x, 0.0, cell, width, 1};
}

// A camera PC's daemon: publishes maps of its geometry on its channel.
class CameraPc {
 public:
  CameraPc(MemoryNetwork& network, std::string channel, const MapGeometry& geometry)
      : bus_(network.connect()),
        channel_(std::move(channel)),
        frame_(geometry, 1),
        encoder_(geometry, {"c0"}, MapEncoding::kZstd) {}

  void publish(const std::vector<CellState>& cells, double capture_s) {
    frame_.map.cells = cells;
    frame_.utime = static_cast<std::int64_t>(capture_s * 1e6);
    frame_.seq = seq_++;
    ASSERT_TRUE(bus_->publish(channel_, encoder_.encode(frame_)));
  }

 private:
  std::unique_ptr<MemoryBus> bus_;
  std::string channel_;
  MapFrame frame_;
  MapEncoder encoder_;
  std::int64_t seq_ = 0;
};

// What subscribers hear on the merged channel.
class Listener {
 public:
  explicit Listener(MemoryNetwork& network) : bus_(network.connect()) {
    bus_->subscribe("MERGED", [this](const std::uint8_t* data, std::size_t size, std::int64_t) {
      const DecodedMap& map = decoder_.decode(data, size);
      ASSERT_TRUE(map.ok()) << map.error;
      last_ = map;
      ++heard_;
    });
  }
  void drain() {
    while (bus_->handleTimeout(0) > 0) {
    }
  }
  const DecodedMap& last() const { return last_; }
  int heard() const { return heard_; }
  std::vector<CellState> cells() const {
    std::vector<CellState> cells;
    for (const std::uint8_t c : last_.cells) cells.push_back(static_cast<CellState>(c));
    return cells;
  }

 private:
  std::unique_ptr<MemoryBus> bus_;
  MapDecoder decoder_;
  DecodedMap last_;
  int heard_ = 0;
};

void handleAll(MergeNode& node) {
  while (node.spinOnce(0) > 0) {
  }
}

TEST(MergeNode, PublishesTheFreshInputsMergedAndTurnsAStaleOneUnseen) {
  MemoryNetwork network;
  const MapGeometry g = strip(0, 1, 4);
  auto node_bus = network.connect();
  MergeNode node(*node_bus, g, {{"west", "MAP_WEST"}, {"east", "MAP_EAST"}}, 0.150, "MERGED",
                 MapEncoding::kZstd);
  Listener listener(network);
  CameraPc west(network, "MAP_WEST", g);
  CameraPc east(network, "MAP_EAST", g);

  west.publish({F, O, U, U}, 10.000);
  handleAll(node);
  listener.drain();
  EXPECT_EQ(listener.cells(), (std::vector<CellState>{F, O, U, U}));  // east not heard: down
  // East's map alone: west has brought nothing since, and no frame period has passed: held.
  east.publish({O, U, F, O}, 10.010);
  handleAll(node);
  listener.drain();
  EXPECT_EQ(listener.heard(), 1);
  // West's next: every fresh input has a new map, out goes the merge.
  west.publish({F, O, U, U}, 10.0 + 1 / 30.0);
  handleAll(node);
  listener.drain();
  EXPECT_EQ(listener.heard(), 2);
  EXPECT_EQ(listener.cells(), (std::vector<CellState>{F, O, F, O}));
  EXPECT_EQ(listener.last().utime, 10'033'333);
  ASSERT_EQ(listener.last().cameras.size(), 2u);
  EXPECT_EQ(listener.last().cameras[1].name, "east");
  EXPECT_EQ(listener.last().cameras[1].state, CameraState::kStreaming);

  // East stops; west goes on at 30 Hz, a merged map each (a frame period passes each time): east
  // is down once 0.15 s behind, its cells unseen.
  for (int frame = 2; frame <= 7; ++frame) west.publish({F, O, U, U}, 10.0 + frame / 30.0);
  handleAll(node);
  listener.drain();
  EXPECT_EQ(listener.heard(), 8);
  EXPECT_EQ(listener.cells(), (std::vector<CellState>{F, O, U, U}));
  EXPECT_EQ(listener.last().cameras[1].state, CameraState::kDown);
  EXPECT_FALSE(node.inputs()[1].fresh);
  EXPECT_NEAR(*node.inputs()[1].age_s, 0.2233333, 1e-6);
  // Its next map makes it fresh again, merged in the next map out.
  east.publish({O, U, F, O}, 10.205);
  handleAll(node);
  west.publish({F, O, U, U}, 10.0 + 8 / 30.0);
  handleAll(node);
  listener.drain();
  EXPECT_EQ(listener.cells(), (std::vector<CellState>{F, O, F, O}));
  EXPECT_EQ(listener.last().cameras[1].state, CameraState::kStreaming);
  EXPECT_EQ(node.inputs()[0].maps, 9u);
  // East's occmapd restarted: its seq counts from 0 again, its captures are newer: merged.
  CameraPc east_again(network, "MAP_EAST", g);
  east_again.publish({O, U, U, F}, 10.0 + 8.5 / 30.0);
  handleAll(node);
  west.publish({F, O, U, U}, 10.0 + 9 / 30.0);
  handleAll(node);
  listener.drain();
  EXPECT_EQ(listener.cells(), (std::vector<CellState>{F, O, U, F}));
  EXPECT_EQ(node.inputs()[1].maps, 3u);
  EXPECT_EQ(node.inputs()[1].lost, 0u);
  EXPECT_EQ(listener.heard(), static_cast<int>(node.published()));
}

TEST(MergeNode, InputsOfAnotherGeometryAreResampledAndBadMessagesCounted) {
  MemoryNetwork network;
  const MapGeometry merged = strip(0, 0.5, 8);
  auto node_bus = network.connect();
  MergeNode node(*node_bus, merged, {{"coarse", "MAP_COARSE"}}, 0.150, "MERGED", MapEncoding::kRaw);
  Listener listener(network);
  CameraPc coarse(network, "MAP_COARSE", strip(1, 1, 3));
  coarse.publish({F, O, U}, 1.0);
  handleAll(node);
  listener.drain();
  EXPECT_EQ(listener.cells(), (std::vector<CellState>{U, U, F, F, O, O, U, U}));
  auto rogue = network.connect();
  const std::uint8_t junk[] = {1, 2, 3};
  rogue->publish("MAP_COARSE", junk);
  handleAll(node);
  EXPECT_EQ(node.inputs()[0].refused, 1u);
  EXPECT_FALSE(node.inputs()[0].last_error.empty());
}

// A zone of the config gets its state on every merged map, sent right after it, as occmapd does.
TEST(MergeNode, ZonesHaveAStateOnEveryMergedMap) {
  MemoryNetwork network;
  const MapGeometry g = strip(0, 1, 4);
  auto node_bus = network.connect();
  const std::vector<ZoneSpec> zones = {{"dock", {{2.0, 0.0}, {4.0, 0.0}, {4.0, 1.0}, {2.0, 1.0}}}};
  MergeNode node(*node_bus, g, {{"west", "MAP_WEST"}, {"east", "MAP_EAST"}}, 0.150, "MERGED",
                 MapEncoding::kRaw, zones);
  auto listener = network.connect();
  std::vector<occmap::zones_t> heard;
  listener->subscribe(zonesChannel("MERGED"),
                      [&](const std::uint8_t* data, std::size_t size, std::int64_t) {
                        const auto decoded = decodeZones(data, size);
                        ASSERT_TRUE(decoded);
                        heard.push_back(*decoded);
                      });
  CameraPc west(network, "MAP_WEST", g);
  CameraPc east(network, "MAP_EAST", g);
  west.publish({F, O, U, U}, 1.000);  // the dock (cells 2 and 3) unseen
  handleAll(node);
  east.publish({O, U, F, O}, 1.010);
  handleAll(node);
  west.publish({F, O, U, U}, 1.0 + 1 / 30.0);  // merged: the dock's cell 3 occupied
  handleAll(node);
  while (listener->handleTimeout(0) > 0) {
  }
  ASSERT_EQ(heard.size(), 2u);
  ASSERT_EQ(heard[0].num_zones, 1);
  EXPECT_EQ(heard[0].zones[0].name, "dock");
  EXPECT_EQ(heard[0].zones[0].state, occmap::zone_t::UNSEEN);
  EXPECT_EQ(heard[1].zones[0].state, occmap::zone_t::OCCUPIED);
  EXPECT_EQ(heard[1].zones[0].occupied_cells, 1);
  EXPECT_EQ(heard[1].seq, 1);  // the merged map's own seq
}

// Large floors: camera PCs that send their maps in tiles and one that sends them whole, merged
// into a map sent in tiles (transport/map_tiles.h); a lost tile is counted for its input and its
// cells are unseen there.
TEST(MergeNode, TiledInputsAndTiledOutput) {
  MemoryNetwork network;
  const MapGeometry g{0.0, 0.0, 0.05, 600, 300};  // 7 tiles of 240 x 240 a map
  auto node_bus = network.connect();
  MergeNode node(*node_bus, g, {{"west", "MAP_WEST"}, {"east", "MAP_EAST"}}, 0.150, "MERGED",
                 MapEncoding::kZstd, {}, "merge", MapMessages::kTiles);
  auto listener_bus = network.connect();
  DecodedMap heard;
  int maps_heard = 0;
  MapReceiver listener(*listener_bus, "MERGED", [&](const DecodedMap& map, std::int64_t) {
    heard = map;
    ++maps_heard;
  });
  auto west_bus = network.connect();
  auto east_bus = network.connect();
  MapPublisher west(g, {"c0"}, MapEncoding::kZstd, "MAP_WEST", "test", MapMessages::kTiles);
  MapPublisher east(g, {"c1"}, MapEncoding::kZstd, "MAP_EAST", "test", MapMessages::kWhole);
  MapFrame west_map(g, 1), east_map(g, 1);
  // West frees the left half, east the bottom rows; the rest is seen occupied by west.
  for (int row = 0; row < g.height; ++row) {
    for (int column = 0; column < g.width; ++column) {
      west_map.map.cells[static_cast<std::size_t>(g.index(row, column))] = column < 300 ? F : O;
      east_map.map.cells[static_cast<std::size_t>(g.index(row, column))] = row < 100 ? F : U;
    }
  }
  for (int frame = 0; frame < 3; ++frame) {
    west_map.utime = 1'000'000 + frame * 33'333;
    east_map.utime = west_map.utime + 1'000;
    ASSERT_TRUE(west.publish(*west_bus, west_map));
    handleAll(node);
    ASSERT_TRUE(east.publish(*east_bus, east_map));
    handleAll(node);
  }
  while (listener_bus->handleTimeout(0) > 0) {
  }
  ASSERT_GE(maps_heard, 2);
  EXPECT_EQ(listener.tilesOfMap().count, 6);  // 600 x 300 cells: 3 x 2 tiles of 240
  EXPECT_EQ(listener.tilesOfMap().missing, 0);
  ASSERT_EQ(heard.cells.size(), g.cellCount());
  EXPECT_EQ(heard.cells[g.index(250, 10)], 0);   // west frees it
  EXPECT_EQ(heard.cells[g.index(50, 500)], 0);   // east frees it
  EXPECT_EQ(heard.cells[g.index(250, 500)], 1);  // seen by west, freed by none
  EXPECT_EQ(node.inputs()[0].tiles_lost, 0u);
  EXPECT_EQ(node.publishErrors(), 0u);
}

// The people: each PC's occmapd finds them with its own cameras and sends them with its maps; the
// node merges what two PCs found of one person into one and tracks them on the merged map.
TEST(MergeNode, PeopleFoundByTwoPcsAreOnePersonTrackedOnTheMergedMap) {
  MemoryNetwork network;
  const MapGeometry g{0.0, 0.0, 0.1, 100, 50};  // 10 m x 5 m
  auto node_bus = network.connect();
  MergeNode node(*node_bus, g, {{"west", "MAP_WEST"}, {"east", "MAP_EAST"}}, 0.150, "MERGED",
                 MapEncoding::kZstd);
  auto listener = network.connect();
  std::vector<occmap::tracks_t> heard;
  listener->subscribe(tracksChannel("MERGED"),
                      [&](const std::uint8_t* data, std::size_t size, std::int64_t) {
                        const auto decoded = decodeTracks(data, size);
                        ASSERT_TRUE(decoded);
                        heard.push_back(*decoded);
                      });
  CameraPc west(network, "MAP_WEST", g);
  CameraPc east(network, "MAP_EAST", g);
  auto west_people = network.connect();
  auto east_people = network.connect();
  FootprintsPublisher west_found("MAP_WEST", "west-pc", {});
  FootprintsPublisher east_found("MAP_EAST", "east-pc", {});
  const std::vector<CellState> floor(g.cellCount(), F);
  // Ann walks east through the middle, where both PCs see her (each a few cm off); Bob stands in
  // the east, which only east sees; Cy and Dee stand 0.4 m apart in the west, seen by west alone:
  // two people, never joined.
  for (int frame = 0; frame < 20; ++frame) {
    const double t = 5.0 + frame / 30.0;
    const double ann_x = 4.0 + 1.2 * (t - 5.0);
    const std::vector<Detection> by_west = {{ann_x + 0.03, 2.5, 0.2, 0.8, 1.75},
                                            {1.0, 1.0, 0.2, 0.9, 1.75},
                                            {1.0, 1.4, 0.2, 0.9, 1.75}};
    const std::vector<Detection> by_east = {{ann_x - 0.04, 2.52, 0.25, 0.6, 1.75},
                                            {8.0, 3.0, 0.2, 0.7, 1.75}};
    west.publish(floor, t);
    ASSERT_TRUE(west_found.publishTracks(*west_people, frame, static_cast<std::int64_t>(t * 1e6),
                                         by_west, {}));
    handleAll(node);
    east.publish(floor, t + 0.002);
    ASSERT_TRUE(east_found.publishTracks(
        *east_people, frame, static_cast<std::int64_t>((t + 0.002) * 1e6), by_east, {}));
    handleAll(node);
  }
  while (listener->handleTimeout(0) > 0) {
  }
  ASSERT_FALSE(heard.empty());
  const occmap::tracks_t& last = heard.back();
  EXPECT_EQ(last.num_footprints, 4) << "Ann once, Bob, Cy and Dee";
  ASSERT_EQ(last.num_tracks, 4);
  EXPECT_EQ(node.tracks().size(), 4u);
  const double ann_x = 4.0 + 1.2 * 19 / 30.0;
  bool ann = false;
  for (const occmap::track_t& track : last.tracks) {
    if (std::abs(track.y_m - 2.5) < 0.1) {
      ann = true;
      // Between the two PCs' places for her, nearer the surer one's.
      EXPECT_NEAR(track.x_m, ann_x, 0.05);
      EXPECT_NEAR(track.vx_m_s, 1.2, 0.3);
    }
  }
  EXPECT_TRUE(ann);
  // Every tracks_t names a merged map that was sent.
  EXPECT_LE(last.seq, static_cast<std::int64_t>(node.published()) - 1);
  EXPECT_GE(node.tracksPublished(), 15u);
}

InputError configError(const std::string& text) {
  try {
    parseConfig(text, "/site/merge.yaml");
  } catch (const InputError& error) {
    return error;
  }
  ADD_FAILURE() << "accepted:\n" << text;
  return InputError("", 0, "", "");
}

TEST(MergeConfig, InputsInsteadOfCamerasAndEachSlipNamed) {
  const std::string map = "map: {origin_m: [0, 0], cell_size_m: 0.1, width: 10, height: 10}\n";
  const Config config = parseConfig(map +
                                        "merge:\n"
                                        "  max_age_ms: 200\n"
                                        "  inputs:\n"
                                        "    - {name: west, channel: OCCMAP_MAP_WEST}\n"
                                        "    - {name: east, channel: OCCMAP_MAP_EAST}\n",
                                    "/site/merge.yaml");
  ASSERT_TRUE(config.merge);
  EXPECT_TRUE(config.cameras.empty());
  ASSERT_EQ(config.merge->inputs.size(), 2u);
  EXPECT_EQ(config.merge->inputs[1].channel, "OCCMAP_MAP_EAST");
  EXPECT_EQ(config.merge->max_age_ms, 200.0);
  // A rig of no cameras is refused with what to do.
  EXPECT_THROW(Rig::open(config), InputError);

  const InputError both =
      configError(map +
                  "cameras:\n  - {name: c0, source: \"sim://room/c0\"}\nmerge: {inputs: [{name: w, "
                  "channel: W}]}\n");
  EXPECT_EQ(both.field(), "merge");
  const InputError own = configError(map + "merge: {inputs: [{name: w, channel: OCCMAP_MAP}]}\n");
  EXPECT_NE(std::string(own.what()).find("where this node publishes"), std::string::npos)
      << own.what();
  const InputError twice =
      configError(map +
                  "merge:\n  inputs:\n    - {name: w, channel: A}\n    - {name: w, "
                  "channel: B}\n");
  EXPECT_EQ(twice.line(), 5);
  const InputError none = configError(map + "merge: {max_age_ms: 100}\n");
  EXPECT_EQ(none.field(), "merge.inputs");
  const InputError neither = configError(map);
  EXPECT_NE(std::string(neither.what()).find("merge node"), std::string::npos) << neither.what();
}

}  // namespace
}  // namespace occmap
