#pragma once
// Starts a daemon as a child process the way a service manager would (arguments, environment,
// stderr to a file), sends it signals and waits for it with a deadline.

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include "command_runner.h"

namespace occmap::testing {

class DaemonProcess {
 public:
  DaemonProcess(const std::vector<std::string>& arguments,
                const std::vector<std::pair<std::string, std::string>>& environment,
                const std::filesystem::path& stderr_file)
      : stderr_file_(stderr_file) {
    pid_ = ::fork();
    if (pid_ == 0) {
      for (const auto& [name, value] : environment) ::setenv(name.c_str(), value.c_str(), 1);
      if (std::freopen(stderr_file.c_str(), "w", stderr) == nullptr) ::_exit(126);
      std::vector<char*> argv;
      for (const std::string& argument : arguments)
        argv.push_back(const_cast<char*>(argument.c_str()));
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }
  ~DaemonProcess() {
    if (running()) {
      ::kill(pid_, SIGKILL);
      waitExit(std::chrono::seconds(5));
    }
  }
  DaemonProcess(const DaemonProcess&) = delete;
  DaemonProcess& operator=(const DaemonProcess&) = delete;

  pid_t pid() const { return pid_; }
  bool running() const { return pid_ > 0 && !exit_code_; }
  void signal(int number) const { ::kill(pid_, number); }
  std::string log() const { return readWhole(stderr_file_); }

  // The exit code once the process has ended within `timeout` (-signal when killed by one).
  std::optional<int> waitExit(std::chrono::milliseconds timeout) {
    if (exit_code_) return exit_code_;
    const auto end = std::chrono::steady_clock::now() + timeout;
    do {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
        return exit_code_;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    } while (std::chrono::steady_clock::now() < end);
    return std::nullopt;
  }

 private:
  pid_t pid_ = -1;
  std::filesystem::path stderr_file_;
  std::optional<int> exit_code_;
};

// A small simulated rig for daemon tests: the paper's room, four cameras, a 256 x 256 map of 4 cm
// cells (fast to build), LCM in process memory unless told otherwise.
inline std::string simRoomConfig(const std::string& lcm_url = "memq://",
                                 const std::string& extra_fusion = "") {
  return "map: {origin_m: [-0.62, -1.87], cell_size_m: 0.04, width: 256, height: 256}\n"
         "fusion: {threshold: 20, column_height_m: 0" +
         extra_fusion +
         "}\n"
         "transport: {lcm_url: \"" +
         lcm_url +
         "\"}\n"
         "cameras:\n"
         "  - {name: c0, source: \"sim://room/c0\"}\n"
         "  - {name: c1, source: \"sim://room/c1\"}\n"
         "  - {name: c2, source: \"sim://room/c2\"}\n"
         "  - {name: c3, source: \"sim://room/c3\"}\n";
}

}  // namespace occmap::testing
