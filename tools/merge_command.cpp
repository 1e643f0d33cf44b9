// occmap merge: map sequences of several camera PCs merged frame by frame into one, by the rule the
// merge node uses (core/map_merge.h), so that merges can be checked and replayed off-line.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "capture/image_file.h"
#include "config/config.h"
#include "config/exit_codes.h"
#include "config/input_error.h"
#include "core/map_merge.h"
#include "tools/commands.h"
#include "tools/map_files.h"
#include "tools/progress.h"

namespace occmap::tools {
namespace {

namespace fs = std::filesystem;

struct MergeOptions {
  std::vector<std::string> inputs;
  std::vector<std::string> input_configs;
  std::string config;
  std::string out;
  bool overwrite = false;
};

Image readMapImage(const fs::path& file) {
  std::string error;
  std::optional<Image> image = readGreyImage(file, error);
  if (!image) throw InputError(file.string(), 0, "", error);
  return std::move(*image);
}

int runMerge(const MergeOptions& o) {
  if (!o.input_configs.empty() && o.input_configs.size() != o.inputs.size()) {
    throw InputError("", 0, "--input-config",
                     "is given " + std::to_string(o.input_configs.size()) + " times for " +
                         std::to_string(o.inputs.size()) +
                         " inputs; give one per --input, in the same order, or none (the inputs "
                         "then have the merged map's geometry)");
  }
  std::vector<std::vector<fs::path>> maps;
  for (const std::string& input : o.inputs) maps.push_back(mapFiles(input));

  // Each input's geometry from its config, else the merged map's; the merged map's from --config,
  // else the first input's size (then every input must have it).
  std::vector<MapGeometry> geometries;
  for (const std::string& file : o.input_configs) geometries.push_back(loadConfig(file).map);
  MapGeometry merged;
  if (!o.config.empty()) {
    merged = loadConfig(o.config).map;
  } else if (!geometries.empty()) {
    throw InputError("", 0, "--config",
                     "is needed with --input-config: it gives the merged map's geometry");
  } else {
    const Image first = readMapImage(maps.front().front());
    merged.width = first.width();
    merged.height = first.height();
  }
  if (geometries.empty()) geometries.assign(o.inputs.size(), merged);
  MapMerger merger(merged, geometries);

  const fs::path out(o.out);
  const std::vector<fs::path> old_maps = checkOutput(out, o.overwrite, "merge");
  makeOutput(out, old_maps);
  std::size_t count = maps.front().size();
  for (const auto& list : maps) count = std::min(count, list.size());
  std::vector<OccupancyMap> input_maps;
  for (const MapGeometry& geometry : geometries) input_maps.emplace_back(geometry);
  std::vector<const OccupancyMap*> pointers;
  for (const OccupancyMap& map : input_maps) pointers.push_back(&map);
  OccupancyMap result(merged);
  Progress progress("merge", count);
  for (std::size_t frame = 0; frame < count; ++frame) {
    for (std::size_t k = 0; k < maps.size(); ++k) {
      input_maps[k] = mapFromImage(readMapImage(maps[k][frame]), geometries[k], maps[k][frame]);
    }
    merger.merge(pointers, result);
    std::string error;
    const fs::path file = out / maps.front()[frame].filename();
    if (!writeGreyPng(file, mapImage(result), error)) {
      std::fprintf(stderr, "occmap merge: %s\n", error.c_str());
      return kExitFailure;
    }
    progress.update(frame + 1);
  }
  progress.finish();
  std::printf("merged %zu maps of %zu inputs into %s\n", count, maps.size(), o.out.c_str());
  for (std::size_t k = 0; k < maps.size(); ++k) {
    if (maps[k].size() != count) {
      std::fprintf(stderr, "occmap merge: %s has %zu maps; merged the first %zu of each input\n",
                   o.inputs[k].c_str(), maps[k].size(), count);
    }
  }
  return kExitOk;
}

}  // namespace

Command addMergeCommand(CLI::App& app) {
  auto o = std::make_shared<MergeOptions>();
  CLI::App* command = app.add_subcommand(
      "merge",
      "Merges map sequences frame by frame (map_000000.png of each --input, then map_000001.png, "
      "...) into one, as a merge node merges several camera PCs' maps: a cell is free when some "
      "input frees it, unseen when no input sees it, occupied otherwise. So the maps of two PCs' "
      "cameras merge into exactly the maps one PC with all the cameras makes.\n"
      "Inputs of another geometry than the merged map are resampled (each merged cell takes the "
      "input cell under its centre): give each input's config with --input-config, in the order of "
      "the --input, and the merged map's with --config. Without them every input must have the "
      "same size, and so has the merged map.\n\n"
      "Examples:\n"
      "  occmap merge --input west/maps --input east/maps --out merged\n"
      "  occmap merge --input west/maps --input-config west.yaml --input east/maps --input-config "
      "east.yaml --config site.yaml --out merged");
  command->add_option("--input", o->inputs, "A folder of maps (occmap fuse's or merge's output)")
      ->required()
      ->check(CLI::ExistingDirectory);
  command
      ->add_option("--input-config", o->input_configs,
                   "The config whose map: an --input's maps have (one per --input, in order)")
      ->check(CLI::ExistingFile);
  command->add_option("--config", o->config, "The config whose map: the merged map has")
      ->check(CLI::ExistingFile);
  command->add_option("--out", o->out, "Folder to write the merged maps to")->required();
  command->add_flag("--overwrite", o->overwrite, "Replace maps an earlier run left in --out");
  return [o] { return runMerge(*o); };
}

}  // namespace occmap::tools
