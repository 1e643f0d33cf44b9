#include "config/floor_points_file.h"

#include <cerrno>
#include <cmath>
#include <fstream>
#include <string>
#include <system_error>

#include "config/input_error.h"
#include "config/number_text.h"

namespace occmap {
namespace {

// Frames are counted from 0; a frame index past this is a wrong column, not a long recording
// (a billion frames is a year at 30 fps).
constexpr std::int64_t kLastFrame = 1'000'000'000'000;

std::ifstream openOrThrow(const std::filesystem::path& file, std::string_view what) {
  errno = 0;
  std::ifstream in(file);
  if (!in) {
    throw InputError(file.string(), 0, "",
                     "cannot read " + std::string(what) +
                         " file: " + std::generic_category().message(errno != 0 ? errno : ENOENT));
  }
  return in;
}

std::vector<std::string_view> split(std::string_view line, char separator) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = line.find(separator, start);
    fields.push_back(trimBlanks(line.substr(start, end - start)));
    if (end == std::string_view::npos) return fields;
    start = end + 1;
  }
}

std::vector<std::string_view> splitBlanks(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t u = 0;
  while (u < line.size()) {
    while (u < line.size() && (line[u] == ' ' || line[u] == '\t')) ++u;
    const std::size_t start = u;
    while (u < line.size() && line[u] != ' ' && line[u] != '\t') ++u;
    if (u > start) fields.push_back(line.substr(start, u - start));
  }
  return fields;
}

struct Reader {
  const std::filesystem::path& file;
  int line;

  double real(std::string_view text, std::string_view column) const {
    const std::optional<double> value = parseReal(text);
    if (!value) fail(column, "'" + std::string(text) + "' is not a number");
    if (!std::isfinite(*value)) fail(column, "must be finite, not " + std::string(text));
    return *value;
  }
  std::int64_t integer(std::string_view text, std::string_view column) const {
    const std::optional<long long> value = parseInteger(text);
    if (!value) fail(column, "'" + std::string(text) + "' is not a whole number");
    return *value;
  }
  std::int64_t frame(std::string_view text, std::string_view column) const {
    const std::int64_t value = integer(text, column);
    if (value < 0 || value > kLastFrame) {
      fail(column, "frame " + std::string(text) + " is not a frame set's index (0, 1, 2, ...)");
    }
    return value;
  }
  [[noreturn]] void fail(std::string_view column, const std::string& message) const {
    throw InputError(file.string(), line, std::string(column), message);
  }
};

std::string withoutCarriageReturn(std::string text) {
  if (!text.empty() && text.back() == '\r') text.pop_back();
  return text;
}

}  // namespace

std::vector<FloorPointRow> readFloorPointsCsv(const std::filesystem::path& file,
                                              std::string_view what, std::string_view id_column) {
  std::ifstream in = openOrThrow(file, what);
  std::string text;
  int line = 0;
  // The header: the first line that is not blank.
  std::vector<std::string> names;
  while (names.empty() && std::getline(in, text)) {
    ++line;
    text = withoutCarriageReturn(std::move(text));
    if (trimBlanks(text).empty()) continue;
    for (const std::string_view name : split(text, ',')) names.emplace_back(name);
  }
  const Reader header{file, line};
  if (names.empty()) {
    header.fail("", "is empty; a " + std::string(what) +
                        " file starts with a header line such as 'frame,x_m,y_m'");
  }
  const auto column = [&](std::string_view name) -> std::size_t {
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (names[i] == name) return i;
    }
    std::string have;
    for (const std::string& n : names) have += (have.empty() ? "" : ",") + n;
    header.fail(name, "the header has no column '" + std::string(name) + "' (it reads '" + have +
                          "'); a " + std::string(what) + " file names frame, x_m and y_m" +
                          (id_column.empty() ? "" : " and " + std::string(id_column)));
  };
  const std::size_t frame_at = column("frame");
  const std::size_t x_at = column("x_m");
  const std::size_t y_at = column("y_m");
  const std::size_t id_at = id_column.empty() ? 0 : column(id_column);
  std::vector<FloorPointRow> rows;
  while (std::getline(in, text)) {
    ++line;
    text = withoutCarriageReturn(std::move(text));
    if (trimBlanks(text).empty()) continue;
    const Reader reader{file, line};
    const std::vector<std::string_view> fields = split(text, ',');
    if (fields.size() != names.size()) {
      reader.fail("", std::to_string(fields.size()) + " columns where the header names " +
                          std::to_string(names.size()));
    }
    FloorPointRow row;
    row.line = line;
    row.frame = reader.frame(fields[frame_at], "frame");
    row.point = {reader.real(fields[x_at], "x_m"), reader.real(fields[y_at], "y_m")};
    if (!id_column.empty()) row.id = reader.integer(fields[id_at], id_column);
    rows.push_back(row);
  }
  if (in.bad()) header.fail("", "reading stopped: " + std::generic_category().message(EIO));
  return rows;
}

std::vector<FloorPointRow> readEpflGroundTruth(const std::filesystem::path& file) {
  std::ifstream in = openOrThrow(file, "EPFL ground truth");
  std::string text;
  int line = 0;
  std::vector<FloorPointRow> rows;
  while (std::getline(in, text)) {
    ++line;
    text = withoutCarriageReturn(std::move(text));
    const std::vector<std::string_view> fields = splitBlanks(text);
    if (fields.empty()) continue;
    const Reader reader{file, line};
    if (fields.size() != 4) {
      reader.fail("", std::to_string(fields.size()) +
                          " fields; an EPFL ground truth line is 'index source_frame x_mm y_mm'");
    }
    FloorPointRow row;
    row.line = line;
    row.frame = reader.frame(fields[0], "index");
    reader.frame(fields[1], "source_frame");
    row.point = {reader.real(fields[2], "x_mm") / 1000.0, reader.real(fields[3], "y_mm") / 1000.0};
    rows.push_back(row);
  }
  if (rows.empty()) {
    throw InputError(file.string(), 0, "",
                     "has no people; an EPFL ground truth line is 'index source_frame x_mm y_mm'");
  }
  return rows;
}

}  // namespace occmap
