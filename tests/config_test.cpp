// The config file as users write it: a valid one reads into the struct with paths taken from the
// file's folder and defaults filled in; every mistake is refused with a message that names the
// file, the line and the key, so that the user can go there and fix it.
#include "config/config.h"

#include <atomic>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "config/input_error.h"
#include "temporary_folder.h"

namespace occmap {
namespace {

namespace fs = std::filesystem;

using testing::TemporaryFolder;

// The InputError that loading `text` as a config file throws; fails the test if none is thrown.
InputError errorFor(const TemporaryFolder& folder, const std::string& text) {
  const fs::path file = folder.write("occmap.yaml", text);
  try {
    loadConfig(file);
  } catch (const InputError& error) {
    return error;
  }
  ADD_FAILURE() << "this config was accepted but should be refused:\n" << text;
  return InputError("", 0, "", "");
}

// Checks that the error points at the file, line and field, and says `what`.
void expectError(const std::string& text, int line, const std::string& field,
                 const std::string& what) {
  const TemporaryFolder folder;
  const InputError error = errorFor(folder, text);
  const std::string message = error.what();
  const std::string file = (folder.path() / "occmap.yaml").string();
  EXPECT_EQ(error.file(), file) << message;
  EXPECT_EQ(error.line(), line) << message;
  EXPECT_EQ(error.field(), field) << message;
  const std::string location = line > 0 ? file + ":" + std::to_string(line) + ": " : file + ": ";
  EXPECT_EQ(message.rfind(location, 0), 0u) << "message should start with " << location << "\n"
                                            << message;
  EXPECT_NE(message.find(field), std::string::npos) << message;
  EXPECT_NE(message.find(what), std::string::npos) << "message should say \"" << what << "\":\n"
                                                   << message;
}

// A valid config of one sim camera; tests change one line at a time. Lines are numbered from 1.
const std::string kMinimal =
    "map: {}\n"                  // 1
    "cameras:\n"                 // 2
    "  - name: c0\n"             // 3
    "    source: sim://room\n";  // 4

TEST(Config, FullConfigReadsIntoTheStruct) {
  const TemporaryFolder folder;
  const std::string text =
      "# occmapd config\n"                                                             // 1
      "map:       {origin_m: [-0.25, -1.5], cell_size_m: 0.05, width: 300,\n"          // 2
      "            height: 200}\n"                                                     // 3
      "fusion:    {threshold: 30, column_height_m: 0.5, max_wait_ms: 40}\n"            // 4
      "transport: {lcm_url: \"udpm://239.255.76.67:7667?ttl=1\", map_channel: MAP,\n"  // 5
      "            status_channel: STATUS, encoding: raw}\n"                           // 6
      "cameras:\n"                                                                     // 7
      "  - name: c0\n"                                                                 // 8
      "    source: \"aravis://Basler-21945843\"\n"                                     // 9
      "    calibration: calib/c0.xml\n"                                                // 10
      "    calibration_units: cm\n"                                                    // 11
      "    image_region: [8, 4.5, 704, 568]\n"                                         // 12
      "    background: ./bg/../bg/c0.png\n"                                            // 13
      "    floor_mask: /srv/masks/c0.png\n"                                            // 14
      "    threshold: 25\n"                                                            // 15
      "    fps: 12.5\n"                                                                // 16
      "    settings: {ExposureTime: 8000, Gain: 0, PixelFormat: Mono8, Gamma: 0.5}\n"  // 17
      "  - name: c1.left-2\n"                                                          // 18
      "    source: files:///data/c1/*.png\n"                                           // 19
      "    calibration: ../shared/c1.yml\n"                                            // 20
      "    background: bg/c1.png\n"                                                    // 21
      "  - name: sim_0\n"                                                              // 22
      "    source: sim://room/c0\n";                                                   // 23
  const fs::path file = folder.write("etc/occmap.yaml", text);
  const Config config = loadConfig(file);
  const fs::path base = folder.path() / "etc";

  EXPECT_EQ(config.file, file);
  EXPECT_EQ(config.map.origin_x_m, -0.25);
  EXPECT_EQ(config.map.origin_y_m, -1.5);
  EXPECT_EQ(config.map.cell_size_m, 0.05);
  EXPECT_EQ(config.map.width, 300);
  EXPECT_EQ(config.map.height, 200);
  EXPECT_EQ(config.fusion.threshold, 30);
  EXPECT_EQ(config.fusion.column_height_m, 0.5);
  EXPECT_EQ(config.fusion.max_wait_ms, 40);
  EXPECT_EQ(config.transport.lcm_url, "udpm://239.255.76.67:7667?ttl=1");
  EXPECT_EQ(config.transport.map_channel, "MAP");
  EXPECT_EQ(config.transport.status_channel, "STATUS");
  EXPECT_EQ(config.transport.encoding, "raw");
  ASSERT_EQ(config.cameras.size(), 3u);

  const CameraConfig& c0 = config.cameras[0];
  EXPECT_EQ(c0.name, "c0");
  EXPECT_EQ(c0.source, "aravis://Basler-21945843");
  EXPECT_EQ(c0.calibration, base / "calib/c0.xml");
  EXPECT_EQ(c0.calibration_units, LengthUnit::kCentimetre);
  ASSERT_TRUE(c0.image_region);
  EXPECT_EQ(c0.image_region->x0, 8);
  EXPECT_EQ(c0.image_region->y0, 4.5);
  EXPECT_EQ(c0.image_region->width, 704);
  EXPECT_EQ(c0.image_region->height, 568);
  EXPECT_EQ(c0.background, base / "bg/c0.png") << "relative paths are normalised";
  EXPECT_EQ(c0.floor_mask, fs::path("/srv/masks/c0.png")) << "absolute paths stay";
  EXPECT_EQ(c0.threshold, 25);
  EXPECT_EQ(c0.effectiveThreshold(config.fusion), 25);
  EXPECT_EQ(c0.fps, 12.5);
  const std::vector<std::pair<std::string, std::string>> settings = {
      {"ExposureTime", "8000"}, {"Gain", "0"}, {"PixelFormat", "Mono8"}, {"Gamma", "0.5"}};
  EXPECT_EQ(c0.settings, settings) << "settings keep their text and file order";
  EXPECT_EQ(c0.line, 8);
  EXPECT_EQ(c0.lineOf("calibration"), 10);
  EXPECT_EQ(c0.lineOf("floor_mask"), 14);
  EXPECT_EQ(c0.key_lines.size(), 10u);

  const CameraConfig& c1 = config.cameras[1];
  EXPECT_EQ(c1.name, "c1.left-2");
  EXPECT_EQ(c1.source, "files:///data/c1/*.png");
  EXPECT_EQ(c1.calibration, folder.path() / "shared/c1.yml");
  EXPECT_EQ(c1.background, base / "bg/c1.png");
  EXPECT_FALSE(c1.calibration_units);
  EXPECT_FALSE(c1.image_region);
  EXPECT_FALSE(c1.floor_mask);
  EXPECT_FALSE(c1.threshold);
  EXPECT_EQ(c1.effectiveThreshold(config.fusion), 30) << "no override: the fusion threshold";
  EXPECT_FALSE(c1.fps);
  EXPECT_TRUE(c1.settings.empty());
  EXPECT_EQ(c1.line, 18);
  EXPECT_EQ(c1.lineOf("threshold"), 18) << "a key not given points at the camera's entry";

  const CameraConfig& sim = config.cameras[2];
  EXPECT_EQ(sim.name, "sim_0");
  EXPECT_FALSE(sim.calibration) << "a sim camera needs no calibration";
  EXPECT_FALSE(sim.background);
}

TEST(Config, DefaultsAreTheDesignsDefaults) {
  const Config config = parseConfig(kMinimal, "/etc/occmap/occmap.yaml");
  const MapGeometry map;
  EXPECT_EQ(config.map.origin_x_m, -0.5);
  EXPECT_EQ(config.map.origin_y_m, -1.5);
  EXPECT_EQ(config.map.cell_size_m, 0.02);
  EXPECT_EQ(config.map.width, 512);
  EXPECT_EQ(config.map.height, 512);
  EXPECT_EQ(config.fusion.threshold, 20);
  EXPECT_EQ(config.fusion.column_height_m, 0.3);
  EXPECT_EQ(config.fusion.max_wait_ms, 50);
  EXPECT_EQ(config.transport.lcm_url, "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_EQ(config.transport.map_channel, "OCCMAP_MAP");
  EXPECT_EQ(config.transport.status_channel, "OCCMAP_STATUS");
  EXPECT_EQ(config.transport.encoding, "zstd");
  ASSERT_EQ(config.cameras.size(), 1u);
  EXPECT_EQ(config.cameras[0].effectiveThreshold(config.fusion), 20);
  const LightingSettings lighting = config.cameras[0].effectiveLighting(config.fusion);
  EXPECT_TRUE(lighting.adapt) << "the light's model is on by default";
  EXPECT_EQ(lighting.drift_frames, 256);
  EXPECT_EQ(lighting.min_agreement, 0.7);
  EXPECT_EQ(lighting.min_agreement_in_place, 0.4);
  EXPECT_EQ(lighting.agreement_grey_levels, 8);
  EXPECT_TRUE(lighting.local) << "the local light is on by default";
}

// fusion.lighting for every camera; a camera's own lighting keys replace those they name.
TEST(Config, LightingIsSetForAllAndOverriddenPerCamera) {
  const Config config = parseConfig(
      "map: {}\n"
      "fusion:\n"
      "  lighting: {drift_frames: 900, min_agreement: 0.6}\n"
      "cameras:\n"
      "  - {name: c0, source: sim://room/c0}\n"
      "  - {name: c1, source: sim://room/c1, lighting: {adapt: false}}\n"
      "  - {name: c2, source: sim://room/c2, lighting: {drift_frames: 30, "
      "agreement_grey_levels: 12, local: false, min_agreement_in_place: 0.25}}\n",
      "/etc/occmap/occmap.yaml");
  const LightingSettings c0 = config.cameras[0].effectiveLighting(config.fusion);
  EXPECT_TRUE(c0.adapt);
  EXPECT_EQ(c0.drift_frames, 900);
  EXPECT_EQ(c0.min_agreement, 0.6);
  EXPECT_EQ(c0.agreement_grey_levels, 8);
  const LightingSettings c1 = config.cameras[1].effectiveLighting(config.fusion);
  EXPECT_FALSE(c1.adapt);
  EXPECT_EQ(c1.drift_frames, 900);
  const LightingSettings c2 = config.cameras[2].effectiveLighting(config.fusion);
  EXPECT_TRUE(c2.adapt);
  EXPECT_EQ(c2.drift_frames, 30);
  EXPECT_EQ(c2.min_agreement, 0.6);
  EXPECT_EQ(c2.agreement_grey_levels, 12);
  EXPECT_EQ(c2.min_agreement_in_place, 0.25);
  EXPECT_EQ(c0.min_agreement_in_place, 0.4);
  EXPECT_FALSE(c2.local);
  EXPECT_TRUE(c0.local);
}

TEST(Config, RelativePathsAreTakenFromTheConfigFilesFolder) {
  const Config config = parseConfig(
      "map: {}\ncameras:\n  - {name: a, source: v4l2:///dev/video0, calibration: c/a.xml,\n"
      "     background: ../bg/a.png, floor_mask: /abs/./m.png}\n",
      "/etc/occmap/occmap.yaml");
  EXPECT_EQ(config.cameras[0].calibration, fs::path("/etc/occmap/c/a.xml"));
  EXPECT_EQ(config.cameras[0].background, fs::path("/etc/bg/a.png"));
  EXPECT_EQ(config.cameras[0].floor_mask, fs::path("/abs/m.png"));
}

TEST(ConfigErrors, YamlSyntaxErrorNamesTheParsersLine) {
  const TemporaryFolder folder;
  const InputError error = errorFor(folder,
                                    "map: {}\n"
                                    "cameras:\n"
                                    "  - name: c0\n"
                                    "    source: [sim://room\n"
                                    "  - name: c1\n");
  EXPECT_EQ(error.file(), (folder.path() / "occmap.yaml").string());
  EXPECT_GE(error.line(), 4) << error.what();
  EXPECT_LE(error.line(), 6) << error.what();
  EXPECT_NE(std::string(error.what()).find("YAML"), std::string::npos) << error.what();

  expectError("map: {}\ncameras:\n  - name: c0\n   source: sim://room\n", 4, "", "not valid YAML");
}

TEST(ConfigErrors, UnknownKeysAreNamedWithTheAllowedOnes) {
  expectError("map: {}\nmaps: {}\n" + kMinimal.substr(8), 2, "maps", "unknown key \"maps\"");
  expectError("map: {}\ncamera: []\n", 2, "camera", "did you mean cameras?");
  expectError("map:\n  width: 100\n  cellsize_m: 0.1\n" + kMinimal.substr(8), 3, "map.cellsize_m",
              "allowed here: origin_m, cell_size_m, width, height");
  expectError(kMinimal + "    treshold: 20\n", 5, "cameras[0].treshold", "did you mean threshold?");
  expectError(kMinimal + "fusion: {threshold: 20, wait_ms: 5}\n", 5, "fusion.wait_ms",
              "unknown key");
  expectError(kMinimal + "transport:\n  url: x\n", 6, "transport.url", "lcm_url");
}

// footprints: (docs/detection.md): read as written, each key checked.
TEST(Config, FootprintsAreReadAndChecked) {
  const Config defaults = parseConfig(kMinimal, "/etc/occmap/occmap.yaml");
  EXPECT_EQ(defaults.footprints.min_cameras, 2);
  EXPECT_DOUBLE_EQ(defaults.footprints.box_height_m, 1.75);
  EXPECT_TRUE(defaults.footprints.enabled) << "occmapd finds people unless told not to";
  EXPECT_DOUBLE_EQ(defaults.footprints.object_height_m, 0.5);
  const Config config = parseConfig(
      kMinimal +
          "footprints: {box_width_m: 0.6, box_height_m: 1.2, step_m: 0.05, min_support: "
          "0.3, min_fresh: 0.15, min_cameras: 3, min_separation_m: 0.4, enabled: false, "
          "object_height_m: 0, object_min_support: 0.5, object_min_fresh: 0.25, "
          "settle_reach_m: 0.3, hidden_floor_unseen: true, two_view_min_own: 0.3, "
          "box_strips: 2, hold_hidden: false, hold_own_factor: 2}\n",
      "/etc/occmap/occmap.yaml");
  EXPECT_FALSE(config.footprints.enabled);
  EXPECT_DOUBLE_EQ(config.footprints.object_height_m, 0.0);
  EXPECT_DOUBLE_EQ(config.footprints.object_min_support, 0.5);
  EXPECT_DOUBLE_EQ(config.footprints.object_min_fresh, 0.25);
  EXPECT_DOUBLE_EQ(config.footprints.box_width_m, 0.6);
  EXPECT_DOUBLE_EQ(config.footprints.box_height_m, 1.2);
  EXPECT_DOUBLE_EQ(config.footprints.step_m, 0.05);
  EXPECT_DOUBLE_EQ(config.footprints.min_support, 0.3);
  EXPECT_DOUBLE_EQ(config.footprints.min_fresh, 0.15);
  EXPECT_EQ(config.footprints.min_cameras, 3);
  EXPECT_DOUBLE_EQ(config.footprints.min_separation_m, 0.4);
  EXPECT_DOUBLE_EQ(config.footprints.settle_reach_m, 0.3);
  EXPECT_DOUBLE_EQ(defaults.footprints.settle_reach_m, 0.5);
  EXPECT_DOUBLE_EQ(config.footprints.two_view_min_own, 0.3);
  EXPECT_EQ(config.footprints.box_strips, 2);
  EXPECT_EQ(defaults.footprints.box_strips, 3) << "boxes that follow the board";
  expectError(kMinimal + "footprints: {box_strips: 0}\n", 5, "footprints.box_strips", "");
  expectError(kMinimal + "footprints: {box_strips: 1.5}\n", 5, "footprints.box_strips", "");
  EXPECT_DOUBLE_EQ(defaults.footprints.two_view_min_own, 0.4) << "twice min_support";
  expectError(kMinimal + "footprints: {two_view_min_own: 1.2}\n", 5, "footprints.two_view_min_own",
              "must be <= 1");
  EXPECT_TRUE(config.footprints.hidden_floor_unseen);
  EXPECT_FALSE(defaults.footprints.hidden_floor_unseen) << "the map's cells alone, unless asked";
  expectError(kMinimal + "footprints: {hidden_floor_unseen: 2}\n", 5,
              "footprints.hidden_floor_unseen", "");
  EXPECT_FALSE(config.footprints.hold_hidden);
  EXPECT_TRUE(defaults.footprints.hold_hidden) << "someone followed and hidden is held";
  EXPECT_DOUBLE_EQ(config.footprints.hold_own_factor, 2.0);
  EXPECT_DOUBLE_EQ(defaults.footprints.hold_own_factor, 1.5);
  expectError(kMinimal + "footprints: {hold_own_factor: 0}\n", 5, "footprints.hold_own_factor",
              "must be > 0");
  expectError(kMinimal + "footprints: {min_support: 1.5}\n", 5, "footprints.min_support",
              "must be <= 1");
  expectError(kMinimal + "footprints: {min_cameras: 0}\n", 5, "footprints.min_cameras", "");
  expectError(kMinimal + "footprints: {object_height_m: -1}\n", 5, "footprints.object_height_m",
              "");
  expectError(kMinimal + "footprints: {enabled: maybe}\n", 5, "footprints.enabled", "");
  expectError(kMinimal + "footprints: {settle_reach_m: -0.1}\n", 5, "footprints.settle_reach_m",
              "");
  expectError(kMinimal + "footprints: {box_heigth_m: 2}\n", 5, "footprints.box_heigth_m",
              "did you mean box_height_m?");
}

// zones: after the map wherever they stand, each on it, named once.
TEST(Config, ZonesAreReadAndChecked) {
  const Config config = parseConfig(
      "zones:\n  - {name: robot-cell, polygon_m: [[0, 0], [1, 0], [1, 1]]}\n" + kMinimal,
      "/etc/occmap/occmap.yaml");
  ASSERT_EQ(config.zones.size(), 1u);
  EXPECT_EQ(config.zones[0].name, "robot-cell");
  EXPECT_EQ(config.zones[0].polygon_m.size(), 3u);
  expectError(kMinimal + "zones:\n  - {name: a, polygon_m: [[0, 0], [1, 0]]}\n", 6,
              "zones[0].polygon_m", "has 2 corners");
  expectError(kMinimal + "zones:\n  - {name: a, polygon_m: [[90, 90], [91, 90], [91, 91]]}\n", 6,
              "zones[0].polygon_m", "holds no cell centre of the map");
  expectError(kMinimal +
                  "zones:\n  - {name: a, polygon_m: [[0, 0], [1, 0], [1, 1]]}\n"
                  "  - {name: a, polygon_m: [[0, 0], [1, 0], [1, 1]]}\n",
              7, "zones[1].name", "is used twice");
  expectError(kMinimal + "zones:\n  - {polygon_m: [[0, 0], [1, 0], [1, 1]]}\n", 6, "zones[0].name",
              "is missing");
}

TEST(ConfigErrors, WrongTypesNameTheExpectedType) {
  expectError("map: {width: 512.5}\n" + kMinimal.substr(8), 1, "map.width", "whole number");
  expectError("map:\n  height: tall\n" + kMinimal.substr(8), 2, "map.height", "whole number");
  expectError("map: [1, 2]\n" + kMinimal.substr(8), 1, "map", "must be a mapping");
  expectError("map:\n  origin_m: 0\n" + kMinimal.substr(8), 2, "map.origin_m", "a list [x, y]");
  expectError("map:\n  origin_m: [0, x]\n" + kMinimal.substr(8), 2, "map.origin_m[1]",
              "must be a number");
  expectError("map:\n  cell_size_m: \"0.02\"\n" + kMinimal.substr(8), 2, "map.cell_size_m",
              "must be a number, got the text \"0.02\"");
  expectError("map: {}\ncameras: {name: c0}\n", 2, "cameras", "must be a list of cameras");
  expectError("map: {}\ncameras:\n  - c0\n", 3, "cameras[0]", "must be a mapping");
  expectError(kMinimal + "    settings: [ExposureTime, 8000]\n", 5, "cameras[0].settings",
              "must be a mapping");
  expectError(kMinimal + "    settings:\n      Gain: [1, 2]\n", 6, "cameras[0].settings.Gain",
              "single value");
  expectError(kMinimal + "    threshold: 20.0\n", 5, "cameras[0].threshold", "whole number");
  expectError(kMinimal + "    name2: x\n    fps:\n", 5, "cameras[0].name2", "unknown key");
  expectError(kMinimal + "    fps:\n", 5, "cameras[0].fps", "must be a number, got nothing");
}

TEST(ConfigErrors, OutOfRangeValuesSayTheRange) {
  expectError("map: {cell_size_m: -0.02}\n" + kMinimal.substr(8), 1, "map.cell_size_m", "> 0");
  expectError("map: {cell_size_m: 11}\n" + kMinimal.substr(8), 1, "map.cell_size_m", "<= 10");
  expectError("map: {width: 9000}\n" + kMinimal.substr(8), 1, "map.width", "from 1 to 8192");
  expectError("map: {height: 0}\n" + kMinimal.substr(8), 1, "map.height", "from 1 to 8192");
  expectError("map: {origin_m: [.nan, 0]}\n" + kMinimal.substr(8), 1, "map.origin_m[0]", "finite");
  expectError("map: {}\ncameras: []\n", 2, "cameras", "at least one camera");
  expectError(kMinimal + "    threshold: 256\n", 5, "cameras[0].threshold", "from 1 to 255");
  expectError(kMinimal + "fusion:\n  threshold: 256\n", 6, "fusion.threshold", "from 1 to 255");
  expectError(kMinimal + "fusion:\n  column_height_m: 5.5\n", 6, "fusion.column_height_m", "<= 5");
  expectError(kMinimal + "fusion:\n  max_wait_ms: -1\n", 6, "fusion.max_wait_ms",
              "from 0 to 10000");
  expectError(kMinimal + "fusion:\n  lighting: {drift_frames: 0}\n", 6,
              "fusion.lighting.drift_frames", "from 1 to 1000000");
  expectError(kMinimal + "fusion:\n  lighting: {min_agreement: 1.5}\n", 6,
              "fusion.lighting.min_agreement", "<= 1");
  expectError(kMinimal + "fusion:\n  lighting: {min_agreement_in_place: -0.1}\n", 6,
              "fusion.lighting.min_agreement_in_place", ">= 0");
  expectError(kMinimal + "    lighting: {adapt: maybe}\n", 5, "cameras[0].lighting.adapt",
              "true or false");
  expectError(kMinimal + "    lighting: {adapts: false}\n", 5, "cameras[0].lighting.adapts",
              "did you mean adapt?");
  expectError(kMinimal + "    fps: 0\n", 5, "cameras[0].fps", "> 0");
  expectError(kMinimal + "    fps: .inf\n", 5, "cameras[0].fps", "finite");
  expectError(kMinimal + "    image_region: [0, 0, 720]\n", 5, "cameras[0].image_region",
              "[x0, y0, width, height]");
  expectError(kMinimal + "    image_region: [0, -1, 720, 576]\n", 5, "cameras[0].image_region[1]",
              ">= 0");
  expectError(kMinimal + "    image_region: [0, 0, 720, 0]\n", 5, "cameras[0].image_region[3]",
              "> 0");
  expectError(kMinimal + "    calibration_units: km\n", 5, "cameras[0].calibration_units",
              "mm, cm or m");
  expectError(kMinimal + "    name: c0\n", 5, "cameras[0].name", "appears twice (lines 3 and 5)");
  expectError("map: {}\ncameras:\n  - name: c/0\n    source: sim://room\n", 3, "cameras[0].name",
              "letters, digits");
  expectError(kMinimal + "transport: {encoding: lz4}\n", 5, "transport.encoding", "raw or zstd");
  expectError(kMinimal + "transport: {lcm_url: \"\"}\n", 5, "transport.lcm_url", "empty");
  expectError(kMinimal + "transport: {lcm_url: \"bogus://x\"}\n", 5, "transport.lcm_url",
              "not an LCM URL");
  expectError(kMinimal + "transport: {lcm_url: \"239.255.76.67:7667\"}\n", 5, "transport.lcm_url",
              "udpm://");
  expectError(kMinimal + "transport:\n  map_channel: A\n  status_channel: A\n", 7,
              "transport.status_channel", "must differ");
}

TEST(ConfigErrors, MissingFileSaysWhy) {
  const TemporaryFolder folder;
  const fs::path file = folder.path() / "absent.yaml";
  try {
    loadConfig(file);
    FAIL() << "a missing config file was accepted";
  } catch (const InputError& error) {
    EXPECT_EQ(error.file(), file.string());
    EXPECT_EQ(error.line(), 0);
    const std::string message = error.what();
    EXPECT_EQ(message.rfind(file.string() + ": cannot read config file: ", 0), 0u) << message;
    EXPECT_NE(message.find("No such file or directory"), std::string::npos) << message;
  }
  try {
    loadConfig(folder.path());
    FAIL() << "a folder was accepted as a config file";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("Is a directory"), std::string::npos) << error.what();
  }
}

TEST(ConfigErrors, EmptyOrNonMappingFilesAreRefused) {
  expectError("", 0, "", "is empty");
  expectError("# only a comment\n", 0, "", "is empty");
  expectError("- map\n- cameras\n", 1, "", "top level must be a mapping");
  expectError(kMinimal + "---\nmap: {}\n", 5, "", "more than one YAML document");
  expectError(kMinimal + "...\n# end\nmap: {}\n", 7, "", "more than one YAML document");
  // yaml-cpp 0.7's LoadAll never returns on this (jbeder/yaml-cpp#1040); it must be an error.
  expectError("# config\n,map: {}\n", 2, "", "top level must be a mapping");
  // An explicit document start, a directive and a document end are one document.
  EXPECT_NO_THROW(parseConfig("%YAML 1.2\n---\n" + kMinimal + "...\n", "occmap.yaml"));
  EXPECT_NO_THROW(parseConfig("--- # occmapd\n" + kMinimal, "occmap.yaml"));
}

TEST(ConfigErrors, RequiredSectionsAndKeys) {
  expectError("cameras:\n  - name: c0\n    source: sim://room\n", 1, "map", "is missing");
  expectError("map: {}\n", 1, "cameras", "is missing");
  expectError("map: {}\ncameras:\n  - source: sim://room\n", 3, "cameras[0].name", "is missing");
  expectError("map: {}\ncameras:\n  - name: c0\n", 3, "cameras[0].source", "is missing");
}

TEST(ConfigErrors, DuplicateCameraNamesNameBothLines) {
  expectError(kMinimal + "  - name: c1\n    source: sim://b\n  - name: c0\n    source: sim://c\n",
              7, "cameras[2].name", "\"c0\" is used on lines 3 and 7");
}

TEST(ConfigErrors, CalibrationIsRequiredUnlessTheSourceIsSimulated) {
  expectError(
      "map: {}\n"
      "cameras:\n"
      "  - name: c0\n"
      "    source: sim://room/c0\n"
      "  - name: c1\n"
      "    source: files:///data/c1/*.png\n"
      "    background: bg/c1.png\n",
      5, "cameras[1].calibration", "needs a calibration file");
  expectError(
      "map: {}\n"
      "cameras:\n"
      "  - name: c1\n"
      "    source: aravis://Basler-1\n"
      "    calibration: c1.xml\n",
      3, "cameras[0].background", "image of the empty scene");
  // The sim camera alone is valid without either.
  EXPECT_NO_THROW(parseConfig(kMinimal, "occmap.yaml"));
}

TEST(ConfigErrors, SourceSchemeMustBeKnown) {
  expectError("map: {}\ncameras:\n  - name: c0\n    source: rtsp://10.0.0.2/stream\n", 4,
              "cameras[0].source", "unknown scheme \"rtsp://\"; use one of files://, sim://");
  expectError("map: {}\ncameras:\n  - name: c0\n    source: /dev/video0\n", 4, "cameras[0].source",
              "names no source scheme");
}

TEST(ConfigErrors, ParseConfigNamesTheGivenFile) {
  try {
    parseConfig("map: {width: 0}\n", "site/occmap.yaml");
    FAIL() << "width 0 accepted";
  } catch (const InputError& error) {
    EXPECT_EQ(std::string(error.what()).rfind("site/occmap.yaml:1: map.width: ", 0), 0u)
        << error.what();
  }
}

}  // namespace
}  // namespace occmap
