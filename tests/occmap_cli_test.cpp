// The occmap command as a user runs it: output formats, exit codes, and maps that equal the
// reference fusion of the same images.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "capture/files_source.h"
#include "capture/image_file.h"
#include "command_runner.h"
#include "config/calibration_file.h"
#include "core/carve_table.h"
#include "core/reference_fusion.h"
#include "left_handed_extrinsics.h"
#include "sim_reference.h"
#include "sim_room_config.h"
#include "tsai_xml.h"

namespace occmap {
namespace {

using testing::kDownwardXml;
using testing::readWhole;
using testing::runCommand;
using testing::TemporaryFolder;
using testing::writeText;

const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";

// The number `key` names in `json`, one JSON object (a failure and NaN when it is not JSON or has
// no such number).
double jsonNumber(const std::string& json, const std::string& key) {
  const nlohmann::json object = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (!object.is_object() || !object.contains(key) || !object[key].is_number()) {
    ADD_FAILURE() << "no number " << key << " in " << json;
    return std::nan("");
  }
  return object[key].get<double>();
}

TEST(OccmapProject, WorldToPixelAsJsonInFullPrecision) {
  TemporaryFolder folder;
  writeText(folder / "down.xml", kDownwardXml);
  const auto result =
      runCommand({kOccmap, "project", "--calibration", (folder / "down.xml").string(), "--world",
                  "-100", "250.5", "0", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  // x -100 mm: 10 pixels left of the centre; y +250.5 mm: 25.05 pixels up (world +y is image -v).
  EXPECT_NEAR(jsonNumber(result.out, "u"), 49.5 - 10.0, 1e-12);
  EXPECT_NEAR(jsonNumber(result.out, "v"), 49.5 - 25.05, 1e-12);
  EXPECT_NEAR(jsonNumber(result.out, "depth"), 2000.0, 1e-9);
  EXPECT_EQ(result.out.front(), '{');
  EXPECT_EQ(std::count(result.out.begin(), result.out.end(), '\n'), 1);
  // Full double precision: 17 significant digits survive the round trip exactly.
  const auto loaded = loadCalibration(folder / "down.xml");
  const auto image = loaded.model->worldToImage({-100, 250.5, 0});
  EXPECT_EQ(jsonNumber(result.out, "v"), image->pixel.y());
}

TEST(OccmapProject, PixelToPlaneAndOutsideTheImage) {
  TemporaryFolder folder;
  writeText(folder / "down.xml", kDownwardXml);
  const std::string calibration = (folder / "down.xml").string();
  auto result = runCommand({kOccmap, "project", "--calibration", calibration, "--pixel", "59.5",
                            "49.5", "--z", "1000", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NEAR(jsonNumber(result.out, "x"), 50.0, 1e-9);  // 10 pixels at 1000 mm: 5 mm each
  EXPECT_NEAR(jsonNumber(result.out, "y"), 0.0, 1e-9);
  EXPECT_EQ(jsonNumber(result.out, "z"), 1000.0);
  EXPECT_NEAR(jsonNumber(result.out, "depth"), 1000.0, 1e-9);
  // A point far outside the image still has its pixel.
  result =
      runCommand({kOccmap, "project", "--calibration", calibration, "--world", "5000", "0", "0"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("outside"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("u 549.5"), std::string::npos) << result.out;
}

TEST(OccmapProject, NoResultIsExitThreeWithAReason) {
  TemporaryFolder folder;
  writeText(folder / "down.xml", kDownwardXml);
  const std::string calibration = (folder / "down.xml").string();
  auto result =
      runCommand({kOccmap, "project", "--calibration", calibration, "--world", "0", "0", "2500"});
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_NE(result.err.find("behind the camera"), std::string::npos) << result.err;
  EXPECT_TRUE(result.out.empty());
  // The plane z = 2500 lies behind this downward camera for every pixel.
  result = runCommand(
      {kOccmap, "project", "--calibration", calibration, "--pixel", "10", "10", "--z", "2500"});
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_NE(result.err.find("never meets the plane"), std::string::npos) << result.err;
}

TEST(OccmapProject, BadInputIsExitTwoNamingTheProblem) {
  TemporaryFolder folder;
  std::string broken = kDownwardXml;
  broken.replace(broken.find("focal=\"2.0\" "), 12, "");
  writeText(folder / "broken.xml", broken);
  auto result = runCommand({kOccmap, "project", "--calibration", (folder / "broken.xml").string(),
                            "--world", "0", "0", "0"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("broken.xml:4"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("Intrinsic.focal"), std::string::npos) << result.err;
  result = runCommand({kOccmap, "project", "--calibration", (folder / "none.xml").string(),
                       "--world", "0", "0", "0"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("none.xml"), std::string::npos) << result.err;
  // Usage: two numbers where three are needed, or neither --world nor --pixel.
  result = runCommand({kOccmap, "project", "--calibration", "x.xml", "--world", "1", "2"});
  EXPECT_EQ(result.exit_code, 2);
  result = runCommand({kOccmap, "project", "--calibration", "x.xml"});
  EXPECT_EQ(result.exit_code, 2);
  result = runCommand({kOccmap, "no-such-command"});
  EXPECT_EQ(result.exit_code, 2);
  result = runCommand({kOccmap, "project", "--help"});
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_NE(result.out.find("Example"), std::string::npos);
}

// A files:// rig: the downward camera, a uniform background, three frames with a dark square each.
struct FilesRig {
  TemporaryFolder folder;
  FilesRig() {
    writeText(folder / "down.xml", kDownwardXml);
    std::filesystem::create_directories(folder / "frames");
    const cv::Mat background(100, 100, CV_8UC1, cv::Scalar(120));
    cv::imwrite((folder / "background.png").string(), background);
    // Natural order: frame2 comes before frame10 (plain sorting would put it last).
    const std::pair<const char*, int> frames[] = {
        {"frame1.png", 10}, {"frame2.png", 40}, {"frame10.png", 70}};
    for (const auto& [name, corner] : frames) {
      cv::Mat live = background.clone();
      live(cv::Rect(corner, corner, 20, 20)).setTo(20);
      // Colour on disk: converted to luminance on reading.
      cv::Mat colour;
      cv::cvtColor(live, colour, cv::COLOR_GRAY2BGR);
      cv::imwrite((folder / "frames" / name).string(), colour);
    }
    writeText(folder / "rig.yaml",
              R"(map: {origin_m: [-0.6, -0.6], cell_size_m: 0.04, width: 30, height: 30}
fusion: {threshold: 25, column_height_m: 0}
cameras:
  - name: down
    source: "files://frames/*.png"
    calibration: down.xml
    background: background.png
)");
  }
};

// The files:// source under fuse and occmapd: every frame is the file's grey image, decoded into
// the same buffer frame after frame (no pixel memory allocated per frame on the daemon's capture
// thread).
TEST(FilesSource, ReadsEveryFrameIntoTheSameBuffer) {
  FilesRig rig;
  std::string error;
  const auto source = FilesSource::open((rig.folder / "frames" / "*.png").string(), error);
  ASSERT_NE(source, nullptr) << error;
  const char* names[] = {"frame1.png", "frame2.png", "frame10.png"};
  const std::uint8_t* first_pixels = nullptr;
  for (const char* name : names) {
    Frame frame;
    ASSERT_EQ(source->read(frame), FrameSource::Status::kFrame) << source->lastError();
    if (first_pixels == nullptr) first_pixels = frame.image.data;
    EXPECT_EQ(frame.image.data, first_pixels) << name << " was decoded into a new buffer";
    const Image expected = *readGreyImage(rig.folder / "frames" / name, error);
    ASSERT_EQ(frame.image.width, expected.width());
    ASSERT_EQ(frame.image.height, expected.height());
    for (int v = 0; v < expected.height(); ++v) {
      ASSERT_TRUE(
          std::equal(expected.row(v), expected.row(v) + expected.width(), frame.image.row(v)))
          << name << " row " << v;
    }
  }
  Frame end;
  EXPECT_EQ(source->read(end), FrameSource::Status::kEnd);
}

TEST(OccmapFuse, WritesOnlyMapsAndTheyEqualTheReferenceFusion) {
  FilesRig rig;
  const auto out = rig.folder / "maps";
  const auto result = runCommand(
      {kOccmap, "fuse", "--config", (rig.folder / "rig.yaml").string(), "--out", out.string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("wrote 3 maps"), std::string::npos) << result.out;
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(out)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  ASSERT_EQ(names,
            (std::vector<std::string>{"map_000000.png", "map_000001.png", "map_000002.png"}));

  // The same fusion in process, from the same files, in natural order.
  const auto calibration = loadCalibration(rig.folder / "down.xml");
  const Camera camera(calibration.model, calibration.units, 100, 100);
  MapGeometry map{-0.6, -0.6, 0.04, 30, 30};
  const CarveTable table = buildCarveTable(camera, map, 0.0);
  std::string error;
  const Image background = *readGreyImage(rig.folder / "background.png", error);
  const char* frames[] = {"frame1.png", "frame2.png", "frame10.png"};
  int occupied_seen = 0;
  for (int k = 0; k < 3; ++k) {
    const Image live = *readGreyImage(rig.folder / "frames" / frames[k], error);
    const CameraFrame frame{&table, live.view(), background.view(), 25};
    const OccupancyMap expected = fuseReference(map, std::span(&frame, 1));
    const cv::Mat written =
        cv::imread((out / names[static_cast<std::size_t>(k)]).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(written.type(), CV_8UC1);
    ASSERT_EQ(written.rows, 30);
    ASSERT_EQ(written.cols, 30);
    for (int row = 0; row < 30; ++row) {
      for (int column = 0; column < 30; ++column) {
        ASSERT_EQ(written.at<std::uint8_t>(row, column), greyLevel(expected.at(row, column)))
            << "map " << k << " cell " << row << "," << column;
        occupied_seen += expected.at(row, column) == CellState::kOccupied ? 1 : 0;
      }
    }
  }
  EXPECT_GT(occupied_seen, 3 * 20) << "each frame's square should leave occupied cells";
  // The camera sees 1 m x 1 m of the 1.2 m x 1.2 m map: the rim is unseen (128).
  const cv::Mat first = cv::imread((out / names[0]).string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(first.at<std::uint8_t>(0, 0), 128);
  EXPECT_EQ(first.at<std::uint8_t>(15, 15), 0);
}

TEST(OccmapFuse, StopsAfterFramesAndGuardsItsFolder) {
  FilesRig rig;
  const std::string config = (rig.folder / "rig.yaml").string();
  const auto out = rig.folder / "maps";
  auto result =
      runCommand({kOccmap, "fuse", "--config", config, "--out", out.string(), "--frames", "2"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(out), {}), 2);
  // Old maps stay unless --overwrite; a folder with other files is refused outright.
  result = runCommand({kOccmap, "fuse", "--config", config, "--out", out.string()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--overwrite"), std::string::npos) << result.err;
  result = runCommand({kOccmap, "fuse", "--config", config, "--out", out.string(), "--overwrite"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(out), {}), 3);
  writeText(out / "notes.txt", "mine");
  result = runCommand({kOccmap, "fuse", "--config", config, "--out", out.string(), "--overwrite"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_TRUE(std::filesystem::exists(out / "notes.txt"));
  EXPECT_TRUE(std::filesystem::exists(out / "map_000002.png"));
}

TEST(OccmapFuse, InvalidConfigIsExitTwoBeforeAnyWork) {
  FilesRig rig;
  writeText(rig.folder / "bad.yaml",
            "map: {width: 30, height: 30}\nfusion: {treshold: 20}\ncameras: []\n");
  const auto out = rig.folder / "maps";
  auto result = runCommand(
      {kOccmap, "fuse", "--config", (rig.folder / "bad.yaml").string(), "--out", out.string()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("bad.yaml:2"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("treshold"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  // A background of another size than the stream names the config line of `background`.
  const cv::Mat small(50, 50, CV_8UC1, cv::Scalar(120));
  cv::imwrite((rig.folder / "small.png").string(), small);
  writeText(rig.folder / "small.yaml", R"(map: {width: 30, height: 30}
cameras:
  - name: down
    source: "files://frames/*.png"
    calibration: down.xml
    background: small.png
)");
  result = runCommand(
      {kOccmap, "fuse", "--config", (rig.folder / "small.yaml").string(), "--out", out.string()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("small.yaml:6"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("50x50"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(out)) << "a wrong-size background left " << out;
  // A broken calibration is found before the folder is made, and old maps are kept.
  std::string broken = kDownwardXml;
  broken.replace(broken.find("focal=\"2.0\" "), 12, "");
  writeText(rig.folder / "broken.xml", broken);
  std::string text = readWhole(rig.folder / "rig.yaml");
  text.replace(text.find("down.xml"), 8, "broken.xml");
  writeText(rig.folder / "broken.yaml", text);
  result = runCommand(
      {kOccmap, "fuse", "--config", (rig.folder / "broken.yaml").string(), "--out", out.string()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("broken.xml:4"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("Intrinsic.focal"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(out)) << "a broken calibration left " << out;
  const auto earlier = rig.folder / "earlier";
  std::filesystem::create_directories(earlier);
  writeText(earlier / "map_000000.png", "an earlier run's map");
  result = runCommand({kOccmap, "fuse", "--config", (rig.folder / "broken.yaml").string(), "--out",
                       earlier.string(), "--overwrite"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_TRUE(std::filesystem::exists(earlier / "map_000000.png"))
      << "a refused run must not remove the maps of an earlier one";
}

// A files:// glob in a folder that does not exist says so (not that a folder is unreadable), at
// the config line of the source.
TEST(OccmapFuse, SourceInAMissingFolderSaysItDoesNotExist) {
  FilesRig rig;
  std::string text = readWhole(rig.folder / "rig.yaml");
  text.replace(text.find("files://frames/*.png"), 20, "files://no-such-folder/*.png");
  writeText(rig.folder / "missing.yaml", text);
  const auto out = rig.folder / "maps";
  const auto result = runCommand(
      {kOccmap, "fuse", "--config", (rig.folder / "missing.yaml").string(), "--out", out.string()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("missing.yaml:5"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find((rig.folder / "no-such-folder").string() + " does not exist"),
            std::string::npos)
      << result.err;
  EXPECT_EQ(result.err.find("unreadable"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(OccmapFuse, SimulatedRoomIsScoredAgainstItsGroundTruth) {
  TemporaryFolder folder;
  const auto result =
      runCommand({kOccmap, "fuse", "--config", OCCMAP_SOURCE_DIR "/examples/sim-room.yaml", "--out",
                  (folder / "maps").string(), "--frames", "3", "--snapshot",
                  (folder / "snapshot.png").string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("objects found 15 of 15"), std::string::npos) << result.out;
  const cv::Mat picture = cv::imread((folder / "snapshot.png").string());
  EXPECT_GT(picture.cols, 512);
}

// occmap fuse runs the daemon's kernel; its maps must still be the reference fusion of the same
// frames, cell for cell, in both carving modes. The simulator is deterministic: frame n of
// sim://room/cK is what SimRoomReference renders for sequence n.
TEST(OccmapFuse, SimulatedRoomMapsAreTheReferenceFusionOfTheirFrames) {
  constexpr int kFrames = 8;
  const std::string example = readWhole(OCCMAP_SOURCE_DIR "/examples/sim-room.yaml");
  const std::string column_line = "column_height_m: 0.3";
  ASSERT_NE(example.find(column_line), std::string::npos) << "examples/sim-room.yaml changed";
  const MapGeometry map{-0.62, -1.87, 0.02, 512, 512};  // the example's map
  for (const double column_height : {0.0, 0.3}) {
    SCOPED_TRACE("column_height_m " + std::to_string(column_height));
    TemporaryFolder folder;
    std::string text = example;
    if (column_height == 0.0)
      text.replace(text.find(column_line), column_line.size(), "column_height_m: 0");
    writeText(folder / "room.yaml", text);
    const auto out = folder / "maps";
    const auto result = runCommand({kOccmap, "fuse", "--config", (folder / "room.yaml").string(),
                                    "--out", out.string(), "--frames", std::to_string(kFrames)});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    ASSERT_NE(result.out.find("wrote " + std::to_string(kFrames) + " maps"), std::string::npos)
        << result.out;

    const testing::SimRoomReference reference(map, column_height);
    std::size_t occupied = 0;
    for (int n = 0; n < kFrames; ++n) {
      DecodedMap frames;  // what a map of frame set n used: frame n of every camera
      frames.cameras.resize(4);
      for (DecodedCamera& camera : frames.cameras) {
        camera.used = true;
        camera.sequence = n;
      }
      const OccupancyMap expected = reference.expected(frames);
      char name[32];
      std::snprintf(name, sizeof name, "map_%06d.png", n);
      const cv::Mat written = cv::imread((out / name).string(), cv::IMREAD_UNCHANGED);
      ASSERT_EQ(written.type(), CV_8UC1) << name;
      ASSERT_EQ(written.rows, map.height) << name;
      ASSERT_EQ(written.cols, map.width) << name;
      for (int row = 0; row < map.height; ++row) {
        for (int column = 0; column < map.width; ++column) {
          ASSERT_EQ(written.at<std::uint8_t>(row, column), greyLevel(expected.at(row, column)))
              << name << " cell " << row << "," << column;
          occupied += expected.at(row, column) == CellState::kOccupied ? 1 : 0;
        }
      }
    }
    EXPECT_GT(occupied, kFrames * 1000u)
        << "the people, chairs and robot should leave occupied cells";
  }
}

// occmap record of the simulated room under changing light, then occmap fuse of its replay.yaml:
// the very maps occmap fuse makes of the simulated cameras themselves (the light's model
// included), so a recording replays as it was.
TEST(OccmapRecord, AReplayOfTheRecordingMakesTheSameMapsAsTheCameras) {
  TemporaryFolder folder;
  const std::string text = testing::inCoarseMap(
      testing::inScene(readWhole(OCCMAP_SOURCE_DIR "/examples/sim-room.yaml"), "room-light"));
  ASSERT_NE(text, "") << "examples/sim-room.yaml changed: not the map inCoarseMap knows";
  writeText(folder / "room.yaml", text);
  const auto recording = folder / "recording";
  auto result = runCommand({kOccmap, "record", "--config", (folder / "room.yaml").string(), "--out",
                            recording.string(), "--frames", "40"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  for (const char* camera : {"c0", "c1", "c2", "c3"}) {
    const std::string times = readWhole(recording / camera / "timestamps.csv");
    EXPECT_EQ(times.rfind("frame,sequence,capture_utime\n0,0,", 0), 0u) << times;
    EXPECT_EQ(std::count(times.begin(), times.end(), '\n'), 41) << camera;
    EXPECT_TRUE(std::filesystem::exists(recording / camera / "000039.png"));
    EXPECT_FALSE(std::filesystem::exists(recording / camera / "000040.png"));
  }
  result = runCommand({kOccmap, "fuse", "--config", (recording / "replay.yaml").string(), "--out",
                       (folder / "replayed").string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("wrote 40 maps"), std::string::npos) << result.out;
  result = runCommand({kOccmap, "fuse", "--config", (folder / "room.yaml").string(), "--out",
                       (folder / "live").string(), "--frames", "40"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  for (int n = 0; n < 40; ++n) {
    char name[32];
    std::snprintf(name, sizeof name, "map_%06d.png", n);
    EXPECT_EQ(readWhole(folder / "replayed" / name), readWhole(folder / "live" / name)) << name;
  }
  // Nothing is lost: an existing recording is not written over, and how much to record is asked.
  result = runCommand({kOccmap, "record", "--config", (folder / "room.yaml").string(), "--out",
                       recording.string(), "--frames", "1"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("exists and is not an empty folder"), std::string::npos) << result.err;
  result = runCommand({kOccmap, "record", "--config", (folder / "room.yaml").string(), "--out",
                       (folder / "other").string()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--frames is needed"), std::string::npos) << result.err;
}

TEST(OccmapBackground, TheMedianOfFramesDropsWhatPassesBy) {
  FilesRig rig;
  const std::string config = (rig.folder / "rig.yaml").string();
  const auto out = rig.folder / "made-background.png";
  auto result = runCommand({kOccmap, "background", "--config", config, "--camera", "down",
                            "--frames", "3", "--out", out.string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("median of 3 frames"), std::string::npos) << result.out;
  // Each frame's dark square lies elsewhere: every pixel's median is the empty scene's 120.
  const cv::Mat made = cv::imread(out.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(made.type(), CV_8UC1);
  EXPECT_EQ(cv::countNonZero(made != 120), 0);
  // Nothing is overwritten unasked; an unknown camera is named.
  result = runCommand(
      {kOccmap, "background", "--config", config, "--camera", "down", "--out", out.string()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--overwrite"), std::string::npos) << result.err;
  result = runCommand({kOccmap, "background", "--config", config, "--camera", "left", "--out",
                       (rig.folder / "x.png").string()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("no camera named 'left'"), std::string::npos) << result.err;
}

TEST(OccmapCoverage, DrawsWhichCamerasSeeEachCell) {
  TemporaryFolder folder;
  const auto result =
      runCommand({kOccmap, "coverage", "--config", OCCMAP_SOURCE_DIR "/examples/sim-room.yaml",
                  "--out", (folder / "coverage.png").string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  for (const char* name : {"c0", "c1", "c2", "c3"}) {
    EXPECT_NE(result.out.find(name), std::string::npos) << result.out;
  }
  EXPECT_NE(result.out.find("by 2+:"), std::string::npos) << result.out;
  // The cells seen, by how many cameras see them: 1 to 4, every one counted once.
  const std::size_t exactly = result.out.find("of the cells seen, seen by exactly ");
  ASSERT_NE(exactly, std::string::npos) << result.out;
  double shares = 0.0;
  std::size_t at = exactly;
  for (int n = 1; n <= 4; ++n) {
    at = result.out.find(std::to_string(n) + ": ", at);
    ASSERT_NE(at, std::string::npos) << result.out;
    shares += std::stod(result.out.substr(at + 3));
  }
  EXPECT_NEAR(shares, 100.0, 0.25) << result.out;
  const cv::Mat picture = cv::imread((folder / "coverage.png").string());
  EXPECT_GE(picture.cols, 512);
}

// ----------------------------------------------------------------------------------------------
// occmap project on OpenCV calibrations as WILDTRACK and MultiviewX ship them: cv::FileStorage
// XML, intrinsics and extrinsics in two files, no image size, MultiviewX's left-handed world.

const cv::Mat kXmlCameraMatrix =
    (cv::Mat_<double>(3, 3) << 1743.4, 0, 934.5, 0, 1735.1, 444.4, 0, 0, 1);
const cv::Mat kXmlDistortion = (cv::Mat_<double>(1, 5) << -0.43, 0.25, 0.0012, -0.0007, -0.06);
// A camera 3 m above the floor looking down at it and forward (as in
// opencv_two_file_calibration_test.cpp), and a floor point in front of it, inside its image.
const cv::Vec3d kXmlRvec(-2.2, 0.15, -0.1);
const cv::Vec3d kXmlTvec(-0.6, 1.2, 4.5);
const cv::Point3d kXmlFloorPoint(0.5, 1.5, 0.0);

// Intrinsics as cv::FileStorage writes them, without the image size (WILDTRACK's layout).
std::filesystem::path writeXmlIntrinsics(const std::filesystem::path& file) {
  cv::FileStorage storage(file.string(), cv::FileStorage::WRITE);
  storage << "camera_matrix" << kXmlCameraMatrix << "distortion_coefficients" << kXmlDistortion;
  return file;
}

// Extrinsics as WILDTRACK writes them: each vector as numbers between blanks, by hand.
std::filesystem::path writeXmlExtrinsics(const std::filesystem::path& file, const cv::Vec3d& rvec,
                                         const cv::Vec3d& tvec) {
  char text[512];
  std::snprintf(text, sizeof text,
                "<?xml version=\"1.0\"?>\n<opencv_storage>\n<rvec>%.17g %.17g %.17g</rvec>\n"
                "<tvec>%.17g %.17g %.17g</tvec>\n</opencv_storage>\n",
                rvec[0], rvec[1], rvec[2], tvec[0], tvec[1], tvec[2]);
  writeText(file, text);
  return file;
}

cv::Point2d openCvPixel(const cv::Point3d& point, const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(std::vector<cv::Point3d>{point}, rvec, tvec, kXmlCameraMatrix, kXmlDistortion,
                    pixels);
  return pixels.at(0);
}

std::vector<std::string> worldArguments(const cv::Point3d& point) {
  return {"--world", std::to_string(point.x), std::to_string(point.y), std::to_string(point.z)};
}

TEST(OccmapProject, OpenCvXmlIntrinsicsAndExtrinsicsGiveOpenCvsPixel) {
  TemporaryFolder folder;
  const std::string intrinsics = writeXmlIntrinsics(folder / "intr.xml").string();
  const std::string extrinsics =
      writeXmlExtrinsics(folder / "extr.xml", kXmlRvec, kXmlTvec).string();
  std::vector<std::string> arguments = {kOccmap,        "project",      "--intrinsics",
                                        intrinsics,     "--extrinsics", extrinsics,
                                        "--image-size", "1920",         "1080"};
  for (const std::string& argument : worldArguments(kXmlFloorPoint)) arguments.push_back(argument);
  arguments.push_back("--json");
  auto result = runCommand(arguments);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const cv::Point2d expected = openCvPixel(kXmlFloorPoint, kXmlRvec, kXmlTvec);
  EXPECT_NEAR(jsonNumber(result.out, "u"), expected.x, 1e-6);
  EXPECT_NEAR(jsonNumber(result.out, "v"), expected.y, 1e-6);
  EXPECT_GT(jsonNumber(result.out, "depth"), 0.0);
  // It lands inside the 1920 x 1080 image (else the test would say little).
  EXPECT_GT(expected.x, 0.0);
  EXPECT_LT(expected.x, 1920.0);
  EXPECT_GT(expected.y, 0.0);
  EXPECT_LT(expected.y, 1080.0);

  // Without --image-size the text says that the calibration gives none, and still the pixel.
  result = runCommand({kOccmap, "project", "--intrinsics", intrinsics, "--extrinsics", extrinsics,
                       "--world", "0.5", "1.5", "0"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("the calibration gives no image size"), std::string::npos)
      << result.out;
  char u[64];
  std::snprintf(u, sizeof u, "u %.6f", expected.x);
  EXPECT_NE(result.out.find(u), std::string::npos) << result.out << " should hold " << u;
  // With it, the text says whether the pixel is inside the frame.
  result = runCommand({kOccmap, "project", "--intrinsics", intrinsics, "--extrinsics", extrinsics,
                       "--image-size", "1920", "1080", "--world", "0.5", "1.5", "0"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("inside the 1920x1080 calibration frame"), std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find(" m  (inside"), std::string::npos) << result.out;
  // WILDTRACK's world is in centimetres: --units names them; the numbers are the file's own.
  result =
      runCommand({kOccmap, "project", "--intrinsics", intrinsics, "--extrinsics", extrinsics,
                  "--image-size", "1920", "1080", "--units", "cm", "--world", "0.5", "1.5", "0"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find(u), std::string::npos) << result.out << " should hold " << u;
  EXPECT_NE(result.out.find(" cm  (inside"), std::string::npos) << result.out;
}

// MultiviewX's extrinsics, made in Unity's left-handed world: every floor point at negative depth.
TEST(OccmapProject, LeftHandedExtrinsicsNeedWorldFrameLeftHanded) {
  TemporaryFolder folder;
  const auto [left_rvec, left_tvec] = testing::leftHandedExtrinsics(kXmlRvec, kXmlTvec);
  const std::string intrinsics = writeXmlIntrinsics(folder / "intr.xml").string();
  const std::string extrinsics =
      writeXmlExtrinsics(folder / "extr.xml", left_rvec, left_tvec).string();
  std::vector<std::string> arguments = {kOccmap,        "project",      "--intrinsics",
                                        intrinsics,     "--extrinsics", extrinsics,
                                        "--image-size", "1920",         "1080"};
  for (const std::string& argument : worldArguments(kXmlFloorPoint)) arguments.push_back(argument);
  arguments.push_back("--json");

  // Read as right-handed: behind the camera, exit 3, and the hint.
  auto result = runCommand(arguments);
  EXPECT_EQ(result.exit_code, 3) << result.out << result.err;
  EXPECT_TRUE(result.out.empty()) << result.out;
  EXPECT_NE(result.err.find("behind the camera"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("--world-frame left-handed"), std::string::npos) << result.err;

  // With --world-frame left-handed: cv::projectPoints' pixel, at positive depth.
  arguments.push_back("--world-frame");
  arguments.push_back("left-handed");
  result = runCommand(arguments);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const cv::Point2d expected = openCvPixel(kXmlFloorPoint, left_rvec, left_tvec);
  EXPECT_NEAR(jsonNumber(result.out, "u"), expected.x, 1e-6);
  EXPECT_NEAR(jsonNumber(result.out, "v"), expected.y, 1e-6);
  EXPECT_GT(jsonNumber(result.out, "depth"), 0.0);
  // The very pixel of the right-handed camera it mirrors.
  const cv::Point2d right = openCvPixel(kXmlFloorPoint, kXmlRvec, kXmlTvec);
  EXPECT_NEAR(expected.x, right.x, 1e-6);
  EXPECT_NEAR(expected.y, right.y, 1e-6);
}

TEST(OccmapProject, IntrinsicsGoWithExtrinsicsAndNotWithCalibration) {
  TemporaryFolder folder;
  const std::string intrinsics = writeXmlIntrinsics(folder / "intr.xml").string();
  const std::string extrinsics =
      writeXmlExtrinsics(folder / "extr.xml", kXmlRvec, kXmlTvec).string();
  writeText(folder / "down.xml", kDownwardXml);
  const std::string calibration = (folder / "down.xml").string();
  // --calibration together with --intrinsics (and --extrinsics): usage, exit 2.
  auto result = runCommand({kOccmap, "project", "--calibration", calibration, "--intrinsics",
                            intrinsics, "--extrinsics", extrinsics, "--world", "0", "0", "0"});
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
  EXPECT_TRUE(result.out.empty()) << result.out;
  EXPECT_NE(result.err.find("--intrinsics"), std::string::npos) << result.err;
  result = runCommand({kOccmap, "project", "--calibration", calibration, "--intrinsics", intrinsics,
                       "--world", "0", "0", "0"});
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
  // --intrinsics without --extrinsics, and the other way round.
  result =
      runCommand({kOccmap, "project", "--intrinsics", intrinsics, "--world", "0.5", "1.5", "0"});
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
  EXPECT_TRUE(result.out.empty()) << result.out;
  EXPECT_NE(result.err.find("--extrinsics"), std::string::npos) << result.err;
  result =
      runCommand({kOccmap, "project", "--extrinsics", extrinsics, "--world", "0.5", "1.5", "0"});
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
  EXPECT_NE(result.err.find("--intrinsics"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace occmap
