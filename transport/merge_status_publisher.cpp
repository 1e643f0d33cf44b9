#include "transport/merge_status_publisher.h"

#include <algorithm>
#include <limits>

#include "base/clock.h"
#include "transport/merge_status_message.h"

namespace occmap {

MergeStatusPublisher::MergeStatusPublisher(const std::string& status_channel, std::size_t inputs,
                                           std::int64_t now_ns)
    : channel_(mergeStatusChannel(status_channel)), rates_(inputs, now_ns) {
  status_.inputs.resize(inputs);
}

void MergeStatusPublisher::publish(Bus& bus, const MergeReport& report, std::int64_t request_id,
                                   std::int64_t now_ns) {
  constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();
  const std::size_t inputs = std::min(report.inputs.size(), rates_.parts());
  status_.utime = hostTimeMicroseconds();
  status_.request_id = request_id;
  status_.hostname = report.hostname;
  status_.config_file = report.config_file;
  status_.map_channel = report.map_channel;
  status_.state = static_cast<std::int8_t>(report.state);
  status_.uptime_s = report.uptime_s;
  status_.maps_published = static_cast<std::int64_t>(report.maps_published);
  status_.publish_errors = static_cast<std::int64_t>(report.publish_errors + errors_);
  status_.maps_per_s = rates_.mapsPerSecond(report.maps_published, now_ns);
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
    s.maps_per_s = rates_.perSecond(k, r.maps, now_ns);
    s.age_ms = r.age_s ? *r.age_s * 1e3 : kUnknown;
    s.lost_maps = static_cast<std::int64_t>(r.lost);
    s.tiles_lost = static_cast<std::int64_t>(r.tiles_lost);
    s.refused = static_cast<std::int64_t>(r.refused);
    s.clock_offset_ms = r.clock_offset_s ? *r.clock_offset_s * 1e3 : kUnknown;
    s.last_error.assign(r.last_error, 0, std::min(r.last_error.size(), kMaxErrorText));
  }
  if (request_id < 0) {
    rates_.moveOn(now_ns, report.maps_published,
                  [&](std::size_t k) { return k < inputs ? report.inputs[k].maps : 0; });
  }
  buffer_.resize(static_cast<std::size_t>(status_.getEncodedSize()));
  status_.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (!bus.publish(channel_, buffer_)) ++errors_;
}

}  // namespace occmap
