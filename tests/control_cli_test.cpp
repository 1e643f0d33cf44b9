// `occmap control` against occmapd, both as processes, over LCM's UDP multicast in a private
// network namespace (docs/control.md): a threshold set and seen in `occmap status`, a reason for a
// refusal, no reply (exit 3) under another key, a reload (SIGHUP) going back to the config's
// values; and --make-key. Skips without a network namespace (root or CAP_SYS_ADMIN).
#include <chrono>
#include <filesystem>
#include <numbers>
#include <thread>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>

#include "capture/image_file.h"
#include "capture/sim/scene.h"
#include "child_process.h"
#include "config/calibration_file.h"
#include "core/tsai_camera.h"
#include "network_namespace.h"
#include "sim_room_config.h"
#include "temporary_folder.h"
#include "timing.h"

namespace occmap {
namespace {

using namespace std::chrono_literals;
using testing::ChildProcess;
using testing::runCommand;
using testing::TemporaryFolder;

const std::string kOccmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";

bool waitForError(ChildProcess& process, const std::string& text, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (process.err().find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(20ms);
  }
  return false;
}

TEST(OccmapControl, MakeKeyWritesAPrivateKeyAndNeverReplacesOne) {
  TemporaryFolder folder;
  const std::string key = (folder / "control.key").string();
  auto result = runCommand({kOccmap, "control", "--make-key", key});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("chown occmap"), std::string::npos) << result.out;
  struct stat info {};
  ASSERT_EQ(::stat(key.c_str(), &info), 0);
  EXPECT_EQ(info.st_mode & 0777, 0600u);
  result = runCommand({kOccmap, "control", "--make-key", key});
  EXPECT_EQ(result.exit_code, 2) << "an existing key must not be replaced";
  result = runCommand({kOccmap, "control", "--help"});
  EXPECT_EQ(result.exit_code, 0);
  for (const char* words : {"set-threshold", "recapture-background", "--make-key", "--key-file",
                            "HMAC", "replay window", "SIGHUP", "docs/control.md", "Exit codes"}) {
    EXPECT_NE(result.out.find(words), std::string::npos) << "--help does not mention " << words;
  }
  result = runCommand({kOccmap, "control", "--key-file", key});
  EXPECT_EQ(result.exit_code, 2) << "no command given";
}

TEST(OccmapControl, SetsAThresholdThatStatusShowsAndAReloadPutsBack) {
  if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
    GTEST_SKIP() << problem;
  }
  TemporaryFolder folder;
  const std::string key = (folder / "control.key").string();
  ASSERT_EQ(runCommand({kOccmap, "control", "--make-key", key}).exit_code, 0);
  const auto config = folder.write(
      "room.yaml", testing::simRoomConfig("udpm://239.255.76.67:7667?ttl=0") +
                       "control: {enabled: true, key_file: control.key, replay_window_s: 10}\n");
  ChildProcess daemon({kOccmapd, "--config", config.string()}, folder / "occmapd");
  ASSERT_TRUE(waitForError(daemon, "ready:", testing::eventually(30s))) << daemon.err();

