// The systemd parts, checked by systemd's own tools (no systemd runs as PID 1 here): the unit
// passes `systemd-analyze verify` (pointed at the built occmapd, as its ExecStart must exist), its
// sandbox scores "OK" in `systemd-analyze security`, and the sysusers.d and tmpfiles.d snippets
// make the service user (in the video group) and its folders in a scratch root.
#include <cstdlib>

#include <gtest/gtest.h>

#include "command_runner.h"

namespace occmap {
namespace {

using testing::readWhole;
using testing::runCommand;
using testing::TemporaryFolder;

bool haveTool(const std::string& name) {
  return runCommand({"sh", "-c", "command -v " + name}).exit_code == 0;
}

// The unit as installed, with its programs pointed into this build.
std::string unitForThisBuild() {
  std::string unit = readWhole(OCCMAP_SOURCE_DIR "/systemd/occmapd.service");
  auto replace_all = [&](const std::string& from, const std::string& to) {
    for (std::size_t at = unit.find(from); at != std::string::npos;
         at = unit.find(from, at + to.size())) {
      unit.replace(at, from.size(), to);
    }
  };
  replace_all("@CMAKE_INSTALL_FULL_BINDIR@", OCCMAP_BINARY_DIR "/daemon");
  replace_all("@CMAKE_INSTALL_FULL_DOCDIR@", "/usr/share/doc/occmap");
  return unit;
}

TEST(SystemdUnit, PassesSystemdAnalyzeVerify) {
  if (!haveTool("systemd-analyze")) GTEST_SKIP() << "systemd-analyze is not installed";
  TemporaryFolder folder;
  const auto unit = folder.write("occmapd.service", unitForThisBuild());
  const auto result = runCommand({"systemd-analyze", "verify", unit.string()});
  EXPECT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_EQ(result.err.find("occmapd.service:"), std::string::npos)
      << "systemd-analyze found fault with the unit:\n"
      << result.err;
  const std::string text = readWhole(unit);
  for (const char* setting :
       {"Type=notify", "WatchdogSec=", "Restart=on-failure", "RestartPreventExitStatus=2",
        "SupplementaryGroups=video", "--config /etc/occmap/occmapd.yaml"}) {
    EXPECT_NE(text.find(setting), std::string::npos) << setting;
  }
}

TEST(SystemdUnit, SandboxScoresOk) {
  if (!haveTool("systemd-analyze")) GTEST_SKIP() << "systemd-analyze is not installed";
  TemporaryFolder folder;
  const auto unit = folder.write("occmapd.service", unitForThisBuild());
  const auto result = runCommand({"systemd-analyze", "security", "--offline=true", unit.string()});
  const std::string marker = "Overall exposure level for occmapd.service: ";
  const std::size_t at = result.out.find(marker);
  ASSERT_NE(at, std::string::npos) << result.out << result.err;
  const double exposure = std::strtod(result.out.c_str() + at + marker.size(), nullptr);
  std::printf("systemd-analyze security: exposure %.1f\n", exposure);
  EXPECT_LE(exposure, 2.0) << "the unit's sandbox has widened:\n" << result.out;
}

TEST(SystemdUnit, SysusersAndTmpfilesMakeTheUserAndItsFolders) {
  if (!haveTool("systemd-sysusers") || !haveTool("systemd-tmpfiles")) {
    GTEST_SKIP() << "systemd-sysusers or systemd-tmpfiles is not installed";
  }
  TemporaryFolder root;
  std::filesystem::create_directories(root / "etc");
  auto result = runCommand({"systemd-sysusers", "--root=" + root.path().string(),
                            OCCMAP_SOURCE_DIR "/systemd/occmap.sysusers"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(readWhole(root / "etc/passwd").find("occmap:x:"), std::string::npos);
  const std::string groups = readWhole(root / "etc/group");
  const std::size_t video = groups.find("video:x:");
  ASSERT_NE(video, std::string::npos) << groups;
  EXPECT_NE(groups.substr(video, groups.find('\n', video) - video).find("occmap"),
            std::string::npos)
      << "occmap must be a member of video:\n"
      << groups;
  result = runCommand({"systemd-tmpfiles", "--create", "--root=" + root.path().string(),
                       OCCMAP_SOURCE_DIR "/systemd/occmap.tmpfiles"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_TRUE(std::filesystem::is_directory(root / "etc/occmap"));
  EXPECT_TRUE(std::filesystem::is_directory(root / "var/lib/occmap"));
}

TEST(Install, PutsTheProgramsUnitAndSnippetsInPlace) {
  TemporaryFolder prefix;
  const auto result =
      runCommand({"cmake", "--install", OCCMAP_BINARY_DIR, "--prefix", prefix.path().string()});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  for (const char* file : {"bin/occmapd", "bin/occmap", "lib/systemd/system/occmapd.service",
                           "lib/sysusers.d/occmap.conf", "lib/tmpfiles.d/occmap.conf",
                           "share/occmap/examples/sim-room.yaml"}) {
    EXPECT_TRUE(std::filesystem::exists(prefix / file)) << file << " not installed";
  }
  const std::string unit = readWhole(prefix / "lib/systemd/system/occmapd.service");
  EXPECT_NE(unit.find("/bin/occmapd --config /etc/occmap/occmapd.yaml"), std::string::npos) << unit;
  EXPECT_EQ(unit.find("@CMAKE_"), std::string::npos) << "an unconfigured @VARIABLE@ is left:\n"
                                                     << unit;
}

}  // namespace
}  // namespace occmap
