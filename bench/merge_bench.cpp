// A merge node under the load issue 16 names: camera PCs replaying 512 x 512 maps at 30 Hz into
// one 2048 x 2048 merged map (the PCs' maps tile it 4 x 4; 32 PCs: two over each tile). Each input
// map differs from its last as a site's does: eight people walk, a thousand or two cells change,
// and the map stays coherent (PcFloor); a second run adds 1 % random speckle to every map, the
// worst case for compression. Per input map heard: decode, the merged map kept up to date, and a
// merged map published when every fresh PC has brought a new one (30 a second: 4 Mi cells in 81
// zstd tiles), all on the node's one thread, as occmapd's merge node does (daemon/merge_node.h),
// through the in-memory bus.
// Counters: the node's share of one core at 30 Hz (time per second of input, each PC's first map
// apart: first_maps_ms), the time per input map at the median and the 99th percentile, the median
// of those that published a merged map and of those that did not, merged maps a second, and the
// input maps lost or refused (must be 0).
#include <algorithm>
#include <chrono>
#include <cmath>
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

// One camera PC's floor as its maps show it: free floor, a band no camera sees, a few fixed
// obstacles (shelves, tables), and people walking: each an occupied disc with the wedge behind it
// that no camera clears, moving about 0.6 m/s. From map to map a few hundred cells change, and the
// map is coherent, as a fused map is (not noise, which zstd cannot shrink).
class PcFloor {
 public:
  // `speckle_per_mille`: cells occupied at random anew on every map (a noisy camera's false
  // changes that the fusion lets through), a worst case for compression.
  PcFloor(int seed, std::uint32_t people, int speckle_per_mille)
      : state_(static_cast<std::uint32_t>(seed) * 2654435761u), speckle_(speckle_per_mille) {
    base_.assign(static_cast<std::size_t>(kSide) * kSide, CellState::kFree);
    for (int r = 0; r < kSide; ++r) {
      for (int c = 0; c < kSide; ++c) {
        CellState& cell = base_[static_cast<std::size_t>(r) * kSide + static_cast<std::size_t>(c)];
        if (c < 40) cell = CellState::kUnseen;
      }
    }
    for (int k = 0; k < 6; ++k) {  // obstacles 0.4 to 1.2 m
      const int r0 = next(kSide - 60), c0 = 40 + next(kSide - 100), h = 20 + next(40),
                w = 20 + next(40);
      for (int r = r0; r < r0 + h; ++r) {
        for (int c = c0; c < c0 + w; ++c) {
          base_[static_cast<std::size_t>(r) * kSide + static_cast<std::size_t>(c)] =
              CellState::kOccupied;
        }
      }
    }
    for (std::uint32_t k = 0; k < people; ++k) {
      people_.push_back({60.0 + next(kSide - 120), 60.0 + next(kSide - 120),
                         (next(200) - 100) / 100.0, (next(200) - 100) / 100.0});
    }
  }

  // The next map: everyone a step on (bouncing off the edges).
  void step(OccupancyMap& map) {
    map.cells = base_;
    const int speckles = kSide * kSide / 1000 * speckle_;
    for (int k = 0; k < speckles; ++k) {
      map.cells[static_cast<std::size_t>(next(kSide * kSide))] = CellState::kOccupied;
    }
    for (Person& p : people_) {
      p.x += p.vx;
      p.y += p.vy;
      if (p.x < 50 || p.x > kSide - 50) p.vx = -p.vx;
      if (p.y < 50 || p.y > kSide - 50) p.vy = -p.vy;
      // A disc 0.5 m across and a wedge 0.8 m long behind it, away from the map's centre.
      const double ax = p.x - kSide / 2.0, ay = p.y - kSide / 2.0;
      const double norm = std::max(1.0, std::hypot(ax, ay));
      for (int t = 0; t <= 40; t += 2) {
        const double cx = p.x + ax / norm * t, cy = p.y + ay / norm * t;
        const double radius = 12.0 + t / 4.0;
        for (int r = static_cast<int>(cy - radius); r <= static_cast<int>(cy + radius); ++r) {
          for (int c = static_cast<int>(cx - radius); c <= static_cast<int>(cx + radius); ++c) {
            if (r < 0 || r >= kSide || c < 0 || c >= kSide) continue;
            if ((r - cy) * (r - cy) + (c - cx) * (c - cx) > radius * radius) continue;
            map.cells[static_cast<std::size_t>(r) * kSide + static_cast<std::size_t>(c)] =
                CellState::kOccupied;
          }
        }
      }
    }
  }

 private:
  struct Person {
    double x, y, vx, vy;  // cells, cells per map
  };
  int next(int below) {
    state_ = state_ * 1664525u + 1013904223u;
    return static_cast<int>((state_ >> 8) % static_cast<std::uint32_t>(below));
  }
  std::uint32_t state_;
  int speckle_;
  std::vector<CellState> base_;
  std::vector<Person> people_;
};

