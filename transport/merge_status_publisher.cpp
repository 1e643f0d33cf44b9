#include "transport/merge_status_publisher.h"

#include <algorithm>
#include <limits>

#include "base/clock.h"
#include "transport/merge_status_message.h"

namespace occmap {

MergeStatusPublisher::MergeStatusPublisher(const std::string& status_channel, std::size_t inputs,
                                           std::int64_t now_ns)
    : channel_(mergeStatusChannel(status_channel)),
      samples_(kRateSamples, Sample{now_ns, 0, std::vector<std::uint64_t>(inputs)}) {
  status_.inputs.resize(inputs);
}

void MergeStatusPublisher::publish(Bus& bus, const MergeReport& report, std::int64_t request_id,
                                   std::int64_t now_ns) {
  constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();
  const std::size_t inputs = std::min(report.inputs.size(), samples_[0].maps.size());
  const Sample& oldest = samples_[oldest_];
  const double window_s = std::max(1e-3, static_cast<double>(now_ns - oldest.ns) / 1e9);
  status_.utime = hostTimeMicroseconds();
  status_.request_id = request_id;
  status_.hostname = report.hostname;
  status_.config_file = report.config_file;
  status_.map_channel = report.map_channel;
  status_.state = static_cast<std::int8_t>(report.state);
  status_.uptime_s = report.uptime_s;
  status_.maps_published = static_cast<std::int64_t>(report.maps_published);
  status_.publish_errors = static_cast<std::int64_t>(report.publish_errors + errors_);
  status_.maps_per_s = static_cast<double>(report.maps_published - oldest.published) / window_s;
  status_.max_age_ms = report.max_age_s * 1e3;
  status_.latency_p50_ms = report.latency_p50_ms;
  status_.latency_p99_ms = report.latency_p99_ms;
  status_.latency_last_ms = report.latency_last_ms;
  status_.merge_p50_ms = report.merge_p50_ms;
  status_.merge_p99_ms = report.merge_p99_ms;
  status_.clock_warning_ms = report.clock_warning_s * 1e3;
  status_.num_inputs = static_cast<std::int16_t>(inputs);
  status_.inputs.resize(inputs);
  for (std::size_t k = 0; k < inputs; ++k) {
    const MergeInputReport& r = report.inputs[k];
    occmap::merge_input_status_t& s = status_.inputs[k];
    s.name = r.name;
    s.channel = r.channel;
    s.state = static_cast<std::int8_t>(r.state);
    s.maps = static_cast<std::int64_t>(r.maps);
    s.maps_per_s = static_cast<double>(r.maps - oldest.maps[k]) / window_s;
    s.age_ms = r.age_s ? *r.age_s * 1e3 : kUnknown;
    s.lost_maps = static_cast<std::int64_t>(r.lost);
    s.tiles_lost = static_cast<std::int64_t>(r.tiles_lost);
    s.refused = static_cast<std::int64_t>(r.refused);
    s.clock_offset_ms = r.clock_offset_s ? *r.clock_offset_s * 1e3 : kUnknown;
    s.last_error.assign(r.last_error, 0, std::min(r.last_error.size(), kMaxErrorText));
  }
  if (request_id < 0) {
    // The oldest sample makes way for this one (the ring starts with copies of the start).
    Sample& sample = samples_[oldest_];
    sample.ns = now_ns;
    sample.published = report.maps_published;
    for (std::size_t k = 0; k < inputs; ++k) sample.maps[k] = report.inputs[k].maps;
    oldest_ = (oldest_ + 1) % kRateSamples;
  }
  buffer_.resize(static_cast<std::size_t>(status_.getEncodedSize()));
  status_.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (!bus.publish(channel_, buffer_)) ++errors_;
}

}  // namespace occmap
