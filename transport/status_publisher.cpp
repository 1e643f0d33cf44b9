#include "transport/status_publisher.h"

#include <algorithm>

#include "base/clock.h"
#include "transport/control_message.h"

namespace occmap {

StatusPublisher::StatusPublisher(std::string status_channel, std::size_t cameras,
                                 std::int64_t now_ns)
    : status_channel_(std::move(status_channel)),
      control_status_channel_(controlStatusChannel(status_channel_)),
      lighting_status_channel_(lightingStatusChannel(status_channel_)),
      view_status_channel_(viewStatusChannel(status_channel_)),
      rates_(cameras, now_ns) {
  status_.cameras.resize(cameras);
  for (occmap::camera_status_t& camera : status_.cameras) camera.last_error.reserve(kMaxErrorText);
}

void StatusPublisher::publish(Bus& bus, const DaemonReport& report, std::int64_t request_id,
                              std::int64_t now_ns) {
  const std::size_t cameras = report.cameras.size();
  status_.utime = hostTimeMicroseconds();
  status_.request_id = request_id;
  status_.hostname = report.hostname;
  status_.config_file = report.config_file;
  status_.state = static_cast<std::int8_t>(report.state);
  status_.uptime_s = report.uptime_s;
  status_.maps_published = static_cast<std::int64_t>(report.maps_published);
  status_.publish_errors = static_cast<std::int64_t>(report.publish_errors + errors_);
  status_.maps_per_s = rates_.mapsPerSecond(report.maps_published, now_ns);
  status_.fusion_p50_ms = report.fusion_p50_ms;
  status_.fusion_p99_ms = report.fusion_p99_ms;
  status_.num_cameras = static_cast<std::int16_t>(cameras);
  status_.cameras.resize(cameras);
  for (std::size_t k = 0; k < cameras; ++k) {
    const CameraReport& c = report.cameras[k];
    occmap::camera_status_t& s = status_.cameras[k];
    s.name = c.name;
    s.source = c.source;
    s.state = static_cast<std::int8_t>(c.state);
    s.frames_in = static_cast<std::int64_t>(c.frames_in);
    s.frames_dropped = static_cast<std::int64_t>(c.frames_dropped);
    s.fps = k < rates_.parts() ? rates_.perSecond(k, c.frames_in, now_ns) : 0.0;
    s.last_capture_utime = c.last_capture_utime;
    s.frames_incomplete = c.frames_incomplete;
    s.missing_packets = c.missing_packets;
    s.resent_packets = c.resent_packets;
    s.underruns = c.underruns;
    s.reconnects = c.reconnects;
    s.last_error = c.last_error;
  }
  if (request_id < 0) {
    rates_.moveOn(now_ns, report.maps_published,
                  [&](std::size_t k) { return k < cameras ? report.cameras[k].frames_in : 0; });
  }
  const auto encoded = static_cast<std::size_t>(status_.getEncodedSize());
  // Room for the longest status these cameras can make (every error text at its longest), made
  // the first time: a longer error later allocates nothing.
  std::size_t error_bytes = 0;
  for (const occmap::camera_status_t& s : status_.cameras) error_bytes += s.last_error.size();
  buffer_.reserve(encoded - error_bytes + cameras * kMaxErrorText);
  buffer_.resize(encoded);
  status_.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (!bus.publish(status_channel_, buffer_)) ++errors_;

  // The same utime, request_id and hostname pair the two.
  const ControlCounts& control = report.control;
  control_status_.utime = status_.utime;
  control_status_.request_id = request_id;
  control_status_.hostname = report.hostname;
  control_status_.control_enabled = report.control_enabled;
  control_status_.disabled = static_cast<std::int64_t>(control.disabled);
  control_status_.malformed = static_cast<std::int64_t>(control.malformed);
  control_status_.bad_mac = static_cast<std::int64_t>(control.bad_mac);
  control_status_.stale = static_cast<std::int64_t>(control.stale);
  control_status_.refused = static_cast<std::int64_t>(control.refused);
  control_status_.accepted = static_cast<std::int64_t>(control.accepted);
  control_status_.num_cameras = static_cast<std::int16_t>(cameras);
  control_status_.camera_name.resize(cameras);
  control_status_.camera_threshold.resize(cameras);
  control_status_.camera_background_utime.resize(cameras);
  for (std::size_t k = 0; k < cameras; ++k) {
    control_status_.camera_name[k] = report.cameras[k].name;
    control_status_.camera_threshold[k] = report.cameras[k].threshold;
    control_status_.camera_background_utime[k] = report.cameras[k].background_utime;
  }
  buffer_.resize(static_cast<std::size_t>(control_status_.getEncodedSize()));
  control_status_.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (!bus.publish(control_status_channel_, buffer_)) ++errors_;

  lighting_status_.utime = status_.utime;
  lighting_status_.request_id = request_id;
  lighting_status_.hostname = report.hostname;
  lighting_status_.num_cameras = static_cast<std::int16_t>(cameras);
  lighting_status_.camera_name.resize(cameras);
  lighting_status_.adapt.resize(cameras);
  lighting_status_.gain.resize(cameras);
  lighting_status_.agreement.resize(cameras);
  lighting_status_.explained.resize(cameras);
  lighting_status_.unexplained_frames.resize(cameras);
  for (std::size_t k = 0; k < cameras; ++k) {
    const CameraReport& c = report.cameras[k];
    lighting_status_.camera_name[k] = c.name;
    lighting_status_.adapt[k] = c.lighting_adapt;
    lighting_status_.gain[k] = c.lighting_gain;
    lighting_status_.agreement[k] = c.lighting_agreement;
    lighting_status_.explained[k] = c.lighting_explained;
    lighting_status_.unexplained_frames[k] = static_cast<std::int64_t>(c.unexplained_frames);
  }
  buffer_.resize(static_cast<std::size_t>(lighting_status_.getEncodedSize()));
  lighting_status_.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (!bus.publish(lighting_status_channel_, buffer_)) ++errors_;

  view_status_.utime = status_.utime;
  view_status_.request_id = request_id;
  view_status_.hostname = report.hostname;
  view_status_.num_cameras = static_cast<std::int16_t>(cameras);
  view_status_.camera_name.resize(cameras);
  view_status_.view.resize(cameras);
  view_status_.shift_x_px.resize(cameras);
  view_status_.shift_y_px.resize(cameras);
  view_status_.turn_deg.resize(cameras);
  view_status_.residual_px.resize(cameras);
  view_status_.checked_utime.resize(cameras);
  view_status_.reposes.resize(cameras);
  view_status_.reposed_turn_deg.resize(cameras);
  view_status_.reposed_utime.resize(cameras);
  for (std::size_t k = 0; k < cameras; ++k) {
    const CameraReport& c = report.cameras[k];
    view_status_.camera_name[k] = c.name;
    view_status_.view[k] = c.view;
    view_status_.shift_x_px[k] = c.view_shift_x_px;
    view_status_.shift_y_px[k] = c.view_shift_y_px;
    view_status_.turn_deg[k] = c.view_turn_deg;
    view_status_.residual_px[k] = c.view_residual_px;
    view_status_.checked_utime[k] = c.view_checked_utime;
    view_status_.reposes[k] = c.reposes;
    view_status_.reposed_turn_deg[k] = c.reposed_turn_deg;
    view_status_.reposed_utime[k] = c.reposed_utime;
  }
  buffer_.resize(static_cast<std::size_t>(view_status_.getEncodedSize()));
  view_status_.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (!bus.publish(view_status_channel_, buffer_)) ++errors_;
}

}  // namespace occmap
