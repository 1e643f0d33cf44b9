// The systemd parts, checked by systemd's own tools (no systemd runs as PID 1 here): the unit
// passes `systemd-analyze verify` (pointed at the built occmapd, as its ExecStart must exist), its
// sandbox scores "OK" in `systemd-analyze security`, the sysusers.d and tmpfiles.d snippets make
// the service user (in the video group) and its folders in a scratch root, and `cmake --install`
// writes a unit that names the programs where that installation put them.
#include <cstdlib>
#include <sstream>
#include <vector>

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

// The values of every `key=` line of a unit, in order.
std::vector<std::string> settings(const std::string& unit, const std::string& key) {
  std::vector<std::string> values;
  std::istringstream lines(unit);
  for (std::string line; std::getline(lines, line);) {
    if (line.starts_with(key + "=")) values.push_back(line.substr(key.size() + 1));
  }
  return values;
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

// A bad config must stop the service, not restart it: systemd applies RestartPreventExitStatus=
// to the main process only (systemd issue #11868), so the check cannot run as ExecStartPre=, and
// occmapd makes it itself. A reload checks the new config before signalling the daemon, so that
// `systemctl reload` fails on a bad one.
TEST(SystemdUnit, ABadConfigStopsTheServiceAndFailsAReload) {
  const std::string unit = unitForThisBuild();
  const std::string occmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
  EXPECT_EQ(settings(unit, "ExecStartPre"), std::vector<std::string>{}) << unit;
  EXPECT_EQ(settings(unit, "ExecStart"),
            std::vector<std::string>{occmapd + " --config /etc/occmap/occmapd.yaml"});
  EXPECT_EQ(settings(unit, "RestartPreventExitStatus"), std::vector<std::string>{"2"});
  EXPECT_EQ(settings(unit, "ExecReload"),
            (std::vector<std::string>{occmapd + " --check --config /etc/occmap/occmapd.yaml",
                                      "/bin/kill -HUP $MAINPID"}));
  // The exit code the unit relies on: an invalid config is exit 2 from the main process itself.
  TemporaryFolder folder;
  const auto config =
      folder.write("bad.yaml", "map: {width: 30, height: 30}\nfusion: {treshold: 20}\n");
  const auto result = runCommand({occmapd, "--config", config.string()});
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
}

// systemd keeps the folders' modes as the unit says; they must be those of occmap.tmpfiles, or
// systemd warns at every start (/etc/occmap) or opens the state folder up again (/var/lib/occmap).
TEST(SystemdUnit, FolderModesAgreeWithTmpfiles) {
  const std::string unit = unitForThisBuild();
  const std::string tmpfiles = readWhole(OCCMAP_SOURCE_DIR "/systemd/occmap.tmpfiles");
  const auto modeIn = [&](const std::string& folder) {
    std::istringstream lines(tmpfiles);
    for (std::string line; std::getline(lines, line);) {
      std::istringstream fields(line);
      std::string type, path, mode;
      fields >> type >> path >> mode;
      if (type == "d" && path == folder) return mode;
    }
    return std::string("(not in occmap.tmpfiles)");
  };
  EXPECT_EQ(settings(unit, "ConfigurationDirectory"), std::vector<std::string>{"occmap"});
  EXPECT_EQ(settings(unit, "ConfigurationDirectoryMode"),
            std::vector<std::string>{modeIn("/etc/occmap")});
  EXPECT_EQ(settings(unit, "StateDirectory"), std::vector<std::string>{"occmap"});
  EXPECT_EQ(settings(unit, "StateDirectoryMode"),
            std::vector<std::string>{modeIn("/var/lib/occmap")});
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

// The opt-in drop-ins (docs/cameras.md) widen exactly what they say, and systemd takes them.
TEST(SystemdUnit, TheCameraDropInsWidenOnlyWhatTheySay) {
  if (!haveTool("systemd-analyze")) GTEST_SKIP() << "systemd-analyze is not installed";
  TemporaryFolder folder;
  const auto unit = folder.write("occmapd.service", unitForThisBuild());
  auto security = [&] {
    return runCommand({"systemd-analyze", "security", "--offline=true", unit.string()}).out;
  };
  auto granted = [](const std::string& report, const std::string& check) {
    std::istringstream lines(report);
    for (std::string line; std::getline(lines, line);) {
      if (line.find(check) != std::string::npos) return line.rfind("\u2717", 0) == 0;  // a cross
    }
    return false;
  };
  const std::string before = security();
  EXPECT_FALSE(granted(before, "RestrictRealtime=")) << before;
  EXPECT_FALSE(granted(before, "RestrictAddressFamilies=~AF_PACKET")) << before;
  for (const char* drop_in : {"occmapd-realtime.conf", "occmapd-packet-socket.conf"}) {
    folder.write(std::string("occmapd.service.d/") + drop_in,
                 readWhole(std::string(OCCMAP_SOURCE_DIR "/systemd/") + drop_in));
  }
  const auto verify = runCommand({"systemd-analyze", "verify", unit.string()});
  EXPECT_EQ(verify.exit_code, 0) << verify.err;
  EXPECT_EQ(verify.err.find("occmapd"), std::string::npos) << verify.err;
  const std::string after = security();
  EXPECT_TRUE(granted(after, "RestrictRealtime=")) << after;
  EXPECT_TRUE(granted(after, "RestrictAddressFamilies=~AF_PACKET")) << after;
  EXPECT_TRUE(granted(after, "CapabilityBoundingSet=~CAP_NET_(BIND_SERVICE|BROADCAST|RAW)"))
      << after;
  EXPECT_FALSE(granted(after, "CapabilityBoundingSet=~CAP_SYS_ADMIN")) << after;
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

// Installed to a prefix other than the one this build was configured with (/usr/local by
// default), the unit names the programs under that prefix.
TEST(Install, PutsTheProgramsUnitAndSnippetsInPlace) {
  TemporaryFolder prefix;
  const auto result =
      runCommand({"cmake", "--install", OCCMAP_BINARY_DIR, "--prefix", prefix.path().string()});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  for (const char* file :
       {"bin/occmapd", "bin/occmap", "lib/systemd/system/occmapd.service",
        "lib/sysusers.d/occmap.conf", "lib/tmpfiles.d/occmap.conf",
        "share/occmap/examples/sim-room.yaml", "lib/udev/rules.d/60-occmap-cameras.rules",
        "share/doc/occmap/systemd-drop-ins/occmapd-realtime.conf",
        "share/doc/occmap/systemd-drop-ins/occmapd-packet-socket.conf",
        "share/doc/occmap/cameras.md"}) {
    EXPECT_TRUE(std::filesystem::exists(prefix / file)) << file << " not installed";
  }
  const std::string unit = readWhole(prefix / "lib/systemd/system/occmapd.service");
  const std::string occmapd = (prefix / "bin/occmapd").string();
  EXPECT_EQ(settings(unit, "ExecStart"),
            std::vector<std::string>{occmapd + " --config /etc/occmap/occmapd.yaml"})
      << unit;
  EXPECT_EQ(settings(unit, "ExecReload").at(0),
            occmapd + " --check --config /etc/occmap/occmapd.yaml");
  EXPECT_EQ(settings(unit, "Documentation"),
            std::vector<std::string>{"file:" + (prefix / "share/doc/occmap/README.md").string()});
  EXPECT_EQ(unit.find("@CMAKE_"), std::string::npos) << "an unconfigured @VARIABLE@ is left:\n"
                                                     << unit;
}

// A package build stages the files under DESTDIR; the unit names where they will be on the target
// system, without the staging folder.
TEST(Install, UnderDestdirTheUnitNamesTheFinalPaths) {
  TemporaryFolder stage;
  const auto result = runCommand({"env", "DESTDIR=" + stage.path().string(), "cmake", "--install",
                                  OCCMAP_BINARY_DIR, "--prefix", "/opt/occmap"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_TRUE(std::filesystem::exists(stage / "opt/occmap/bin/occmapd"));
  const std::string unit = readWhole(stage / "opt/occmap/lib/systemd/system/occmapd.service");
  EXPECT_EQ(settings(unit, "ExecStart"),
            std::vector<std::string>{"/opt/occmap/bin/occmapd --config /etc/occmap/occmapd.yaml"})
      << unit;
}

}  // namespace
}  // namespace occmap
