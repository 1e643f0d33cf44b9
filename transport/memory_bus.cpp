#include "transport/memory_bus.h"

#include <algorithm>

#include <poll.h>

#include "base/clock.h"

namespace occmap {

struct MemoryNetwork::State {
  std::mutex mutex;
  std::vector<MemoryBus*> buses;
};

MemoryNetwork::MemoryNetwork() : state_(std::make_shared<State>()) {}
MemoryNetwork::~MemoryNetwork() = default;

std::unique_ptr<MemoryBus> MemoryNetwork::connect() { return std::make_unique<MemoryBus>(state_); }

MemoryBus::MemoryBus(std::shared_ptr<MemoryNetwork::State> network)
    : network_(std::move(network)), queue_(16) {
  const std::lock_guard lock(network_->mutex);
  network_->buses.push_back(this);
}

MemoryBus::~MemoryBus() {
  const std::lock_guard lock(network_->mutex);
  auto& buses = network_->buses;
  buses.erase(std::remove(buses.begin(), buses.end(), this), buses.end());
}

bool MemoryBus::publish(const std::string& channel, std::span<const std::uint8_t> message) {
  const std::int64_t utime = hostTimeMicroseconds();
  const std::lock_guard lock(network_->mutex);
  for (MemoryBus* bus : network_->buses) bus->deliver(channel, message, utime);
  return true;
}

void MemoryBus::deliver(const std::string& channel, std::span<const std::uint8_t> message,
                        std::int64_t utime) {
  const std::lock_guard lock(mutex_);
  if (std::find(channels_.begin(), channels_.end(), channel) == channels_.end()) return;
  if (count_ == queue_.size()) {
    // Full: the ring grows (warm-up only; nothing is ever dropped), its messages kept in order.
    std::vector<Message> grown(queue_.size() * 2);
    for (std::size_t i = 0; i < count_; ++i) {
      grown[i] = std::move(queue_[(head_ + i) % queue_.size()]);
    }
    queue_ = std::move(grown);
    head_ = 0;
  }
  Message& slot = queue_[(head_ + count_) % queue_.size()];
  slot.channel.assign(channel);  // into the slot's own buffers: no allocation once they fit
  slot.bytes.assign(message.begin(), message.end());
  slot.recv_utime = utime;
  ++count_;
  wakeup_.signal();
}

bool MemoryBus::subscribe(const std::string& channel, Handler handler) {
  handlers_.emplace_back(channel, std::move(handler));
  const std::lock_guard lock(mutex_);
  if (std::find(channels_.begin(), channels_.end(), channel) == channels_.end()) {
    channels_.push_back(channel);
  }
  return true;
}

void MemoryBus::reserve(std::size_t messages, std::size_t bytes) {
  const std::lock_guard lock(mutex_);
  if (messages > queue_.size()) {
    std::vector<Message> grown(messages);
    for (std::size_t i = 0; i < count_; ++i) {
      grown[i] = std::move(queue_[(head_ + i) % queue_.size()]);
    }
    queue_ = std::move(grown);
    head_ = 0;
  }
  for (Message* message = queue_.data(); message != queue_.data() + queue_.size(); ++message) {
    message->bytes.reserve(bytes);
    message->channel.reserve(64);
  }
  in_hand_.bytes.reserve(bytes);
  in_hand_.channel.reserve(64);
}

std::size_t MemoryBus::pending() const {
  const std::lock_guard lock(mutex_);
  return count_;
}

int MemoryBus::handleTimeout(int timeout_ms) {
  {
    pollfd fd{wakeup_.fd(), POLLIN, 0};
    if (pending() == 0 && ::poll(&fd, 1, timeout_ms) < 0) return -1;
  }
  {
    const std::lock_guard lock(mutex_);
    wakeup_.drain();
    if (count_ == 0) return 0;
    // The message changes buffers with the one handled last, so neither side allocates.
    Message& front = queue_[head_];
    std::swap(front.channel, in_hand_.channel);
    std::swap(front.bytes, in_hand_.bytes);
    in_hand_.recv_utime = front.recv_utime;
    head_ = (head_ + 1) % queue_.size();
    --count_;
    if (count_ > 0) wakeup_.signal();  // fileno() stays readable while messages wait
  }
  for (const auto& [channel, handler] : handlers_) {
    if (channel == in_hand_.channel) {
      handler(in_hand_.bytes.data(), in_hand_.bytes.size(), in_hand_.recv_utime);
    }
  }
  return 1;
}

}  // namespace occmap
