#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>

#include "config/prepared_rig.h"

namespace occmap::tools {

// A share for the summary lines the commands print at the end, in per cent (0 of nothing is 0).
inline double percent(std::uint64_t part, std::uint64_t whole) {
  return whole == 0 ? 0.0 : 100.0 * static_cast<double>(part) / static_cast<double>(whole);
}

// A one-line progress bar on stderr, drawn only when stderr is a terminal (logs and pipes stay
// clean), at most ten times a second.
class Progress {
 public:
  Progress(std::string label, std::uint64_t total);  // total 0: unknown
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void update(std::uint64_t done);
  void finish();  // clears the line
  double elapsedSeconds() const;

 private:
  void draw(std::uint64_t done);

  std::string label_;
  std::uint64_t total_;
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

// What fuse and coverage both start from: prepareRig with a progress bar over the carve tables and
// the rig's warnings printed under the command's name.
PreparedRig prepareRigWithProgress(const Config& config, const std::string& command,
                                   std::optional<double> column_height_m = std::nullopt);

}  // namespace occmap::tools
