// A merge node under the load issue 16 names: camera PCs replaying 512 x 512 maps at 30 Hz into
// one 2048 x 2048 merged map (the PCs' maps tile it 4 x 4; 32 PCs: two over each tile). Each input
// map differs from its last as a site's does: people move, a few hundred cells change. Per input
// map heard: decode, the merged map kept up to date, and a merged map published when every fresh
// PC has brought a new one (30 a second: zstd of 4 Mi cells), all on the node's one thread, as
// occmapd's merge node does (daemon/merge_node.h), through the in-memory bus.
// Counters: the node's share of one core at 30 Hz (time per second of input), the time per input
// map at the median and the 99th percentile, merged maps a second.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "daemon/merge_node.h"
#include "transport/map_codec.h"
#include "transport/memory_bus.h"

namespace occmap {
namespace {

constexpr int kSide = 512;
constexpr double kCell = 0.02;

// The messages of `count` PCs for `frames` frames at 30 Hz, in the order they arrive: frame by
// frame, PC by PC.
std::vector<std::vector<std::uint8_t>> inputMessages(int pcs, int frames) {
  std::vector<std::vector<std::uint8_t>> messages;
  std::vector<MapFrame> maps;
  std::vector<std::unique_ptr<MapEncoder>> encoders;
  for (int k = 0; k < pcs; ++k) {
    const int tile = k % 16;
    const MapGeometry g{(tile % 4) * kSide * kCell, (tile / 4) * kSide * kCell, kCell, kSide,
                        kSide};
    maps.emplace_back(g, 4);
    encoders.push_back(std::make_unique<MapEncoder>(
        g, std::vector<std::string>{"c0", "c1", "c2", "c3"}, MapEncoding::kZstd));
    // Mostly free floor, a band unseen, some occupied.
    for (std::size_t i = 0; i < maps.back().map.cells.size(); ++i) {
      maps.back().map.cells[i] = i % kSide < 40 ? CellState::kUnseen
                                 : i % 97 == 0  ? CellState::kOccupied
                                                : CellState::kFree;
    }
  }
  std::uint32_t state = 1;
  for (int frame = 0; frame < frames; ++frame) {
    for (int k = 0; k < pcs; ++k) {
      MapFrame& f = maps[static_cast<std::size_t>(k)];
      // A few people walking: 300 cells flip each frame.
      for (int n = 0; n < 300; ++n) {
        state = state * 1664525u + 1013904223u;
        CellState& cell = f.map.cells[(state >> 8) % f.map.cells.size()];
        cell = cell == CellState::kFree ? CellState::kOccupied : CellState::kFree;
      }
      f.seq = frame;
      f.utime = 1'000'000'000'000 + frame * 33'333 + k * 50;
      const auto message = encoders[static_cast<std::size_t>(k)]->encode(f);
      messages.emplace_back(message.begin(), message.end());
    }
  }
  return messages;
}

void merge(benchmark::State& state) {
  const int pcs = static_cast<int>(state.range(0));
  constexpr int kFrames = 60;
  const auto messages = inputMessages(pcs, kFrames);
  MemoryNetwork network;
  auto pc_bus = network.connect();
  auto node_bus = network.connect();
  std::vector<MergeInputSpec> inputs;
  for (int k = 0; k < pcs; ++k) {
    inputs.push_back({"pc" + std::to_string(k), "MAP_PC" + std::to_string(k)});
  }
  const MapGeometry merged{0.0, 0.0, kCell, 4 * kSide, 4 * kSide};
  MergeNode node(*node_bus, merged, inputs, 0.150, "MERGED", MapEncoding::kZstd);
  std::vector<double> per_map;
  double total_s = 0;
  std::size_t heard = 0;
  for (auto _ : state) {
    for (std::size_t i = 0; i < messages.size(); ++i) {
      const std::size_t k = i % static_cast<std::size_t>(pcs);
      pc_bus->publish("MAP_PC" + std::to_string(k), messages[i]);
      const auto start = std::chrono::steady_clock::now();
      while (node.spinOnce(0) > 0) {
      }
      const double s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      per_map.push_back(s);
      total_s += s;
      ++heard;
    }
  }
  std::sort(per_map.begin(), per_map.end());
  const double seconds_of_input = static_cast<double>(heard) / pcs / 30.0;
  state.counters["core_share"] = total_s / seconds_of_input;
  state.counters["per_map_p50_ms"] = per_map[per_map.size() / 2] * 1e3;
  state.counters["per_map_p99_ms"] = per_map[per_map.size() * 99 / 100] * 1e3;
  state.counters["merged_per_s"] = static_cast<double>(node.published()) / seconds_of_input;
}
BENCHMARK(merge)->Arg(1)->Arg(4)->Arg(16)->Arg(32)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace occmap

BENCHMARK_MAIN();
