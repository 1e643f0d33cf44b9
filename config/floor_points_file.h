#pragma once
// Points on the floor, frame by frame, as files: the truth that detections are scored against and
// the detections themselves (issue 14, docs/detection.md).
// - CSV with a header line naming its columns, in any order: `frame` (the frame set's index from
//   0), `x_m` and `y_m` (metres in the map's world frame) are read; `id` or `track_id` when asked
//   for; other columns (area_m2, score, vx_m_s, ...) are left alone. One point a line.
// - EPFL's ground truth files (`gt.txt` of ../shared/data's Terrace sets): `index source_frame
//   x_mm y_mm` a line, blank-separated, the index being the moment's (and so the frame set's)
//   index from 0.
// Every problem is an InputError naming the file, the line and the column.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string_view>
#include <vector>

#include "core/detection_score.h"

namespace occmap {

struct FloorPointRow {
  std::int64_t frame = 0;
  FloorPoint point;
  std::optional<std::int64_t> id;  // when the file's id column was asked for
  int line = 0;                    // 1-based, for messages
};

// `what` names the file's kind in messages ("truth", "detections"); `id_column`, when not empty,
// is a column that must be there and is read into id.
std::vector<FloorPointRow> readFloorPointsCsv(const std::filesystem::path& file,
                                              std::string_view what,
                                              std::string_view id_column = {});

std::vector<FloorPointRow> readEpflGroundTruth(const std::filesystem::path& file);

}  // namespace occmap