  auto result = runCommand({kOccmap, "control", "--key-file", key, "set-threshold", "c0", "35"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find("done: camera c0: threshold 35 (was 20)"), std::string::npos)
      << result.out;
  result = runCommand({kOccmap, "status", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("\"camera_threshold\":[35,20,20,20]"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("\"control_accepted\":1"), std::string::npos) << result.out;

  // Refused, with the reason, exit 1; options after the command work too.
  result = runCommand({kOccmap, "control", "set-threshold", "c7", "35", "--key-file", key});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("refused: no camera named \"c7\""), std::string::npos) << result.err;

  // Another key: the daemon answers nothing, so the client has no result (exit 3).
  const std::string other = (folder / "other.key").string();
  ASSERT_EQ(runCommand({kOccmap, "control", "--make-key", other}).exit_code, 0);
  result = runCommand(
      {kOccmap, "control", "--key-file", other, "--timeout", "1", "set-threshold", "c0", "99"});
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_NE(result.err.find("no reply"), std::string::npos) << result.err;
  result = runCommand({kOccmap, "status"});
  EXPECT_NE(result.out.find("1 bad mac"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("c0: threshold 35, background from the config"), std::string::npos)
      << result.out;

  // A reload goes back to the config's values.
  daemon.signal(SIGHUP);
  ASSERT_TRUE(waitForError(daemon, "reloaded", testing::eventually(30s))) << daemon.err();
  bool back = false;
  for (int attempt = 0; attempt < 20 && !back; ++attempt) {
    result = runCommand({kOccmap, "status", "--json"});
    back = result.out.find("\"camera_threshold\":[20,20,20,20]") != std::string::npos;
    if (!back) std::this_thread::sleep_for(200ms);
  }
  EXPECT_TRUE(back) << "after SIGHUP the thresholds should be the config's: " << result.out;
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.waitExit(testing::eventually(5s)), 0) << daemon.err();
}

// A knocked camera (sim://room-knock: c1 turned by 1 degree at 1 s) through the log and `occmap
// status`: found moved, by about the degree it turned, and left out of the maps (view_status_t);
// then, its view still for 2 s, re-posed by that turn and back in the maps, and said so.
TEST(OccmapStatus, SaysWhichCameraWasMovedHowFarItTurnedAndThatItWasRePosed) {
  if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
    GTEST_SKIP() << problem;
  }
  TemporaryFolder folder;
  std::string text = testing::simRoomConfig("udpm://239.255.76.67:7667?ttl=0");
  for (std::size_t at = text.find("sim://room/"); at != std::string::npos;
       at = text.find("sim://room/", at)) {
    text.replace(at, std::string("sim://room/").size(), "sim://room-knock/");
  }
  // The zones judge the floor hidden behind the people found, so that the re-posed camera's pose
  // is handed to them too (daemon/pose_handover.h, in daemon/pipeline.cpp, under the sanitizers).
  text +=
      "zones:\n"
      "  - {name: walkway, polygon_m: [[3.5, 1.0], [5.5, 1.0], [5.5, 5.0], [3.5, 5.0]]}\n"
      "footprints: {hidden_floor_unseen: true}\n";
  const auto config = folder.write("room.yaml", text);
  // The state directory systemd gives it (StateDirectory=): where the corrected calibration goes.
  std::filesystem::create_directories(folder / "state");
  ChildProcess daemon({kOccmapd, "--config", config.string()}, folder / "occmapd",
                      {{"STATE_DIRECTORY", (folder / "state").string()}});
  ASSERT_TRUE(waitForError(daemon, "ready:", testing::eventually(30s))) << daemon.err();
  ASSERT_TRUE(
      waitForError(daemon, "camera c1: its view moved: it turned", testing::eventually(10s)))
      << daemon.err();
  EXPECT_EQ(daemon.err().find("camera c0: its view moved"), std::string::npos) << daemon.err();

  bool moved = false;
  testing::CommandResult result;
  for (int attempt = 0; attempt < 20 && !moved; ++attempt) {
    result = runCommand({kOccmap, "status", "--json"});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    moved = result.out.find(
                "\"view_name\":[\"as calibrated\",\"moved\",\"as calibrated\","
                "\"as calibrated\"]") != std::string::npos;
    if (!moved) std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(moved) << result.out;
  const auto turn = nlohmann::json::parse(result.out)["view_turn_deg"];
  ASSERT_EQ(turn.size(), 4u) << result.out;
  EXPECT_NEAR(turn[1].get<double>(), 1.0, 0.1) << result.out;
  EXPECT_EQ(turn[0].get<double>(), 0.0) << result.out;
  result = runCommand({kOccmap, "status"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("c1: DEGRADED, MOVED: it turned"), std::string::npos) << result.out;

  // Re-posed (the scene loops at 20 s, when c1 is back where it was: long before that).
  ASSERT_TRUE(waitForError(daemon, "camera c1: re-posed, turned", testing::eventually(15s)))
      << daemon.err();
  bool back = false;
  for (int attempt = 0; attempt < 20 && !back; ++attempt) {
    result = runCommand({kOccmap, "status", "--json"});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    back = result.out.find("\"lighting_explained\":[true,true,true,true]") != std::string::npos &&
           result.out.find("\"view_reposes\":[0,1,0,0]") != std::string::npos;
    if (!back) std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(back) << result.out;
  const auto reposed = nlohmann::json::parse(result.out)["view_reposed_turn_deg"];
  EXPECT_NEAR(reposed[1].get<double>(), 1.0, 0.1) << result.out;
  result = runCommand({kOccmap, "status"});
  EXPECT_NE(result.out.find("c1: light 1.00 x the background's"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("re-posed 1 time after a knock"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("zone walkway"), std::string::npos) << result.out;
  // The corrected calibration, saved in the file kind it came from (the scene's cameras are
  // Tsai's): the same camera, turned by the degree it was knocked.
  EXPECT_NE(daemon.err().find("the whole calibration is saved to " +
                              (folder / "state" / "calibration-c1.xml").string()),
            std::string::npos)
      << daemon.err();
  const TsaiParameters before = sim::makeScene("room")->cameras()[1].calibration;
  const TsaiParameters after = loadTsaiXml(folder / "state" / "calibration-c1.xml");
  const Eigen::Matrix3d knocked =
      rotationFromTsaiAngles(after.rx, after.ry, after.rz) *
      rotationFromTsaiAngles(before.rx, before.ry, before.rz).transpose();
  EXPECT_NEAR(Eigen::AngleAxisd(knocked).angle() * 180 / std::numbers::pi, 1.0, 0.1);
  EXPECT_EQ(after.focal, before.focal);
  EXPECT_NEAR((TsaiCamera(after).pose().centre() - TsaiCamera(before).pose().centre()).norm(), 0,
              1e-6);
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.waitExit(testing::eventually(5s)), 0) << daemon.err();
}

// The light's status (lighting_status_t, docs/lighting.md) through `occmap status`: camera c1's
// background is a black picture, which no change of light explains, so c1 is degraded (left out
// of the maps) and said to be; the others' light is as when their backgrounds were taken.
TEST(OccmapStatus, SaysWhichCameraNoLightExplainsAndTheOthersLight) {
  if (const std::string& problem = testing::enterPrivateNetwork(); !problem.empty()) {
    GTEST_SKIP() << problem;
  }
  TemporaryFolder folder;
  std::string error;
  ASSERT_TRUE(writeGreyPng(folder / "black.png", Image(640, 480, 0), error)) << error;
  std::string text = testing::simRoomConfig("udpm://239.255.76.67:7667?ttl=0");
  const std::string c1 = "{name: c1, source: \"sim://room/c1\"}";
  ASSERT_NE(text.find(c1), std::string::npos);
  text.replace(text.find(c1), c1.size(),
               "{name: c1, source: \"sim://room/c1\", background: black.png}");
  const auto config = folder.write("room.yaml", text);
  ChildProcess daemon({kOccmapd, "--config", config.string()}, folder / "occmapd");
  ASSERT_TRUE(waitForError(daemon, "ready:", testing::eventually(30s))) << daemon.err();
  ASSERT_TRUE(waitForError(daemon, "camera c1: no change of light explains its view",
                           testing::eventually(5s)))
      << daemon.err();

  auto result = runCommand({kOccmap, "status", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("\"lighting_camera_name\":[\"c0\",\"c1\",\"c2\",\"c3\"]"),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("\"lighting_explained\":[true,false,true,true]"), std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("\"lighting_adapt\":[true,true,true,true]"), std::string::npos)
      << result.out;
  // A black picture is no background's view moved (view_status_t).
  EXPECT_NE(
      result.out.find(
          "\"view_name\":[\"as calibrated\",\"unexplained\",\"as calibrated\",\"as calibrated\"]"),
      std::string::npos)
      << result.out;
  result = runCommand({kOccmap, "status"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("c1: DEGRADED, no change of light explains its view"),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("it is not its background moved"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("c0: light 1.00 x the background's"), std::string::npos) << result.out;
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.waitExit(testing::eventually(5s)), 0) << daemon.err();
}

}  // namespace
}  // namespace occmap
