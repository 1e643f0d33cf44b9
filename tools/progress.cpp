#include "tools/progress.h"

#include <unistd.h>

namespace occmap::tools {

Progress::Progress(std::string label, std::uint64_t total)
    : label_(std::move(label)),
      total_(total),
      enabled_(::isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {}

Progress::~Progress() { finish(); }

double Progress::elapsedSeconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::update(std::uint64_t done) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_draw_ < std::chrono::milliseconds(100) && done != total_) return;
  last_draw_ = now;
  draw(done);
}

void Progress::draw(std::uint64_t done) {
  const double seconds = elapsedSeconds();
  const double rate = seconds > 0 ? static_cast<double>(done) / seconds : 0.0;
  if (total_ > 0) {
    constexpr int kWidth = 30;
    const auto filled =
        static_cast<int>(kWidth * static_cast<double>(done) / static_cast<double>(total_));
    std::string bar(static_cast<std::size_t>(kWidth), '-');
    for (int i = 0; i < filled && i < kWidth; ++i) bar[static_cast<std::size_t>(i)] = '#';
    const double left = rate > 0 ? static_cast<double>(total_ - done) / rate : 0.0;
    std::fprintf(stderr, "\r%s [%s] %llu/%llu  %.1f/s  %.0f s left \033[K", label_.c_str(),
                 bar.c_str(), static_cast<unsigned long long>(done),
                 static_cast<unsigned long long>(total_), rate, left);
  } else {
    std::fprintf(stderr, "\r%s %llu  %.1f/s \033[K", label_.c_str(),
                 static_cast<unsigned long long>(done), rate);
  }
  std::fflush(stderr);
  drawn_ = true;
}

void Progress::finish() {
  if (drawn_) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
    drawn_ = false;
  }
}

PreparedRig prepareRigWithProgress(const Config& config, const std::string& command,
                                   std::optional<double> column_height_m) {
  Progress progress("carve tables", config.cameras.size());
  PreparedRig prepared =
      prepareRig(config, {}, column_height_m, [&](std::size_t built) { progress.update(built); });
  progress.finish();
  for (const std::string& warning : prepared.rig.warnings()) {
    std::fprintf(stderr, "occmap %s: warning: %s\n", command.c_str(), warning.c_str());
  }
  return prepared;
}

}  // namespace occmap::tools
