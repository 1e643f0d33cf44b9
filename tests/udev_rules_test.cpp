// systemd/60-occmap-cameras.rules as udev itself reads it. No camera can be plugged in here, so
// what is checked is that udev's own parser (udevadm test, which loads every rules file) takes the
// file without a complaint. It runs in a private mount namespace with a scratch
// /etc/udev/rules.d, so the machine's own rules folder is never touched; it needs root (and
// udevadm, Debian package udev), and skips without them.
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <sched.h>
#include <sys/mount.h>

#include "command_runner.h"

namespace occmap {
namespace {

const std::filesystem::path kRules = OCCMAP_SOURCE_DIR "/systemd/60-occmap-cameras.rules";

TEST(UdevRules, UdevReadsTheCameraRulesWithoutAComplaint) {
  const std::filesystem::path udevadm = "/usr/bin/udevadm";
  if (!std::filesystem::exists(udevadm)) {
    GTEST_SKIP() << "udevadm is not installed (Debian package udev)";
  }
  if (::unshare(CLONE_NEWNS) != 0 ||
      ::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) {
    GTEST_SKIP() << "cannot make a private mount namespace (needs root): " << std::strerror(errno);
  }
  std::filesystem::create_directories("/etc/udev/rules.d");
  ASSERT_EQ(::mount("scratch", "/etc/udev/rules.d", "tmpfs", 0, "mode=0755"), 0)
      << std::strerror(errno);
  std::filesystem::copy_file(kRules, "/etc/udev/rules.d/60-occmap-cameras.rules");
  // A rule that udev refuses, so that the test shows it would see a broken file.
  std::ofstream("/etc/udev/rules.d/61-broken.rules")
      << "SUBSYSTEM==\"usb\", ENV{DEVTYPE}=\"usb_device\", GROUP=\"video\"\n";

  const auto result =
      testing::runCommand({udevadm.string(), "test", "--action=add", "/sys/class/net/lo"});
  const std::string said = result.out + result.err;
  EXPECT_NE(said.find("Reading rules file: /etc/udev/rules.d/60-occmap-cameras.rules"),
            std::string::npos)
      << said;
  EXPECT_NE(said.find("/etc/udev/rules.d/61-broken.rules:1"), std::string::npos)
      << "udev should have refused the broken rule: " << said;
  // udev names a bad line as "<file>:<line> <what is wrong>".
  const std::string ours = "60-occmap-cameras.rules:";
  for (std::size_t at = said.find(ours); at != std::string::npos; at = said.find(ours, at + 1)) {
    const char next = at + ours.size() < said.size() ? said[at + ours.size()] : ' ';
    EXPECT_FALSE(std::isdigit(static_cast<unsigned char>(next))) << "udev complains: " << said;
  }
}

}  // namespace
}  // namespace occmap
