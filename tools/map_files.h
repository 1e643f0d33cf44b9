#pragma once
// Map sequences as files: the folder of map_000000.png, map_000001.png, ... that `occmap fuse`
// writes and `occmap merge` reads and writes (8-bit grey, 0 free, 255 occupied, 128 unseen, picture
// row r = map row r).

#include <filesystem>
#include <string_view>
#include <vector>

#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap::tools {

// map_ + six or more digits + .png.
bool isMapFile(const std::filesystem::path& path);

// The output folder holds maps and nothing else: refuse one with other files in it, and old maps
// unless the user said to replace them. Only looks: returns the old maps to remove, and nothing is
// changed on disk until everything else has been checked too (makeOutput). `command` names the
// program in messages ("fuse").
std::vector<std::filesystem::path> checkOutput(const std::filesystem::path& out, bool overwrite,
                                               std::string_view command);
// The folder as checkOutput found it, made ready: created, or emptied of the old maps.
void makeOutput(const std::filesystem::path& out,
                const std::vector<std::filesystem::path>& old_maps);

// The maps of a folder in order; an InputError when there are none.
std::vector<std::filesystem::path> mapFiles(const std::filesystem::path& folder);

Image mapImage(const OccupancyMap& map);
// A map's picture read back; an InputError naming the file for a grey level that is no state.
OccupancyMap mapFromImage(const Image& image, const MapGeometry& geometry,
                          const std::filesystem::path& file);

}  // namespace occmap::tools
