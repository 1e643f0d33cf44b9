#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace occmap::tools {

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

}  // namespace occmap::tools
