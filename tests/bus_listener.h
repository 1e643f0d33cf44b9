#pragma once
// A test's own program on the daemon's bus: a MemoryBus of the same MemoryNetwork, handled by a
// thread of its own (handlers run there, so the test guards what they write). What it sends goes
// out from that thread too, as another program on the network would send it. stop() hands the
// test every message sent before it: after the daemon's Pipeline::stop(), the last map included.
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
    bus_->subscribe(channel, [handler = std::move(handler)](const std::uint8_t* data,
                                                            std::size_t size,
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
  // Queued here, published by the listener's thread at its next round (within 10 ms).
  void send(std::string channel, std::vector<std::uint8_t> bytes) {
    const std::lock_guard lock(mutex_);
    outbox_.emplace_back(std::move(channel), std::move(bytes));
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
    std::vector<std::pair<std::string, std::vector<std::uint8_t>>> sending;
    {
      const std::lock_guard lock(mutex_);
      sending.swap(outbox_);
    }
    for (const auto& [channel, bytes] : sending) bus_->publish(channel, bytes);
  }

  std::unique_ptr<MemoryBus> bus_;
  std::mutex mutex_;
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> outbox_;
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

}  // namespace occmap::testing
