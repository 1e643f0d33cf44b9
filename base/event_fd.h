#pragma once
// A wake-up between threads that poll(2) can wait on with other descriptors: one thread signals,
// another waits on fd() and drains. Non-blocking, so neither side ever waits inside these calls.

#include "base/unique_fd.h"

namespace occmap {

class EventFd {
 public:
  // Throws std::system_error when the kernel has no eventfd to give.
  EventFd();
  EventFd(EventFd&&) = default;
  EventFd& operator=(EventFd&&) = default;

  int fd() const { return fd_.get(); }
  // Any thread: makes fd() readable.
  void signal() const;
  // The waiting thread: makes fd() unreadable again (what was signalled is taken).
  void drain() const;

 private:
  UniqueFd fd_;
};

}  // namespace occmap
