#pragma once
// What python_example_test and python_example_raw_test share: where Debian's python3, the example
// and its types are, why the example cannot run here, and the script listening live while the
// map publisher sends.

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "child_process.h"
#include "command_runner.h"
#include "network_namespace.h"
#include "temporary_folder.h"

namespace occmap::testing {

// Debian's python, where apt puts python3-zstandard (the PATH's python3 may be another one).
inline const std::string kPython = "/usr/bin/python3";
inline const std::string kScript = OCCMAP_SOURCE_DIR "/examples/python/map_subscriber.py";
inline const std::string kTypes = OCCMAP_BINARY_DIR "/lcmtypes/python";
inline const std::string kPublisher = OCCMAP_BINARY_DIR "/tests/map_publisher";

// Why the example cannot run here, or "".
inline std::string missingPython() {
  if (!std::filesystem::exists(kPython))
    return kPython + " is missing (Debian: apt install python3)";
  const auto result = runCommand({kPython, "-c", "import zstandard"});
  if (result.exit_code != 0) {
    return kPython + " has no zstandard module (Debian: apt install python3-zstandard)";
  }
  return "";
}

// The script on a live LCM network in this process's private network namespace (skips without
// python or without the right to make one).
class PythonExampleLive : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::string why = missingPython(); !why.empty()) GTEST_SKIP() << why;
    const std::string& problem = enterPrivateNetwork();
    if (!problem.empty()) GTEST_SKIP() << problem;
  }

  // Runs the script (with `options` besides the URL, --count and --timeout) on the network while
  // the publisher runs each of `runs`; returns its output.
  std::string receive(const std::string& url, int maps,
                      const std::vector<std::vector<std::string>>& runs,
                      const std::vector<std::string>& options = {}) {
    using namespace std::chrono_literals;
    std::vector<std::string> arguments = {kPython,     kScript, "--types", kTypes,
                                          "--lcm-url", url,     "--count", std::to_string(maps),
                                          "--timeout", "15"};
    arguments.insert(arguments.end(), options.begin(), options.end());
    ChildProcess script(arguments, folder_ / "script");
    EXPECT_TRUE(script.waitForOutput("listening for maps", 10s)) << script.out() << script.err();
    for (std::vector<std::string> run : runs) {
      run.insert(run.begin(), kPublisher);
      run.insert(run.end(), {"--lcm-url", url});
      const auto result = runCommand(run);
      EXPECT_EQ(result.exit_code, 0) << result.out << result.err;
    }
    const auto code = script.waitExit(20s);
    EXPECT_EQ(code, std::optional<int>(0)) << script.out() << script.err();
    return script.out();
  }

  TemporaryFolder folder_;
};

}  // namespace occmap::testing
