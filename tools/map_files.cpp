#include "tools/map_files.h"

#include <algorithm>
#include <string>
#include <system_error>

#include "config/input_error.h"

namespace occmap::tools {

namespace fs = std::filesystem;

bool isMapFile(const fs::path& path) {
  const std::string name = path.filename().string();
  constexpr std::string_view kPrefix = "map_", kSuffix = ".png";
  if (name.size() < kPrefix.size() + 6 + kSuffix.size() || !name.starts_with(kPrefix) ||
      !name.ends_with(kSuffix)) {
    return false;
  }
  const std::string_view digits(name.data() + kPrefix.size(),
                                name.size() - kPrefix.size() - kSuffix.size());
  return std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; });
}

std::vector<fs::path> checkOutput(const fs::path& out, bool overwrite, std::string_view command) {
  std::error_code error;
  if (!fs::exists(out, error)) return {};
  if (!fs::is_directory(out, error)) {
    throw InputError(out.string(), 0, "--out", "is not a folder; give a new or empty folder");
  }
  std::vector<fs::path> old_maps;
  for (const fs::directory_entry& entry : fs::directory_iterator(out)) {
    if (!isMapFile(entry.path())) {
      throw InputError(out.string(), 0, "--out",
                       "holds other files (" + entry.path().filename().string() + "); occmap " +
                           std::string(command) +
                           " writes only map_NNNNNN.png files: give a new or empty folder");
    }
    old_maps.push_back(entry.path());
  }
  if (!old_maps.empty() && !overwrite) {
    throw InputError(out.string(), 0, "--out",
                     "already holds " + std::to_string(old_maps.size()) +
                         " maps from an earlier run; pass --overwrite to replace them, or give "
                         "another folder");
  }
  return old_maps;
}

void makeOutput(const fs::path& out, const std::vector<fs::path>& old_maps) {
  std::error_code error;
  if (!fs::exists(out, error) && !fs::create_directories(out, error)) {
    throw InputError(out.string(), 0, "--out",
                     "cannot create the output folder: " + error.message());
  }
  for (const fs::path& map : old_maps) fs::remove(map);
}

Image mapImage(const OccupancyMap& map) {
  Image image(map.geometry.width, map.geometry.height);
  for (std::size_t i = 0; i < map.cells.size(); ++i) image.data()[i] = greyLevel(map.cells[i]);
  return image;
}

std::vector<fs::path> mapFiles(const fs::path& folder) {
  std::error_code error;
  if (!fs::is_directory(folder, error)) {
    throw InputError(folder.string(), 0, "--input", "is not a folder of maps (map_NNNNNN.png)");
  }
  std::vector<fs::path> maps;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    if (isMapFile(entry.path())) maps.push_back(entry.path());
  }
  if (maps.empty()) {
    throw InputError(folder.string(), 0, "--input",
                     "holds no map_NNNNNN.png: give a folder that occmap fuse or merge wrote");
  }
  std::sort(maps.begin(), maps.end());
  return maps;
}

OccupancyMap mapFromImage(const Image& image, const MapGeometry& geometry, const fs::path& file) {
  if (image.width() != geometry.width || image.height() != geometry.height) {
    throw InputError(file.string(), 0, "",
                     "is " + std::to_string(image.width()) + "x" + std::to_string(image.height()) +
                         " but its maps are " + std::to_string(geometry.width) + "x" +
                         std::to_string(geometry.height) + " cells");
  }
  OccupancyMap map(geometry);
  for (std::size_t i = 0; i < map.cells.size(); ++i) {
    const std::uint8_t grey = image.data()[i];
    if (grey != 0 && grey != 255 && grey != 128) {
      throw InputError(file.string(), 0, "",
                       "has a pixel of grey " + std::to_string(grey) + " (cell " +
                           std::to_string(i) +
                           "); a map is 0 free, 255 occupied, 128 unseen: is it a map?");
    }
    map.cells[i] = grey == 0     ? CellState::kFree
                   : grey == 255 ? CellState::kOccupied
                                 : CellState::kUnseen;
  }
  return map;
}

}  // namespace occmap::tools