// The messages of `pcs` PCs for `frames` frames at 30 Hz, in the order they arrive: frame by
// frame, PC by PC.
std::vector<std::vector<std::uint8_t>> inputMessages(int pcs, int frames, int speckle_per_mille) {
  std::vector<std::vector<std::uint8_t>> messages;
  std::vector<MapFrame> maps;
  std::vector<PcFloor> floors;
  std::vector<std::unique_ptr<MapEncoder>> encoders;
  for (int k = 0; k < pcs; ++k) {
    const int tile = k % 16;
    const MapGeometry g{(tile % 4) * kSide * kCell, (tile / 4) * kSide * kCell, kCell, kSide,
                        kSide};
    maps.emplace_back(g, 4);
    floors.emplace_back(k + 1, 8u, speckle_per_mille);
    encoders.push_back(std::make_unique<MapEncoder>(
        g, std::vector<std::string>{"c0", "c1", "c2", "c3"}, MapEncoding::kZstd));
  }
  for (int frame = 0; frame < frames; ++frame) {
    for (int k = 0; k < pcs; ++k) {
      MapFrame& f = maps[static_cast<std::size_t>(k)];
      floors[static_cast<std::size_t>(k)].step(f.map);
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
  const auto messages = inputMessages(pcs, kFrames, static_cast<int>(state.range(1)));
  MemoryNetwork network;
  auto pc_bus = network.connect();
  auto node_bus = network.connect();
  std::vector<MergeInputSpec> inputs;
  for (int k = 0; k < pcs; ++k) {
    inputs.push_back({"pc" + std::to_string(k), "MAP_PC" + std::to_string(k)});
  }
  const MapGeometry merged{0.0, 0.0, kCell, 4 * kSide, 4 * kSide};
  // A 2048 x 2048 map goes out in tiles, as such a floor's must (docs/daemon.md): 81 of them.
  MergeNode node(*node_bus, merged, inputs, 0.150, "MERGED", MapEncoding::kZstd, {}, "merge",
                 MapMessages::kTiles);
  std::vector<std::string> channels;
  for (int k = 0; k < pcs; ++k) channels.push_back("MAP_PC" + std::to_string(k));
  // The first frame of every PC, not timed: the node learns each input's geometry once (a merger
  // built for 4 Mi cells, ms each) when the PC first speaks, not per map. Counted apart.
  const auto warm_start = std::chrono::steady_clock::now();
  for (int k = 0; k < pcs; ++k) {
    pc_bus->publish(channels[static_cast<std::size_t>(k)], messages[static_cast<std::size_t>(k)]);
    while (node.spinOnce(0) > 0) {
    }
  }
  state.counters["first_maps_ms"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - warm_start).count() * 1e3;
  std::vector<double> per_map, with_publish, without_publish;
  const std::uint64_t published_at_start = node.published();
  double total_s = 0;
  std::size_t heard = 0;
  for (auto _ : state) {
    for (std::size_t i = static_cast<std::size_t>(pcs); i < messages.size(); ++i) {
      pc_bus->publish(channels[i % static_cast<std::size_t>(pcs)], messages[i]);
      const std::uint64_t published_before = node.published();
      const auto start = std::chrono::steady_clock::now();
      while (node.spinOnce(0) > 0) {
      }
      const double s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      per_map.push_back(s);
      (node.published() > published_before ? with_publish : without_publish).push_back(s);
      total_s += s;
      ++heard;
    }
  }
  std::sort(per_map.begin(), per_map.end());
  const double seconds_of_input = static_cast<double>(heard) / pcs / 30.0;
  state.counters["core_share"] = total_s / seconds_of_input;
  state.counters["per_map_p50_ms"] = per_map[per_map.size() / 2] * 1e3;
  state.counters["per_map_p99_ms"] = per_map[per_map.size() * 99 / 100] * 1e3;
  state.counters["merged_per_s"] =
      static_cast<double>(node.published() - published_at_start) / seconds_of_input;
  // The input maps that made a merged map go out, and those that did not (decode and merge only).
  const auto median_ms = [](std::vector<double>& v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2] * 1e3;
  };
  state.counters["publishing_p50_ms"] = median_ms(with_publish);
  state.counters["merging_p50_ms"] = median_ms(without_publish);
  std::uint64_t lost = 0;
  for (const MergeNode::InputStatus& input : node.inputs()) lost += input.lost + input.refused;
  state.counters["inputs_lost"] = static_cast<double>(lost);
}
// Arguments: PCs, then speckle per mille (0: clean maps; 10: 1 % of each map's cells speckled).
BENCHMARK(merge)
    ->ArgNames({"pcs", "speckle_per_mille"})
    ->ArgsProduct({{1, 4, 16, 32}, {0}})
    ->Args({16, 10})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace occmap

BENCHMARK_MAIN();
