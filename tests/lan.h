#pragma once
// A small LAN made by a test, as several machines on one switch: this process's private network
// (network_namespace.h) holds a Linux bridge, the switch, with an address of its own so that the
// test itself is a machine on it; each other machine is a process started in a network namespace
// of its own (`unshare --net`), joined to the bridge by a veth pair, with the multicast route on
// its end. Multicast with ttl=1 goes from machine to machine through the bridge, as on a real
// switch, and nothing leaves the test's namespace. A machine's namespace ends with its process,
// and takes its end of the cable with it.
#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "child_process.h"
#include "command_runner.h"

namespace occmap::testing {

class Lan {
 public:
  static constexpr const char* kBridge = "occmap-lan";

  // Call once this process is in its private network. "" when the LAN is up, else why not (then
  // the test skips: no `ip` command, or no right to make links).
  std::string up() {
    if (runCommand({"sh", "-c", "command -v ip"}).exit_code != 0) {
      return "no `ip` command (Debian package iproute2) to make the bridge and veth pairs";
    }
    // Snooping off: the bridge floods multicast to every port, as a switch with no IGMP querier
    // does once its tables age out; the test must not depend on when they do.
    for (const std::string& command :
         {std::string("ip link add ") + kBridge + " type bridge mcast_snooping 0",
          std::string("ip addr add 10.232.0.1/24 dev ") + kBridge,
          std::string("ip link set ") + kBridge + " up",
          std::string("ip route replace 224.0.0.0/4 dev ") + kBridge}) {
      const CommandResult result = runCommand({"sh", "-c", command});
      if (result.exit_code != 0) return command + ": " + result.err;
    }
    return "";
  }

  // Starts `arguments` (arguments[0] a path) on a new machine at 10.232.0.<host>, its files
  // `<files>.out` / `.err`, with `environment` added. `name` names its cable's ends (at most 10
  // characters, unique for the test's life: a machine started again needs another).
  std::unique_ptr<ChildProcess> start(
      const std::string& name, int host, const std::vector<std::string>& arguments,
      const std::filesystem::path& files,
      const std::vector<std::pair<std::string, std::string>>& environment = {}) {
    const std::string outside = "v-" + name, inside = "m-" + name;
    if (!ip("link add " + outside + " type veth peer name " + inside)) return nullptr;
    // The machine waits for its end of the cable, sets it up and becomes the command ("$@").
    std::vector<std::string> command = {
        "/usr/bin/unshare",
        "--net",
        "sh",
        "-c",
        "until ip link show " + inside +
            " >/dev/null 2>&1; do sleep 0.02; done; "
            "ip link set lo up && ip addr add 10.232.0." +
            std::to_string(host) + "/24 dev " + inside + " && ip link set " + inside +
            " up && ip route add 224.0.0.0/4 dev " + inside + " && exec \"$@\"",
        "sh"};
    command.insert(command.end(), arguments.begin(), arguments.end());
    auto process = std::make_unique<ChildProcess>(command, files, environment);
    // Its end of the cable moves once the process is in a namespace of its own.
    const auto own = std::filesystem::read_symlink("/proc/self/ns/net");
    const std::string its = "/proc/" + std::to_string(process->pid()) + "/ns/net";
    for (int i = 0; i < 500; ++i) {
      std::error_code error;
      const auto ns = std::filesystem::read_symlink(its, error);
      if (!error && ns != own) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (!ip("link set " + inside + " netns " + std::to_string(process->pid())) ||
        !ip("link set " + outside + " master " + kBridge) || !ip("link set " + outside + " up")) {
      return nullptr;
    }
    return process;
  }

  // What went wrong last, for the test's message.
  const std::string& error() const { return error_; }

 private:
  bool ip(const std::string& arguments) {
    const CommandResult result = runCommand({"sh", "-c", "ip " + arguments});
    if (result.exit_code != 0) error_ = "ip " + arguments + ": " + result.err;
    return result.exit_code == 0;
  }

  std::string error_;
};

}  // namespace occmap::testing
