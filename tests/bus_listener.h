#pragma once
// A test's own program on the daemon's bus: a MemoryBus of the same MemoryNetwork, handled by a
// thread of its own (handlers run there, so the test guards what they write). What it sends goes
// out from that thread too, as another program on the network would send it. stop() hands the
// test every message sent before it: after the daemon's Pipeline::stop(), the last map included.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "transport/memory_bus.h"

namespace occmap::testing {

class BusListener {
 public:
  using Handler = std::function<void(const std::uint8_t* data, std::size_t size)>;

  explicit BusListener(MemoryNetwork& network) : bus_(network.connect()) {}
  ~BusListener() { stop(); }
  BusListener(const BusListener&) = delete;
  BusListener& operator=(const BusListener&) = delete;

  // Before start().
  void subscribe(const std::string& channel, Handler handler) {
    bus_->subscribe(channel,
                    [handler = std::move(handler)](const std::uint8_t* data, std::size_t size,
                                                   std::int64_t) { handler(data, size); });
  }
  void start() {
    thread_ = std::thread([this] {
      while (!stopping_.load()) {
        sendQueued();
        bus_->handleTimeout(10);
      }
    });
  }
  // Queued here, published by the listener's thread at its next round (within 10 ms). Once a
  // channel was sent on and reserve() made room, sending allocates nothing.
  void send(const std::string& channel, std::vector<std::uint8_t> bytes) {
    const std::lock_guard lock(mutex_);
    auto known = std::find(channels_.begin(), channels_.end(), channel);
    if (known == channels_.end()) known = channels_.insert(channels_.end(), channel);
    outbox_.emplace_back(static_cast<std::size_t>(known - channels_.begin()), std::move(bytes));
  }
  // Room for `messages` queued sends, and on this side's bus for `messages` received ones of up
  // to `bytes` each (see MemoryBus::reserve). Before start().
  void reserve(std::size_t messages, std::size_t bytes) {
    const std::lock_guard lock(mutex_);
    outbox_.reserve(messages);
    sending_.reserve(messages);
    bus_->reserve(messages, bytes);
  }
  // Ends the thread, then handles here whatever is still waiting.
  void stop() {
    if (!thread_.joinable()) return;
    stopping_.store(true);
    thread_.join();
    while (bus_->handleTimeout(0) > 0) {
    }
  }

 private:
  void sendQueued() {
    const std::lock_guard lock(mutex_);
    sending_.swap(outbox_);  // the two trade their storage: no allocation
    for (const auto& [channel, bytes] : sending_) bus_->publish(channels_[channel], bytes);
    sending_.clear();
  }

  std::unique_ptr<MemoryBus> bus_;
  std::mutex mutex_;
  std::vector<std::string> channels_;  // what was sent on, each made once
  std::vector<std::pair<std::size_t, std::vector<std::uint8_t>>> outbox_;  // (channel, bytes)
  std::vector<std::pair<std::size_t, std::vector<std::uint8_t>>> sending_;
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

}  // namespace occmap::testing
