// The light's model through `occmap fuse` as a user runs it (docs/lighting.md): changing light,
// light in part of the room, a knocked camera re-posed, a day in the room. Each runs `occmap fuse`
// in a process of its own and starts no thread itself (SINGLE_THREADED): its maps come from the
// same code in every test, and the only threads of `occmap fuse` (its table build) are checked
// under ThreadSanitizer by occmap_cli_test's fuse tests, so these stay out of the TSan phase,
// where they would take over a minute.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "capture/image_file.h"
#include "command_runner.h"
#include "sim_room_config.h"
#include "temporary_folder.h"
#include "timing.h"

namespace occmap {
namespace {

using testing::readWhole;
using testing::runCommand;
using testing::TemporaryFolder;
using testing::writeText;

const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";

// `occmap fuse` of the config `text` (simulated cameras) for `frames` frame sets, written to
// folder/name: checks that it ran and found every object in every map, and returns the share of the
// cells a camera sees clearly that are free, in %, as it prints it (-1 when it does not).
double fuseSeenFree(const std::filesystem::path& folder, const std::string& name,
                    const std::string& text, int frames) {
  writeText(folder / name, text);
  const auto result =
      runCommand({kOccmap, "fuse", "--config", (folder / name).string(), "--out",
                  (folder / (name + "-maps")).string(), "--frames", std::to_string(frames)});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  const std::string found = "objects found " + std::to_string(5 * frames) + " of " +
                            std::to_string(5 * frames) + " (100.00 %)";
  EXPECT_NE(result.out.find(found), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("100.00 % of cells under objects not free"), std::string::npos)
      << result.out;
  const std::string label = "% of cells a camera sees clearly are free";
  const std::size_t at = result.out.find(label);
  EXPECT_NE(at, std::string::npos) << result.out;
  const std::size_t start = result.out.rfind("; ", at);
  return at == std::string::npos ? -1.0 : std::atof(result.out.c_str() + start + 2);
}

// The config `text` with `lighting` (a flow map) set for every camera under its fusion key, or ""
// when the text has no fusion key to put it under.
std::string withLighting(const std::string& text, const std::string& lighting) {
  const std::string fusion = "fusion:\n";
  const std::size_t at = text.find(fusion);
  if (at == std::string::npos) return "";
  std::string out = text;
  out.insert(at + fusion.size(), "  lighting: " + lighting + "\n");
  return out;
}

// The number in `out` that follows the last `before` ahead of the first `label` (as in "...; 98.6
// % of cells ...": before "; ", label " % of cells"), or -1 when `label` is not there.
double numberAhead(const std::string& out, const std::string& label, const std::string& before) {
  const std::size_t at = out.find(label);
  if (at == std::string::npos) return -1.0;
  const std::size_t start = out.rfind(before, at);
  return start == std::string::npos ? -1.0 : std::atof(out.c_str() + start + before.size());
}

// That `occmap fuse`'s output `out` says camera c1 was left out of `left_out` frames and found
// moved at map `moved_at`, turned by about a degree, re-posed at map `reposed_at` by about as much,
// and that no other camera was ever left out.
void expectOnlyC1KnockedAndRePosed(const std::string& out, int left_out, int moved_at,
                                   int reposed_at) {
  const std::string moved = "camera c1: " + std::to_string(left_out) +
                            " frames left out, no change of light explaining them; its view moved "
                            "at map " +
                            std::to_string(moved_at) + ": turned ";
  const std::size_t at = out.find(moved);
  ASSERT_NE(at, std::string::npos) << out;
  EXPECT_NEAR(std::atof(out.c_str() + at + moved.size()), 1.0, 0.1) << out;
  const std::string reposed = "; re-posed at map " + std::to_string(reposed_at) + " (turned ";
  const std::size_t reposed_at_text = out.find(reposed);
  ASSERT_NE(reposed_at_text, std::string::npos) << out;
  EXPECT_NEAR(std::atof(out.c_str() + reposed_at_text + reposed.size()), 1.0, 0.05) << out;
  for (const char* steady : {"camera c0:", "camera c2:", "camera c3:"}) {
    EXPECT_EQ(out.find(steady), std::string::npos) << out;
  }
}

// The simulated room while its light steps and ramps (sim://room-light: 1, 0.6, 0.6 -> 1.5, 1.5
// in four seconds) against backgrounds taken at 1: with the light's model (the default) the map
// is what it is in constant light; with `lighting: {adapt: false}` (the paper's fixed background)
// most of the floor reads occupied. Every object is found either way.
TEST(OccmapFuse, TheLightsModelKeepsTheFloorFreeWhileTheLightChanges) {
  TemporaryFolder folder;
  const std::string text = testing::inCoarseMap(
      testing::inScene(readWhole(OCCMAP_SOURCE_DIR "/examples/sim-room.yaml"), "room-light"));
  const std::string fixed_text = withLighting(text, "{adapt: false}");
  ASSERT_NE(fixed_text, "") << "examples/sim-room.yaml changed: not its map, or no fusion key";
  // A whole cycle of the light with the model; without it, its first two seconds (1, then 0.6)
  // are enough to show what a fixed background does.
  const double adapted = fuseSeenFree(folder.path(), "adapted.yaml", text, 120);
  const double fixed = fuseSeenFree(folder.path(), "fixed.yaml", fixed_text, 60);
  std::printf(
      "cells a camera sees clearly that are free: %.2f %% with the light's model, %.2f %% "
      "with a fixed background\n",
      adapted, fixed);
  EXPECT_GE(adapted, 98.0);
  EXPECT_LT(fixed, 75.0) << "the light's step should defeat a fixed background";
}

// Light in parts of the room (sim://room-lamps: a patch of sun crossing the floor, a lamp's pool
// from 1 s, a shade from 2 s): the local light keeps more of the lit floor free than the gain
// alone, and every object is still found in every map.
TEST(OccmapFuse, TheLocalLightKeepsMoreOfTheLitFloorFreeAndFindsEveryObject) {
  TemporaryFolder folder;
  const std::string text = testing::inCoarseMap(
      testing::inScene(readWhole(OCCMAP_SOURCE_DIR "/examples/sim-room.yaml"), "room-lamps"));
  const std::string gain_text = withLighting(text, "{local: false}");
  ASSERT_NE(gain_text, "") << "examples/sim-room.yaml changed: not its map, or no fusion key";
  constexpr int kFrames = 75;  // 2.5 s: the sun all along, the lamp for 1.5 s, the shade for 0.5 s
  const double local = fuseSeenFree(folder.path(), "local.yaml", text, kFrames);
  const double gain_alone = fuseSeenFree(folder.path(), "gain.yaml", gain_text, kFrames);
  std::printf(
      "cells a camera sees clearly that are free: %.2f %% with the local light, %.2f %% with the "
      "gain alone\n",
      local, gain_alone);
  EXPECT_GE(local, gain_alone + 2.0);
}

// The config `text` with every simulated camera at `fps` frame sets a second of scene time (a
// camera entry is one flow map: `, fps: F` goes before its closing brace).
std::string atFps(std::string text, const std::string& fps) {
  for (std::size_t at = text.find("\"sim://"); at != std::string::npos;
       at = text.find("\"sim://", at + 1)) {
    const std::size_t end = text.find('}', at);
    if (end == std::string::npos) return "";
    text.insert(end, ", fps: " + fps);
  }
  return text;
}

// The light stepped and ramped between half and double (sim://room-gains: 1, a step to 0.5, a
// step to 2, a ramp down to 0.5 over 3 s, a ramp up to 2, a step back to 1; 5 frame sets a
// second, 0.3 m columns and floor points): every map more than a second after a step, ramps and
// all, agrees with the map of the room in constant light on at least 99 % of the cells that map
// sees, and no object is freed in any map, not even at a step's own frame. (The target as
// it stands; the two rules that hold it in a light that clips, each enough for this scene alone,
// are held by lighting_model_test's ACrowdInALightThatClipsTheFloor... tests, which fail without
// them.)
TEST(OccmapFuse, FromHalfToDoubleTheLightsMapsAreTheConstantLightsASecondAfterEachStep) {
  TemporaryFolder folder;
  const std::string room =
      testing::inCoarseMap(readWhole(OCCMAP_SOURCE_DIR "/examples/sim-room.yaml"));
  ASSERT_NE(room, "") << "examples/sim-room.yaml changed: not the map inCoarseMap knows";
  const std::string columns = "column_height_m: 0.3";
  const std::size_t columns_at = room.find(columns);
  ASSERT_NE(columns_at, std::string::npos) << "examples/sim-room.yaml has no 0.3 m columns";
  std::string floor = room;
  floor.replace(columns_at, columns.size(), "column_height_m: 0");
  constexpr int kFrames = 100;  // the scene's 20 s
  for (const auto& [mode, text] : {std::pair{"columns", room}, std::pair{"floor", floor}}) {
    // Under a sanitizer the columns alone (the day's test below runs floor points there): both
    // put the same light's model through the same code, and what ASan watches is that code, not
    // the carve table's (occmap_cli_test fuses both under it). With the day's: the binary's CPU
    // under ASan 49 s -> 34 s.
    if (testing::kSanitized && std::string(mode) == "floor") continue;
    SCOPED_TRACE(mode);
    const std::string name = mode;
    folder.write(name + "-room.yaml", atFps(text, "5"));
    folder.write(name + "-gains.yaml", atFps(testing::inScene(text, "room-gains"), "5"));
    const auto fuse = [&](const std::string& config) {
      return runCommand({kOccmap, "fuse", "--config", (folder / (config + ".yaml")).string(),
                         "--out", (folder / config).string()});
    };
    const auto gains = fuse(name + "-gains");
    ASSERT_EQ(gains.exit_code, 0) << gains.err;
    ASSERT_EQ(fuse(name + "-room").exit_code, 0);
    EXPECT_NE(gains.out.find("wrote 100 maps"), std::string::npos) << gains.out;
    EXPECT_NE(gains.out.find("objects found 500 of 500 (100.00 %)"), std::string::npos)
        << gains.out;
    if (name == "columns") {
      EXPECT_NE(gains.out.find("100.00 % of cells under objects not free"), std::string::npos)
          << gains.out;
    }
    EXPECT_EQ(gains.out.find("frames left out"), std::string::npos) << gains.out;
    double worst = 1.0;
    int worst_map = -1;
    for (int n = 0; n < kFrames; ++n) {
      const double t = n / 5.0;
      const bool settled =
          !(t >= 2.0 && t < 3.0) && !(t >= 4.0 && t < 5.0) && !(t >= 16.0 && t < 17.0);
      if (!settled) continue;
      char map[32];
      std::snprintf(map, sizeof map, "map_%06d.png", n);
      std::string error;
      const auto lit = readGreyImage(folder / (name + "-gains") / map, error);
      ASSERT_TRUE(lit) << error;
      const auto constant = readGreyImage(folder / (name + "-room") / map, error);
      ASSERT_TRUE(constant) << error;
      std::size_t seen = 0;
      std::size_t same = 0;
      const std::size_t cells = static_cast<std::size_t>(lit->width()) * lit->height();
      for (std::size_t i = 0; i < cells; ++i) {
        if (constant->data()[i] == 128) continue;  // unseen in constant light
        ++seen;
        same += lit->data()[i] == constant->data()[i] ? 1 : 0;
      }
      ASSERT_GT(seen, cells / 3);
      const double agreement = static_cast<double>(same) / static_cast<double>(seen);
      if (worst_map < 0 || agreement < worst) {
        worst = agreement;
        worst_map = n;
      }
    }
    std::printf(
        "  %s: the worst map a second after a step agrees on %.2f %% of the seen cells (map %d)\n",
        mode, 100 * worst, worst_map);
    EXPECT_GE(worst, 0.99) << "map " << worst_map;
  }
}

// A camera knocked on its mount (sim://room-knock: c1 turned by 1 degree at 1 s; 10 frame sets a
// second, so frame 10): from that frame on its view is no change of light, so its frames are left
// out (its cells counted by the others alone, every object still found) and the run says it
// moved, by about a degree; its view still for 2 s, it is re-posed (frame 30) and back in the
// maps, which are then the maps of
// the room where nobody knocked it but for a thin strip along its view's border (that its old
// background never saw) and a few cells of its blurred background's edges.
TEST(OccmapFuse, AKnockedCameraIsLeftOutThenRePosedAndItsMapsAreTheUnknockedRoomsAgain) {
  TemporaryFolder folder;
  const std::string room =
      testing::inCoarseMap(readWhole(OCCMAP_SOURCE_DIR "/examples/sim-room.yaml"));
  ASSERT_NE(room, "") << "examples/sim-room.yaml changed: not the map inCoarseMap knows";
  folder.write("knock.yaml", atFps(testing::inScene(room, "room-knock"), "10"));
  folder.write("room.yaml", atFps(room, "10"));
  constexpr int kFrames = 40;
  const auto fuse = [&](const std::string& name) {
    return runCommand({kOccmap, "fuse", "--config", (folder / (name + ".yaml")).string(), "--out",
                       (folder / name).string(), "--frames", std::to_string(kFrames)});
  };
  const auto result = fuse("knock");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  ASSERT_EQ(fuse("room").exit_code, 0);
  EXPECT_NE(result.out.find("objects found 200 of 200 (100.00 %)"), std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("100.00 % of cells under objects not free"), std::string::npos)
      << result.out;
  expectOnlyC1KnockedAndRePosed(result.out, 21, 10, 30);
  // The maps once it is back, against the unknocked room's.
  for (int n = 31; n < kFrames; n += 2) {
    char name[32];
    std::snprintf(name, sizeof name, "map_%06d.png", n);
    std::string error;
    const auto knocked = readGreyImage(folder / "knock" / name, error);
    ASSERT_TRUE(knocked) << error;
    const auto unknocked = readGreyImage(folder / "room" / name, error);
    ASSERT_TRUE(unknocked) << error;
    std::size_t same = 0;
    const std::size_t cells = static_cast<std::size_t>(knocked->width()) * knocked->height();
    for (std::size_t i = 0; i < cells; ++i) same += knocked->data()[i] == unknocked->data()[i];
    EXPECT_GE(static_cast<double>(same) / static_cast<double>(cells), 0.99) << name;
  }
}

// Ten simulated minutes of a day in the room (sim://room-day: the light's +-50 % cycle, the
// camera's exposure steps, a lamp, a patch of sun, shadows at people's feet, a grey box only 26
// to 60 grey levels below the floor put down and left, a person standing still for four minutes,
// c1 knocked by 1 degree at 450 s), a frame set every 5 s on the 4 cm map, with 0.3 m columns (the
// example's) and with floor points (sim_truth_test's measure, which the 98 % is of): every
// object is found in every map (the box and the still person never freed), the knocked camera is
// left out from the knock's frame and re-posed at the next (its view still for at least 2 s), and
// no other camera is ever left out. The floor kept free is reported (docs/lighting.md, "A day in
// the room": short of 98 % at every map a second after an event, where the sun clips the sensor
// and where shadows lie at people's feet on flat planks) and held where it is now.
TEST(OccmapFuse, ADayInTheRoomFindsEveryObjectAndRePosesTheKnockedCamera) {
  TemporaryFolder folder;
  std::string text = testing::inCoarseMap(
      testing::inScene(readWhole(OCCMAP_SOURCE_DIR "/examples/sim-room.yaml"), "room-day"));
  ASSERT_NE(text, "") << "examples/sim-room.yaml changed: not the map inCoarseMap knows";
  text = atFps(text, "0.2");
  ASSERT_NE(text, "");
  const std::string columns = "column_height_m: 0.3";
  const std::size_t columns_at = text.find(columns);
  ASSERT_NE(columns_at, std::string::npos) << "examples/sim-room.yaml has no 0.3 m columns";
  std::string floor_text = text;
  floor_text.replace(columns_at, columns.size(), "column_height_m: 0");
  struct Run {
    const char* name;
    const std::string* text;
    double least_inside_kept;  // of the cells under objects, not free
    double least_free;         // of the clearly seen cells, all maps
    double least_worst_free;   // at the worst map a second after every event
  };
  // With floor points, the box (86 grey levels) is within the threshold of the planks' seams (102)
  // and of the darkest planks' grain, so some of its cells are cleared, as by a fixed background in
  // constant light; it is still found in every map.
  for (const Run& run :
       {Run{"columns", &text, 100.0, 94.5, 91.0}, Run{"floor", &floor_text, 95.0, 98.3, 96.5}}) {
    // Under a sanitizer the floor points alone (the columns are the test above's there).
    if (testing::kSanitized && std::string(run.name) == "columns") continue;
    SCOPED_TRACE(run.name);
    const std::string name = std::string(run.name) + ".yaml";
    folder.write(name, *run.text);
    const auto result = runCommand({kOccmap, "fuse", "--config", (folder / name).string(), "--out",
                                    (folder / (std::string(run.name) + "-maps")).string()});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    std::printf("%s\n%s", run.name, result.out.c_str());
    EXPECT_NE(result.out.find("wrote 120 maps"), std::string::npos) << result.out;
    EXPECT_GE(numberAhead(result.out, " % of cells under objects not free", ": "),
              run.least_inside_kept)
        << result.out;
    EXPECT_NE(result.out.find("objects found 756 of 756 (100.00 %)"), std::string::npos)
        << result.out;
    expectOnlyC1KnockedAndRePosed(result.out, 2, 90, 91);
    EXPECT_GE(numberAhead(result.out, "% of cells a camera sees clearly are free", "; "),
              run.least_free)
        << result.out;
    EXPECT_GE(numberAhead(result.out, "clearly free", " has "), run.least_worst_free) << result.out;
  }
}

}  // namespace
}  // namespace occmap
