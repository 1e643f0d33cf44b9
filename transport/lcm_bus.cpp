#include "transport/lcm_bus.h"

#include <algorithm>
#include <stdexcept>

#include <lcm/lcm-cpp.hpp>

namespace occmap {

std::string statusRequestChannel(const std::string& status_channel) {
  return status_channel + "_REQUEST";
}

std::string lightingStatusChannel(const std::string& status_channel) {
  return status_channel + "_LIGHTING";
}

std::string viewStatusChannel(const std::string& status_channel) {
  return status_channel + "_VIEW";
}

namespace {

// LCM's C callback. Subscriptions go through LCM's C API rather than lcm::LCM::subscribe: that
// template builds a std::string of the channel for every message (an allocation for names longer
// than 15 bytes, such as OCCMAP_STATUS_REQUEST), and GCC 12's -fsanitize=vptr (part of UBSan)
// misreads its subscription objects and crashes in the callback.
void dispatch(const lcm_recv_buf_t* buffer, const char* /*channel*/, void* context) {
  const auto& handler = *static_cast<const LcmBus::Handler*>(context);
  handler(static_cast<const std::uint8_t*>(buffer->data), buffer->data_size, buffer->recv_utime);
}

}  // namespace

LcmBus::LcmBus(const std::string& url) : url_(url), lcm_(std::make_unique<lcm::LCM>(url)) {}

LcmBus::~LcmBus() = default;

std::unique_ptr<LcmBus> LcmBus::open(const std::string& url) {
  auto bus = std::make_unique<LcmBus>(url);
  if (!bus->good()) {
    throw std::runtime_error("cannot open LCM at " + url +
                             " (a udpm:// URL needs a network with a multicast route; see "
                             "docs/daemon.md)");
  }
  return bus;
}

bool LcmBus::good() const { return lcm_->good(); }

bool LcmBus::publish(const std::string& channel, std::span<const std::uint8_t> message) {
  if (!lcm_->good() || message.size() > static_cast<std::size_t>(LCM_MAX_MESSAGE_SIZE)) {
    return false;
  }
  return lcm_->publish(channel, message.data(), static_cast<unsigned int>(message.size())) == 0;
}

bool LcmBus::subscribe(const std::string& channel, Handler handler) {
  return subscribeBursts(channel, 0, std::move(handler));
}

bool LcmBus::subscribeBursts(const std::string& channel, std::size_t queue_depth, Handler handler) {
  if (!lcm_->good()) return false;
  auto stored = std::make_unique<Handler>(std::move(handler));
  handlers_.reserve(handlers_.size() + 1);  // so that push_back cannot throw below
  lcm_subscription_t* subscription =
      lcm_subscribe(lcm_->getUnderlyingLCM(), channel.c_str(), dispatch, stored.get());
  if (subscription == nullptr) return false;
  // 0: LCM's own depth (30 messages), which a program that keeps up never fills.
  if (queue_depth > 0) {
    lcm_subscription_set_queue_capacity(
        subscription, static_cast<int>(std::min<std::size_t>(queue_depth, 1 << 20)));
  }
  handlers_.push_back(std::move(stored));
  return true;
}

int LcmBus::fileno() { return lcm_->good() ? lcm_->getFileno() : -1; }

int LcmBus::handleTimeout(int timeout_ms) {
  return lcm_->good() ? lcm_->handleTimeout(timeout_ms) : -1;
}

}  // namespace occmap
