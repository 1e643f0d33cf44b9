#pragma once
// Stands in for systemd's end of sd_notify: a datagram socket a test names in NOTIFY_SOCKET for the
// daemon it starts, collecting every message (READY=1, STATUS=..., WATCHDOG=1, STOPPING=1).

#include <chrono>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

namespace occmap::testing {

class NotifyListener {
 public:
  struct Message {
    std::chrono::steady_clock::time_point when;
    std::string text;
  };

  explicit NotifyListener(const std::filesystem::path& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    if (fd_ < 0 || path.string().size() >= sizeof address.sun_path) {
      throw std::runtime_error("cannot make the notify socket");
    }
    std::strcpy(address.sun_path, path.c_str());
    std::filesystem::remove(path);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      throw std::runtime_error("cannot bind the notify socket");
    }
  }
  ~NotifyListener() {
    ::close(fd_);
    std::filesystem::remove(path_);
  }
  NotifyListener(const NotifyListener&) = delete;
  NotifyListener& operator=(const NotifyListener&) = delete;

  const std::filesystem::path& path() const { return path_; }

  // Collects messages for `duration`, or until one contains `until` (then returns true).
  bool collect(std::chrono::milliseconds duration, const std::string& until = "") {
    const auto end = std::chrono::steady_clock::now() + duration;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return false;
      pollfd fd{fd_, POLLIN, 0};
      if (::poll(&fd, 1, static_cast<int>(left.count())) <= 0) continue;
      char buffer[4096];
      const ssize_t got = ::recv(fd_, buffer, sizeof buffer, 0);
      if (got <= 0) continue;
      messages_.push_back(
          {std::chrono::steady_clock::now(), std::string(buffer, static_cast<std::size_t>(got))});
      if (!until.empty() && messages_.back().text.find(until) != std::string::npos) return true;
    }
  }
  const std::vector<Message>& messages() const { return messages_; }
  std::size_t count(const std::string& text) const {
    std::size_t n = 0;
    for (const Message& m : messages_) n += m.text.find(text) != std::string::npos ? 1 : 0;
    return n;
  }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  std::vector<Message> messages_;
};

}  // namespace occmap::testing
