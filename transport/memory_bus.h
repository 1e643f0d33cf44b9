#pragma once
// A Bus in memory (transport/bus.h), for tests: buses connected to one MemoryNetwork hear each
// other as programs on one LCM network do, in order and without loss, with no socket and no
// namespace. Unlike LCM's memq://, which is private to its one handle, a test has a bus of its own
// beside the daemon's, publishes requests from its thread and listens in its own; and because a
// test can wrap a Bus, faults (a publish that blocks, a message lost) go in between without a hook
// in the daemon.
//
// Channels match by their exact name (LCM's regular expressions are not needed by any test).
// Threads: each bus is used by one thread, as every Bus is; different buses of one network may be
// used from different threads. Once warm (its queue and message buffers grown to the traffic),
// publishing and handling allocate nothing.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "base/event_fd.h"
#include "transport/bus.h"

namespace occmap {

class MemoryBus;

class MemoryNetwork {
 public:
  MemoryNetwork();
  ~MemoryNetwork();
  MemoryNetwork(const MemoryNetwork&) = delete;
  MemoryNetwork& operator=(const MemoryNetwork&) = delete;

  // A new bus on this network. It may outlive the network object (the network's state is shared).
  std::unique_ptr<MemoryBus> connect();

  struct State;

 private:
  std::shared_ptr<State> state_;
};

class MemoryBus final : public Bus {
 public:
  explicit MemoryBus(std::shared_ptr<MemoryNetwork::State> network);
  ~MemoryBus() override;

  // Every bus of the network that subscribed to `channel`, this one included, gets a copy.
  bool publish(const std::string& channel, std::span<const std::uint8_t> message) override;
  bool subscribe(const std::string& channel, Handler handler) override;
  int fileno() override { return wakeup_.fd(); }
  int handleTimeout(int timeout_ms) override;

  // Messages waiting to be handled (any thread).
  std::size_t pending() const;
  // Makes room now for `messages` waiting messages of up to `bytes` each, so that traffic within
  // that allocates nothing at all (tests that count allocations); otherwise the queue grows as
  // needed. Before the bus is handed to another thread.
  void reserve(std::size_t messages, std::size_t bytes);

 private:
  struct Message {
    std::string channel;
    std::vector<std::uint8_t> bytes;
    std::int64_t recv_utime = 0;
  };
  void deliver(const std::string& channel, std::span<const std::uint8_t> message,
               std::int64_t utime);

  std::shared_ptr<MemoryNetwork::State> network_;
  EventFd wakeup_;
  mutable std::mutex
      mutex_;  // the queue and the subscribed channels (publishers come from anywhere)
  std::vector<Message> queue_;  // a ring: count_ messages from head_
  std::size_t head_ = 0;
  std::size_t count_ = 0;
  std::vector<std::string> channels_;
  // Owner thread only: the handlers, and the message being handled.
  std::vector<std::pair<std::string, Handler>> handlers_;
  Message in_hand_;
};

}  // namespace occmap
