#include "daemon/reposer.h"

#include <exception>
#include <utility>

namespace occmap {

void Reposer::start(Camera camera, const Eigen::Vector3d& turn, Image background, Image floor_mask,
                    const MapGeometry& map, double column_height_m) {
  done_.store(false, std::memory_order_relaxed);
  result_.reset();
  error_.clear();
  thread_ = std::thread([this, camera = std::move(camera), turn, background = std::move(background),
                         floor_mask = std::move(floor_mask), map, column_height_m] {
    // Nothing may leave a thread: a failure is the capture thread's to report.
    try {
      ReposedCamera reposed =
          reposeCamera(camera, turn, background.view(), floor_mask.view(), map, column_height_m);
      FusionKernel::Replacement table = FusionKernel::prepareReplacement(reposed.table);
      result_.emplace(Result{std::move(reposed), std::move(table)});
    } catch (const std::exception& failure) {
      error_ = failure.what();
    } catch (...) {
      error_ = "an unknown exception";
    }
    done_.store(true, std::memory_order_release);
  });
}

std::optional<Reposer::Result> Reposer::take(std::string& error) {
  error.clear();
  if (!thread_.joinable() || !done_.load(std::memory_order_acquire)) return std::nullopt;
  thread_.join();
  if (!result_) {
    error = error_.empty() ? "no result" : error_;
    return std::nullopt;
  }
  return std::exchange(result_, std::nullopt);
}

}  // namespace occmap
