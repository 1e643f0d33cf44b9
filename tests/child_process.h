#pragma once
// A program started in the background for a test, its standard output and error going to files
// that the test can read while it runs (to wait for a line such as "listening ..."). Killed and
// reaped when the object goes.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include "command_runner.h"

namespace occmap::testing {

class ChildProcess {
 public:
  // Starts arguments[0] (a path) with the arguments and, on top of this process's environment,
  // `environment`; output goes to `<files>.out` and `.err`.
  ChildProcess(const std::vector<std::string>& arguments, const std::filesystem::path& files,
               const std::vector<std::pair<std::string, std::string>>& environment = {})
      : out_(files.string() + ".out"), err_(files.string() + ".err") {
    std::fflush(nullptr);
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ == 0) {
      // Dies with the test: a test killed by a sanitizer (halt_on_error) or a timeout runs no
      // destructor, and a daemon left behind would hold a core and its ports for the next tests.
      // (The signal comes when the forking thread ends: tests start children from their own.)
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(125);  // the test was gone before prctl took effect
      for (const auto& [name, value] : environment) ::setenv(name.c_str(), value.c_str(), 1);
      if (std::freopen(out_.c_str(), "w", stdout) == nullptr) ::_exit(126);
      if (std::freopen(err_.c_str(), "w", stderr) == nullptr) ::_exit(126);
      std::vector<char*> argv;
      for (const std::string& argument : arguments) {
        argv.push_back(const_cast<char*>(argument.c_str()));
      }
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }
  ~ChildProcess() {
    if (pid_ > 0 && !exit_code_) {
      ::kill(pid_, SIGKILL);
      waitExit(std::chrono::seconds(5));
    }
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool started() const { return pid_ > 0; }
  pid_t pid() const { return pid_; }
  // Still running (not yet seen to end by waitExit()).
  bool running() { return pid_ > 0 && !waitExit(std::chrono::milliseconds(0)); }
  void signal(int number) const {
    if (pid_ > 0 && !exit_code_) ::kill(pid_, number);
  }
  std::string out() const { return readWhole(out_); }
  std::string err() const { return readWhole(err_); }

  // Waits until standard output contains `text` (true) or the process ends or `timeout` passes.
  bool waitForOutput(const std::string& text, std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      if (out().find(text) != std::string::npos) return true;
      if (waitExit(std::chrono::milliseconds(0))) return out().find(text) != std::string::npos;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }

  // The exit code once the process has ended within `timeout` (-signal when a signal ended it).
  std::optional<int> waitExit(std::chrono::milliseconds timeout) {
    if (exit_code_ || pid_ <= 0) return exit_code_;
    const auto end = std::chrono::steady_clock::now() + timeout;
    do {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
        return exit_code_;
      }
      if (std::chrono::steady_clock::now() >= end) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    } while (true);
    return std::nullopt;
  }

 private:
  std::string out_, err_;
  pid_t pid_ = -1;
  std::optional<int> exit_code_;
};

}  // namespace occmap::testing
