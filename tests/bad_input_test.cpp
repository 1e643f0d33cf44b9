// Bad input gets a clear error and loses nothing (issue 6): every kind of bad config, calibration
// and image is exit code 2 from `occmapd --check`, from occmapd itself and from `occmap fuse`, with
// the file and the line or field named; bad frames at run time are dropped and counted while the
// camera goes on with the next one; a camera that sees no floor is a warning and an empty table;
// and a running daemon refuses a reload with bad files and keeps running with its old config.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <occmap/status_t.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <unistd.h>

#include "base/clock.h"
#include "bus_listener.h"
#include "capture/files_source.h"
#include "capture/image_file.h"
#include "child_process.h"
#include "config/calibration_file.h"
#include "config/config.h"
#include "daemon/pipeline.h"
#include "downward_rig.h"
#include "notify_listener.h"
#include "sim_room_config.h"
#include "timing.h"
#include "transport/map_codec.h"
#include "transport/memory_bus.h"
#include "tsai_xml.h"

namespace occmap {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using testing::ChildProcess;
using testing::kDownwardXml;
using testing::NotifyListener;
using testing::readWhole;
using testing::runCommand;
using testing::TemporaryFolder;
using testing::writeText;

const std::string kOccmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  if (at == std::string::npos) {
    ADD_FAILURE() << "\"" << from << "\" is not in\n" << text;
    return text;
  }
  return text.replace(at, from.size(), to);
}

// The same camera turned to look straight up (R = I, T = (0, 0, -2000): still 2 m above the
// origin): every floor point is behind it.
std::string upwardXml() {
  return replaced(
      replaced(kDownwardXml, "tz=\"2000\" rx=\"3.141592653589793\"", "tz=\"-2000\" rx=\"0\""),
      "name=\"down\"", "name=\"up\"");
}

// The downward camera in OpenCV's YAML, as hand-written (fx = focal / dpx = 200 px, tvec in m).
const std::string kDownwardYaml =
    "%YAML:1.0\n"                                                // 1
    "---\n"                                                      // 2
    "image_width: 100\n"                                         // 3
    "image_height: 100\n"                                        // 4
    "camera_matrix: !!opencv-matrix\n"                           // 5
    "   rows: 3\n"                                               // 6
    "   cols: 3\n"                                               // 7
    "   dt: d\n"                                                 // 8
    "   data: [ 200., 0., 49.5, 0., 200., 49.5, 0., 0., 1. ]\n"  // 9
    "distortion_coefficients: [ 0., 0., 0., 0., 0. ]\n"          // 10
    "rvec: [ 3.141592653589793, 0., 0. ]\n"                      // 11
    "tvec: [ 0., 0., 2. ]\n";                                    // 12

// One files:// camera (lines 5-8) on the downward calibration; `extra` adds lines from 9 on.
std::string filesConfig(const std::string& extra = "", const std::string& source = "frames",
                        const std::string& calibration = "down.xml",
                        const std::string& background = "background.png") {
  std::string text =
      "map: {origin_m: [-0.6, -0.6], cell_size_m: 0.04, width: 30, height: 30}\n"
      "fusion: {threshold: 25, column_height_m: 0}\n"
      "transport: {lcm_url: \"memq://\"}\n"
      "cameras:\n"
      "  - name: down\n";
  text += "    source: \"files://" + source + "/*.png\"\n";
  text += "    calibration: " + calibration + "\n";
  text += "    background: " + background + "\n";
  return text + extra;
}

cv::Mat picture(int width, int height, int value) {
  return cv::Mat(height, width, CV_8UC1, cv::Scalar(value));
}

// A folder with a downward camera's files, good and bad: calibrations, a background, frames, and
// every kind of broken image file.
struct Site {
  TemporaryFolder folder;
  Site() {
    writeText(folder / "down.xml", kDownwardXml);
    writeText(folder / "up.xml", upwardXml());
    writeText(folder / "down.yml", kDownwardYaml);
    const cv::Mat background = picture(100, 100, 120);
    cv::imwrite(path("background.png"), background);
    fs::create_directories(folder / "frames");
    for (int k = 1; k <= 3; ++k) {
      cv::Mat live = background.clone();
      live(cv::Rect(20 * k, 20 * k, 20, 20)).setTo(20);
      cv::imwrite(path("frames/frame" + std::to_string(k) + ".png"), live);
    }
    cv::imwrite(path("small.png"), picture(50, 50, 120));
    // Cut short: PNG's chunks and JPEG's markers both tell; a JPEG decoder alone would not.
    cv::imwrite(path("truncated.png"), background);
    fs::resize_file(folder / "truncated.png", fs::file_size(folder / "truncated.png") / 2);
    cv::Mat noise(100, 100, CV_8UC1);
    cv::randu(noise, 0, 256);
    cv::imwrite(path("truncated.jpg"), noise);
    fs::resize_file(folder / "truncated.jpg", fs::file_size(folder / "truncated.jpg") * 2 / 3);
    cv::imwrite(path("deep.png"), cv::Mat(100, 100, CV_16UC1, cv::Scalar(30000)));
    cv::imwrite(path("float.tiff"), cv::Mat(100, 100, CV_32FC1, cv::Scalar(0.5)));
    // Netpbm PAM, grey + alpha: the one format OpenCV hands over with two channels.
    std::string pam =
        "P7\nWIDTH 100\nHEIGHT 100\nDEPTH 2\nMAXVAL 255\nTUPLTYPE GRAYSCALE_ALPHA\n"
        "ENDHDR\n";
    for (int i = 0; i < 100 * 100; ++i) pam += "\x78\xff";
    writeText(folder / "two-channels.pam", pam);
    writeText(folder / "empty.png", "");
    writeText(folder / "notes.png", "this is not a picture\n");
  }
  std::string path(const std::string& name) const { return (folder / name).string(); }
  // mixed/frame1-4.png: a good image, one of another size, a corrupt one, a good one.
  void makeMixedImages() const {
    fs::create_directories(folder / "mixed");
    fs::copy_file(folder / "frames/frame1.png", folder / "mixed/frame1.png");
    fs::copy_file(folder / "small.png", folder / "mixed/frame2.png");
    fs::copy_file(folder / "truncated.png", folder / "mixed/frame3.png");
    fs::copy_file(folder / "frames/frame3.png", folder / "mixed/frame4.png");
  }
};

// ----------------------------------------------------------------------------------------------
// Image files

TEST(BadImages, EachKindOfBrokenFileIsRefusedNamingTheFileAndWhatIsWrong) {
  const Site site;
  const std::pair<const char*, const char*> cases[] = {
      {"truncated.png", "cannot decode image"},
      {"truncated.jpg", "ends before its end-of-image marker (truncated or corrupt)"},
      {"deep.png", "has 16-bit samples; occmap needs 8-bit"},
      {"float.tiff", "has 32-bit samples"},
      {"two-channels.pam", "has 2 channels; occmap needs grey (1), colour (3)"},
      {"empty.png", "cannot decode image"},
      {"notes.png", "not an image format OpenCV reads"},
      {"absent.png", "cannot read image"},
  };
  // One reader for all, a good picture read after each bad file: a bad file must not spoil the
  // reader for the next, nor come out as the picture read before it (cv::imdecode leaves its
  // buffer as it was for bytes no decoder knows).
  GreyImageReader reader;
  for (const auto& [name, what] : cases) {
    std::string error;
    EXPECT_FALSE(reader.read(site.folder / name, error)) << name << " was read as an image";
    EXPECT_NE(error.find(site.path(name)), std::string::npos) << name << ": " << error;
    EXPECT_NE(error.find(what), std::string::npos) << name << ": " << error;
    const std::optional<ImageView> good = reader.read(site.folder / "background.png", error);
    ASSERT_TRUE(good) << "after " << name << ": " << error;
    EXPECT_EQ(good->width, 100);
    EXPECT_EQ(good->at(50, 50), 120);
  }
}

// The end-of-image check refuses only JPEGs that are cut short: baseline, progressive, with
// restart markers, and with bytes after the end (which some cameras append) all read.
TEST(BadImages, WholeJpegsOfEveryKindStillRead) {
  const TemporaryFolder folder;
  cv::Mat noise(64, 80, CV_8UC1);
  cv::randu(noise, 0, 256);
  const std::vector<std::pair<std::string, std::vector<int>>> kinds = {
      {"baseline.jpg", {}},
      {"progressive.jpg", {cv::IMWRITE_JPEG_PROGRESSIVE, 1}},
      {"restarts.jpg", {cv::IMWRITE_JPEG_RST_INTERVAL, 2}},
      {"optimised.jpg", {cv::IMWRITE_JPEG_OPTIMIZE, 1, cv::IMWRITE_JPEG_QUALITY, 100}}};
  for (const auto& [name, parameters] : kinds) {
    const fs::path file = folder / name;
    ASSERT_TRUE(cv::imwrite(file.string(), noise, parameters));
    std::string error;
    EXPECT_TRUE(readGreyImage(file, error)) << name << ": " << error;
    std::ofstream(file, std::ios::app | std::ios::binary) << "trailer appended by a camera";
    EXPECT_TRUE(readGreyImage(file, error)) << name << " with a trailer: " << error;
    // Cut anywhere before its end, it is refused.
    const auto size = fs::file_size(file);
    fs::resize_file(file, size - 30);  // the trailer and the end-of-image marker
    EXPECT_FALSE(readGreyImage(file, error)) << name << " cut short was read";
    fs::resize_file(file, size / 2);
    EXPECT_FALSE(readGreyImage(file, error)) << name << " cut in half was read";
  }
}

// A files:// camera skips a bad image (another size, corrupt) and goes on with the next one:
// before, it read the same bad file again and again and the camera stopped for good.
TEST(BadFrames, AFilesSourceSkipsABadImageAndGoesOnWithTheNext) {
  const Site site;
  site.makeMixedImages();
  std::string error;
  const auto source = FilesSource::open(site.path("mixed/*.png"), error);
  ASSERT_NE(source, nullptr) << error;
  for (int loop = 0; loop < 2; ++loop) {
    Frame frame;
    ASSERT_EQ(source->read(frame), FrameSource::Status::kFrame) << source->lastError();
    EXPECT_EQ(frame.sequence, static_cast<std::uint64_t>(2 * loop));
    EXPECT_EQ(source->read(frame), FrameSource::Status::kError);
    EXPECT_EQ(source->lastError(), "image " + site.path("mixed/frame2.png") +
                                       " is 50x50, but this camera's first image is 100x100");
    EXPECT_EQ(source->read(frame), FrameSource::Status::kError);
    EXPECT_NE(source->lastError().find("cannot decode image " + site.path("mixed/frame3.png")),
              std::string::npos)
        << source->lastError();
    ASSERT_EQ(source->read(frame), FrameSource::Status::kFrame) << source->lastError();
    EXPECT_EQ(frame.sequence, static_cast<std::uint64_t>(2 * loop + 1))
        << "frames delivered are numbered without gaps";
    EXPECT_EQ(frame.image.at(70, 70), 20) << "frame4.png, frame3.png's picture";
    EXPECT_EQ(source->read(frame), FrameSource::Status::kEnd);
    ASSERT_TRUE(source->rewind());
  }
}

// ----------------------------------------------------------------------------------------------
// Exit code 2, file and place named: `occmapd --check`, occmapd as systemd starts it, occmap fuse

struct BadCase {
  std::string name;    // what is wrong, for the test's messages
  std::string config;  // the config's text (empty: `file` is given as the config)
  std::string where;   // the message names this place ("bad.yaml:9: cameras[0].threshold")
  std::string what;    // and says this
  std::string file = "bad.yaml";
};

std::vector<BadCase> badCases(const Site& site) {
  const std::string bad = site.path("bad.yaml");
  std::string nofocal = replaced(kDownwardXml, "focal=\"2.0\" ", "");
  writeText(site.folder / "nofocal.xml", nofocal);
  writeText(site.folder / "nan.xml", replaced(kDownwardXml, "kappa1=\"0\"", "kappa1=\"nan\""));
  writeText(site.folder / "zerofocal.xml", replaced(kDownwardXml, "focal=\"2.0\"", "focal=\"0\""));
  writeText(site.folder / "inf.yml",
            replaced(kDownwardYaml, "tvec: [ 0., 0., 2. ]", "tvec: [ 0., 0., .inf ]"));
  writeText(site.folder / "zerofocal.yml",
            replaced(kDownwardYaml, "[ 200., 0., 49.5, 0., 200.,", "[ 0., 0., 49.5, 0., 0.,"));
  fs::create_directories(site.folder / "corrupt");
  fs::copy_file(site.folder / "truncated.png", site.folder / "corrupt/frame1.png",
                fs::copy_options::overwrite_existing);
  fs::create_directories(site.folder / "deep");
  fs::copy_file(site.folder / "deep.png", site.folder / "deep/frame1.png",
                fs::copy_options::overwrite_existing);
  const std::string base = filesConfig();
  return {
      {"YAML syntax", base + "   threshold: 20\n", bad + ":9: ", "is not valid YAML"},
      {"unknown key", base + "    treshold: 20\n",
       bad + ":9: cameras[0].treshold: ", "unknown key \"treshold\" (did you mean threshold?)"},
      {"wrong type", base + "    threshold: high\n",
       bad + ":9: cameras[0].threshold: ", "must be a whole number from 1 to 255, got high"},
      {"negative cell size", replaced(base, "cell_size_m: 0.04", "cell_size_m: -0.04"),
       bad + ":1: map.cell_size_m: ", "is -0.04; it must be > 0 m"},
      {"threshold over 255", replaced(base, "threshold: 25", "threshold: 300"),
       bad + ":2: fusion.threshold: ", "is 300; it must be from 1 to 255"},
      {"map over 8192 cells", replaced(base, "width: 30", "width: 8193"),
       bad + ":1: map.width: ", "is 8193; it must be from 1 to 8192"},
      {"zero cameras", base.substr(0, base.find("cameras:")) + "cameras: []\n",
       bad + ":4: cameras: ", "is empty; list at least one camera"},
      {"two cameras with one name", base + base.substr(base.find("  - name: down")),
       bad + ":9: cameras[1].name: ", "camera name \"down\" is used on lines 5 and 9"},
      {"missing config file", "", site.path("absent.yaml") + ": ",
       "cannot read config file: No such file or directory", "absent.yaml"},
      {"config file a folder", "", site.path("frames") + ": ",
       "cannot read config file: Is a directory", "frames"},
      {"calibration attribute missing", filesConfig("", "frames", "nofocal.xml"),
       site.path("nofocal.xml") + ":4: Intrinsic.focal: ", "is missing"},
      {"calibration NaN", filesConfig("", "frames", "nan.xml"),
       site.path("nan.xml") + ":4: Intrinsic.kappa1: ", "must be a finite number"},
      {"calibration infinity", filesConfig("", "frames", "inf.yml"),
       site.path("inf.yml") + ":12: tvec: ", "every value must be a finite number"},
      {"zero focal length (Tsai)", filesConfig("", "frames", "zerofocal.xml"),
       site.path("zerofocal.xml") + ":4: Intrinsic.focal: ", "the focal length must be > 0"},
      {"zero focal length (OpenCV)", filesConfig("", "frames", "zerofocal.yml"),
       site.path("zerofocal.yml") + ":5: camera_matrix: ",
       "has fx = 0, fy = 0; both focal lengths (in pixels) must be > 0"},
      {"background of another size", filesConfig("", "frames", "down.xml", "small.png"),
       bad + ":8: cameras[0].background: ", "is 50x50 but camera 'down' delivers 100x100"},
      {"floor mask of another size", base + "    floor_mask: small.png\n",
       bad + ":9: cameras[0].floor_mask: ", "is 50x50 but camera 'down' delivers 100x100"},
      {"background truncated (PNG)", filesConfig("", "frames", "down.xml", "truncated.png"),
       bad + ":8: cameras[0].background: ", "cannot decode image " + site.path("truncated.png")},
      {"background truncated (JPEG)", filesConfig("", "frames", "down.xml", "truncated.jpg"),
       bad + ":8: cameras[0].background: ", "ends before its end-of-image marker"},
      {"background not a picture", filesConfig("", "frames", "down.xml", "notes.png"),
       bad + ":8: cameras[0].background: ", "not an image format OpenCV reads"},
      {"background missing", filesConfig("", "frames", "down.xml", "absent.png"),
       bad + ":8: cameras[0].background: ",
       "cannot read image " + site.path("absent.png") + ": No such file or directory"},
      {"background 16-bit", filesConfig("", "frames", "down.xml", "deep.png"),
       bad + ":8: cameras[0].background: ", "has 16-bit samples"},
      {"background 32-bit float", filesConfig("", "frames", "down.xml", "float.tiff"),
       bad + ":8: cameras[0].background: ", "has 32-bit samples"},
      {"floor mask with two channels", base + "    floor_mask: two-channels.pam\n",
       bad + ":9: cameras[0].floor_mask: ", "has 2 channels"},
      {"first frame corrupt", filesConfig("", "corrupt"),
       bad + ":6: cameras[0].source: ", "cannot decode image " + site.path("corrupt/frame1.png")},
      {"first frame 16-bit", filesConfig("", "deep"),
       bad + ":6: cameras[0].source: ", "has 16-bit samples"},
  };
}

TEST(BadInputExitCodes, EveryBadConfigCalibrationOrImageIsExitTwoNamingTheFileAndPlace) {
  const Site site;
  for (const BadCase& bad : badCases(site)) {
    SCOPED_TRACE(bad.name);
    if (!bad.config.empty()) writeText(site.folder / bad.file, bad.config);
    const std::string config = site.path(bad.file);
    // The place, then on the same line what is wrong there.
    auto expectNamed = [&](const std::string& err, const std::string& program) {
      const std::size_t at = err.find(bad.where);
      const std::size_t what = at == std::string::npos ? at : err.find(bad.what, at);
      EXPECT_TRUE(what != std::string::npos && err.find('\n', at) > what)
          << program << " should say \"" << bad.where << "... " << bad.what << "\":\n"
          << err;
    };
    const auto check = runCommand({kOccmapd, "--check", "--config", config});
    EXPECT_EQ(check.exit_code, 2) << check.out << check.err;
    expectNamed(check.err, "occmapd --check");
    EXPECT_EQ(check.out, "") << "nothing may claim the config is valid";

    // As systemd starts it (no --check): the same refusal before any work, exit 2, which the
    // unit's RestartPreventExitStatus=2 keeps from being restarted in a loop.
    ChildProcess daemon({kOccmapd, "--config", config}, site.folder / "daemon");
    const std::optional<int> code = daemon.waitExit(20s);
    ASSERT_TRUE(code) << "occmapd started on a bad config and ran";
    EXPECT_EQ(*code, 2) << daemon.err();
    expectNamed(daemon.err(), "occmapd");

    const fs::path out = site.folder / "maps";
    const auto fuse = runCommand({kOccmap, "fuse", "--config", config, "--out", out.string()});
    EXPECT_EQ(fuse.exit_code, 2) << fuse.out << fuse.err;
    expectNamed(fuse.err, "occmap fuse");
    EXPECT_FALSE(fs::exists(out)) << "a refused run made its output folder";
  }
}

// Unreadable for want of permission: root reads every file, so the daemon is run as nobody then.
TEST(BadInputExitCodes, AConfigFileWithoutReadPermissionIsExitTwoSayingSo) {
  const Site site;
  const fs::path config = site.folder / "private.yaml";
  writeText(config, filesConfig());
  fs::permissions(config, fs::perms::owner_read | fs::perms::owner_write);
  std::vector<std::string> command = {kOccmapd, "--check", "--config", config.string()};
  if (::geteuid() == 0) {
    if (runCommand({"sh", "-c", "command -v setpriv"}).exit_code != 0) {
      GTEST_SKIP() << "running as root without setpriv (util-linux) to become another user";
    }
    // As nobody, whose view of the folder is that of any other user. The clone may be where
    // nobody cannot go (root's home, mode 700): occmapd, and the sanitizer's suppressions it
    // reads at start (TSAN_OPTIONS), are copied into the test's folder first, so that only the
    // config is out of nobody's reach.
    fs::permissions(site.folder.path(), fs::perms::others_exec, fs::perm_options::add);
    const fs::path occmapd = site.folder / "occmapd";
    fs::copy_file(kOccmapd, occmapd);
    command[0] = occmapd.string();
    std::string tsan_options = std::getenv("TSAN_OPTIONS") ? std::getenv("TSAN_OPTIONS") : "";
    if (const auto at = tsan_options.find("suppressions="); at != std::string::npos) {
      const auto from = at + std::string("suppressions=").size();
      const auto to = tsan_options.find(':', from);
      const fs::path suppressions = site.folder / "tsan.supp";
      fs::copy_file(tsan_options.substr(from, to - from), suppressions);
      fs::permissions(suppressions, fs::perms::others_read, fs::perm_options::add);
      tsan_options.replace(from, to == std::string::npos ? std::string::npos : to - from,
                           suppressions.string());
      command.insert(command.begin(), {"env", "TSAN_OPTIONS=" + tsan_options});
    }
    command.insert(command.begin(),
                   {"setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups", "--"});
  }
  const auto result = runCommand(command);
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
  EXPECT_NE(result.err.find(config.string() + ": cannot read config file: Permission denied"),
            std::string::npos)
      << result.err;
}

// ----------------------------------------------------------------------------------------------
// Bad frames at run time: dropped, counted, and the camera goes on

// What a subscriber in the pipeline's process hears: the newest status and how many maps.
struct Heard {
  std::mutex mutex;
  std::optional<occmap::status_t> status;
  std::size_t maps = 0;
  std::size_t maps_with_free_cells = 0;
  MapDecoder decoder;  // in the listener's thread only
  MemoryNetwork network;
  testing::BusListener listener{network};  // last: it stops before what its handlers write goes
};

// Listens on `heard`'s network; the options the pipeline under test runs with.
PipelineOptions listenTo(Heard& heard) {
  PipelineOptions options;
  options.status_period = 200ms;
  heard.listener.subscribe("OCCMAP_STATUS", [&heard](const std::uint8_t* data, std::size_t size) {
    occmap::status_t status;
    if (status.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) return;
    const std::lock_guard lock(heard.mutex);
    heard.status = status;
  });
  heard.listener.subscribe("OCCMAP_MAP", [&heard](const std::uint8_t* data, std::size_t size) {
    const DecodedMap& map = heard.decoder.decode(data, size);
    const std::lock_guard lock(heard.mutex);
    ++heard.maps;
    if (map.ok() && std::count(map.cells.begin(), map.cells.end(), 0) > 0) {
      ++heard.maps_with_free_cells;
    }
  });
  heard.listener.start();
  return options;
}

// Waits until `done` holds of what was heard, for at most a minute (sanitizers are slow).
bool waitFor(Heard& heard, const std::function<bool(const Heard&)>& done) {
  const auto give_up = std::chrono::steady_clock::now() + 60s;
  while (std::chrono::steady_clock::now() < give_up) {
    {
      const std::lock_guard lock(heard.mutex);
      if (done(heard)) return true;
    }
    std::this_thread::sleep_for(20ms);
  }
  return false;
}

// Frames of another size than the stream, from a source that hands them over as frames (as a
// camera could), and device errors: every second frame is 50x50, every fourth an error.
class OddFramesSource final : public FrameSource {
 public:
  OddFramesSource() : good_(100, 100, 120), small_(50, 50, 120) {}
  int width() const override { return 100; }
  int height() const override { return 100; }
  Status read(Frame& frame) override {
    const std::uint64_t n = next_++;
    if (n % 4 == 3) return fail("frame " + std::to_string(n) + ": the device reported an error");
    frame.image = (n % 4 == 1 ? small_ : good_).view();
    frame.sequence = n;
    frame.capture_time_us = hostTimeMicroseconds();
    return Status::kFrame;
  }

 private:
  Image good_;
  Image small_;
  std::uint64_t next_ = 0;
};

TEST(BadFrames, FramesOfAnotherSizeAndDeviceErrorsAreDroppedAndCountedInTheStatus) {
  Heard heard;
  Pipeline pipeline(testing::downwardRig("odd", std::make_unique<OddFramesSource>(), 0.0),
                    heard.network.connect(), listenTo(heard));
  pipeline.start();
  const bool counted = waitFor(heard, [](const Heard& h) {
    return h.status && h.status->cameras.size() == 1 && h.status->cameras[0].frames_dropped >= 10;
  });
  pipeline.stop();
  ASSERT_TRUE(counted) << "no status with the dropped frames counted";
  const std::lock_guard lock(heard.mutex);
  const occmap::camera_status_t& camera = heard.status->cameras[0];
  // Half the frames are bad; the good half goes in (a read or two may be between the counts).
  EXPECT_NEAR(static_cast<double>(camera.frames_in), static_cast<double>(camera.frames_dropped), 3)
      << "frames in " << camera.frames_in << ", dropped " << camera.frames_dropped;
  EXPECT_EQ(camera.state, static_cast<std::int8_t>(CameraState::kStreaming))
      << "a camera with bad frames among good ones is not down";
  EXPECT_EQ(camera.last_error, "a frame of 50x50 instead of 100x100");
  EXPECT_GE(pipeline.framesDropped(), 10u);
  EXPECT_GT(heard.maps_with_free_cells, 5u) << "the good frames still make maps";
}

// A files:// camera with a picture of another size and a corrupt one among its images: the
// daemon drops and counts them, says so in the log, and streams on from the good ones.
TEST(BadFrames, TheDaemonDropsBadImagesFromAFilesSourceCountsThemAndStreamsOn) {
  const Site site;
  site.makeMixedImages();

  // In process first, where the status can be read field by field.
  const Config config = parseConfig(filesConfig("    fps: 60\n", "mixed"), site.path("mixed.yaml"));
  Rig rig = Rig::open(config);
  std::vector<CarveTable> tables = rig.buildTables(0.0);
  Heard heard;
  {
    Pipeline pipeline(PreparedRig{std::move(rig), std::move(tables), 0.0}, heard.network.connect(),
                      listenTo(heard));
    pipeline.start();
    const bool counted = waitFor(heard, [](const Heard& h) {
      return h.status && h.status->cameras[0].frames_dropped >= 8 &&
             h.status->cameras[0].frames_in >= 8;
    });
    pipeline.stop();
    ASSERT_TRUE(counted) << "the good images after a bad one should go on coming in";
  }
  {
    const std::lock_guard lock(heard.mutex);
    const occmap::camera_status_t& camera = heard.status->cameras[0];
    EXPECT_EQ(camera.state, static_cast<std::int8_t>(CameraState::kStreaming));
    EXPECT_EQ(camera.last_error, "image " + site.path("mixed/frame2.png") +
                                     " is 50x50, but this camera's first image is 100x100");
  }

  // occmapd: the journal line, and the counts in sd_notify's STATUS=.
  const fs::path file = site.folder / "mixed.yaml";
  writeText(file, filesConfig("", "mixed"));
  NotifyListener systemd(site.folder / "notify");
  ChildProcess daemon({kOccmapd, "--config", file.string()}, site.folder / "daemon",
                      {{"NOTIFY_SOCKET", systemd.path().string()}, {"WATCHDOG_USEC", "2000000"}});
  ASSERT_TRUE(systemd.collect(testing::eventually(20s), "READY=1")) << daemon.err();
  systemd.collect(2500ms, "frames dropped");
  std::string status;
  const auto give_up = std::chrono::steady_clock::now() + 30s;
  while (std::chrono::steady_clock::now() < give_up) {
    for (const auto& message : systemd.messages()) {
      if (message.text.starts_with("STATUS=")) status = message.text;
    }
    if (status.find("; 0 frames dropped") == std::string::npos &&
        status.find("frames dropped") != std::string::npos) {
      break;
    }
    systemd.collect(500ms);
  }
  EXPECT_NE(status.find("1 of 1 cameras streaming"), std::string::npos) << status;
  EXPECT_EQ(status.find("; 0 frames dropped"), std::string::npos) << status;
  const std::size_t pings = systemd.count("WATCHDOG=1");
  systemd.collect(1500ms);
  EXPECT_GT(systemd.count("WATCHDOG=1"), pings) << "fusion goes on";
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.waitExit(testing::eventually(5s)), 0) << daemon.err();
  const std::string log = daemon.err();
  EXPECT_NE(log.find("warning: camera down: image " + site.path("mixed/frame2.png") +
                     " is 50x50, but this camera's first image is 100x100, dropped"),
            std::string::npos)
      << log;
  EXPECT_EQ(log.find("camera down is down"), std::string::npos)
      << "the camera must not stall on its bad image:\n"
      << log;
}

// ----------------------------------------------------------------------------------------------
// A camera whose floor is behind it: a warning naming it, an empty table, the others go on

TEST(FloorBehindTheCamera, IsAWarningAndAnEmptyTableAndTheOtherCamerasMakeTheMap) {
  const Site site;
  const std::string text =
      "map: {origin_m: [-0.62, -1.87], cell_size_m: 0.04, width: 256, height: 256}\n"
      "fusion: {threshold: 20, column_height_m: 0.3}\n"
      "transport: {lcm_url: \"memq://\"}\n"
      "cameras:\n"
      "  - {name: c0, source: \"sim://room/c0\"}\n"
      "  - {name: c1, source: \"sim://room/c1\"}\n"
      "  - {name: up, source: \"files://frames/*.png\", calibration: up.xml,\n"
      "     background: background.png}\n";
  const fs::path file = site.folder / "up.yaml";
  writeText(file, text);

  // The rig: an empty table and a warning that says which camera and why.
  Rig rig = Rig::open(loadConfig(file));
  std::vector<CarveTable> tables = rig.buildTables(0.3);
  ASSERT_EQ(tables.size(), 3u);
  EXPECT_EQ(tables[2].cellsInView(), 0u);
  EXPECT_EQ(tables[2].entries(), 0u);
  EXPECT_GT(tables[0].cellsInView(), 1000u);
  ASSERT_EQ(rig.warnings().size(), 1u);
  EXPECT_NE(rig.warnings()[0].find("camera 'up' sees no cell of the map"), std::string::npos)
      << rig.warnings()[0];
  EXPECT_NE(rig.warnings()[0].find("the floor is behind the camera"), std::string::npos)
      << rig.warnings()[0];

  // The pipeline runs with it: maps keep coming, carved by the other two.
  Heard heard;
  {
    Pipeline pipeline(PreparedRig{std::move(rig), std::move(tables), 0.3}, heard.network.connect(),
                      listenTo(heard));
    pipeline.start();
    EXPECT_TRUE(waitFor(heard, [](const Heard& h) { return h.maps_with_free_cells >= 10; }));
    pipeline.stop();
  }
  {
    const std::lock_guard lock(heard.mutex);
    ASSERT_TRUE(heard.status);
    EXPECT_EQ(heard.status->cameras[2].state, static_cast<std::int8_t>(CameraState::kStreaming));
  }

  // occmapd says it as a warning and runs: ready, three cameras streaming, the watchdog fed.
  NotifyListener systemd(site.folder / "notify");
  ChildProcess daemon({kOccmapd, "--config", file.string()}, site.folder / "daemon",
                      {{"NOTIFY_SOCKET", systemd.path().string()}, {"WATCHDOG_USEC", "2000000"}});
  ASSERT_TRUE(systemd.collect(testing::eventually(30s), "READY=1")) << daemon.err();
  EXPECT_TRUE(systemd.collect(testing::eventually(10s), "3 of 3 cameras streaming"))
      << daemon.err();
  const std::size_t pings = systemd.count("WATCHDOG=1");
  systemd.collect(1500ms);
  EXPECT_GT(systemd.count("WATCHDOG=1"), pings);
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.waitExit(testing::eventually(5s)), 0) << daemon.err();
  EXPECT_NE(daemon.err().find("warning: camera 'up' sees no cell of the map"), std::string::npos)
      << daemon.err();

  // occmap fuse likewise: the warning, and the maps of the camera that does see the floor.
  const std::string pair =
      filesConfig() + "  - {name: up, source: \"files://frames/*.png\", calibration: up.xml,\n" +
      "     background: background.png}\n";
  writeText(site.folder / "pair.yaml", pair);
  const auto fuse = runCommand({kOccmap, "fuse", "--config", site.path("pair.yaml"), "--out",
                                (site.folder / "maps").string()});
  EXPECT_EQ(fuse.exit_code, 0) << fuse.err;
  EXPECT_NE(fuse.err.find("occmap fuse: warning: camera 'up' sees no cell of the map"),
            std::string::npos)
      << fuse.err;
  EXPECT_NE(fuse.out.find("wrote 3 maps"), std::string::npos) << fuse.out;
  const cv::Mat first =
      cv::imread((site.folder / "maps/map_000000.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(first.empty());
  EXPECT_EQ(first.at<std::uint8_t>(15, 15), 0) << "the downward camera still clears the floor";
}

// MultiviewX's calibration: the downward camera's OpenCV intrinsics and its extrinsics in two XML
// files, the extrinsics made in Unity's left-handed world, so that read as OpenCV's right-handed
// frame every floor point lies at negative depth. The warning says to add world_frame:
// left-handed; with it, the camera sees the map as its right-handed twin does.
TEST(FloorBehindTheCamera, ALeftHandedCalibrationIsNamedAndWorldFrameLeftHandedSeesTheFloor) {
  const Site site;
  // The intrinsics of kDownwardYaml as cv::FileStorage writes them, without the image size (it is
  // the stream's, 100 x 100).
  {
    cv::FileStorage storage(site.path("intr.xml"), cv::FileStorage::WRITE);
    storage << "camera_matrix" << (cv::Mat_<double>(3, 3) << 200, 0, 49.5, 0, 200, 49.5, 0, 0, 1)
            << "distortion_coefficients" << cv::Mat::zeros(1, 5, CV_64F);
  }
  // The downward camera (R = Rx(pi), t = (0, 0, 2)) in a left-handed world with its frame
  // mirrored too: R' = -R diag(1, 1, -1) = Ry(pi), t' = -t, so that each floor point's camera
  // coordinates are the negated right-handed ones, at depth -2 m. WILDTRACK's and MultiviewX's
  // layout: each vector as numbers between blanks.
  writeText(site.folder / "extr.xml",
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n"
            "<rvec>0. 3.141592653589793 0.</rvec>\n<tvec>0. 0. -2.</tvec>\n"
            "</opencv_storage>\n");
  const std::string calibration = "{intrinsics: intr.xml, extrinsics: extr.xml}";
  writeText(site.folder / "right.yaml", filesConfig("", "frames", calibration));
  writeText(site.folder / "left.yaml",
            filesConfig("    world_frame: left-handed\n", "frames", calibration));
  writeText(site.folder / "twin.yaml", filesConfig("", "frames", "down.yml"));

  // Read as right-handed: an empty table, and the warning names the likely cause and the fix.
  Rig right = Rig::open(loadConfig(site.folder / "right.yaml"));
  const std::vector<CarveTable> right_tables = right.buildTables(0.0);
  ASSERT_EQ(right_tables.size(), 1u);
  EXPECT_EQ(right_tables[0].cellsInView(), 0u);
  ASSERT_EQ(right.warnings().size(), 1u);
  const std::string& warning = right.warnings()[0];
  EXPECT_NE(warning.find("camera 'down' sees no cell of the map"), std::string::npos) << warning;
  EXPECT_NE(warning.find("the map's floor lies behind the camera (negative depth)"),
            std::string::npos)
      << warning;
  EXPECT_NE(warning.find("left-handed world frame"), std::string::npos) << warning;
  EXPECT_NE(warning.find("add world_frame: left-handed"), std::string::npos) << warning;
  // Not the message for a camera that is merely turned away.
  EXPECT_EQ(warning.find("check the rotation"), std::string::npos) << warning;

  // With world_frame: left-handed: no warning, and the cells in view of the right-handed twin
  // (kDownwardYaml, the same camera in one YAML file).
  Rig left = Rig::open(loadConfig(site.folder / "left.yaml"));
  const std::vector<CarveTable> left_tables = left.buildTables(0.0);
  ASSERT_EQ(left_tables.size(), 1u);
  EXPECT_TRUE(left.warnings().empty()) << left.warnings()[0];
  Rig twin = Rig::open(loadConfig(site.folder / "twin.yaml"));
  const std::vector<CarveTable> twin_tables = twin.buildTables(0.0);
  ASSERT_EQ(twin_tables.size(), 1u);
  EXPECT_TRUE(twin.warnings().empty());
  EXPECT_GT(twin_tables[0].cellsInView(), 400u);  // about 25 x 25 cells: 1 m square of 1.2 m
  EXPECT_EQ(left_tables[0].cellsInView(), twin_tables[0].cellsInView());
  EXPECT_EQ(left_tables[0].entries(), twin_tables[0].entries());
}

// MultiviewX's cameras look across the floor, past the horizon: read as right-handed, their rays
// above the horizon meet the floor somewhere (the camera is then mirrored below it), so "sees
// the floor" alone cannot tell a left-handed calibration from a wrong origin_m. The map seen
// mirrored does.
TEST(FloorBehindTheCamera, ALeftHandedCameraThatSeesTheHorizonIsNamedToo) {
  const Site site;
  {
    cv::FileStorage storage(site.path("intr.xml"), cv::FileStorage::WRITE);
    storage << "camera_matrix" << (cv::Mat_<double>(3, 3) << 200, 0, 49.5, 0, 200, 49.5, 0, 0, 1)
            << "distortion_coefficients" << cv::Mat::zeros(1, 5, CV_64F);
  }
  // 2 m up, 5.5 m south of the map, looking north 12 degrees down: the image's top row (14
  // degrees above the axis) is above the horizon, the map (18 to 22 degrees down) in view.
  const double down = 12.0 * M_PI / 180.0;
  Eigen::Matrix3d r;  // world to camera: rows are the camera's right, down and forward
  r << 1, 0, 0, 0, -std::sin(down), -std::cos(down), 0, std::cos(down), -std::sin(down);
  const Eigen::Vector3d t = -r * Eigen::Vector3d(0.0, -5.5, 2.0);
  // The same camera in a left-handed world, its frame mirrored: R' = -R diag(1, 1, -1), t' = -t.
  const Eigen::Matrix3d left = -r * Eigen::Vector3d(1, 1, -1).asDiagonal();
  const Eigen::AngleAxisd turn(left);
  const Eigen::Vector3d rvec = turn.angle() * turn.axis();
  writeText(site.folder / "extr.xml",
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n<rvec>" + std::to_string(rvec.x()) + " " +
                std::to_string(rvec.y()) + " " + std::to_string(rvec.z()) + "</rvec>\n<tvec>" +
                std::to_string(-t.x()) + " " + std::to_string(-t.y()) + " " +
                std::to_string(-t.z()) + "</tvec>\n</opencv_storage>\n");
  const std::string calibration = "{intrinsics: intr.xml, extrinsics: extr.xml}";
  writeText(site.folder / "right.yaml", filesConfig("", "frames", calibration));
  writeText(site.folder / "left.yaml",
            filesConfig("    world_frame: left-handed\n", "frames", calibration));

  Rig right = Rig::open(loadConfig(site.folder / "right.yaml"));
  ASSERT_EQ(right.buildTables(0.0).at(0).cellsInView(), 0u);
  ASSERT_EQ(right.warnings().size(), 1u);
  const std::string& warning = right.warnings()[0];
  EXPECT_NE(warning.find("add world_frame: left-handed"), std::string::npos) << warning;
  EXPECT_EQ(warning.find("origin_m"), std::string::npos) << warning;

  Rig mirrored = Rig::open(loadConfig(site.folder / "left.yaml"));
  EXPECT_GT(mirrored.buildTables(0.0).at(0).cellsInView(), 400u);
  EXPECT_TRUE(mirrored.warnings().empty()) << mirrored.warnings()[0];
}

// ----------------------------------------------------------------------------------------------
// A reload whose files are bad: refused, named, and the old config keeps running

// "4 of 4 cameras streaming; 5130 maps published; ..." (sd_notify's STATUS=) -> 5130, or -1.
long long mapsPublished(const std::string& status) {
  const std::size_t end = status.find(" maps published");
  const std::size_t start = status.rfind("; ", end);
  return end == std::string::npos || start == std::string::npos
             ? -1
             : std::atoll(status.c_str() + start + 2);
}

TEST(ReloadWithBadFiles, IsRefusedNamingTheFileAndTheRunningConfigStays) {
  const Site site;
  const fs::path file = site.folder / "room.yaml";
  writeText(file, testing::simRoomConfig());
  NotifyListener systemd(site.folder / "notify");
  ChildProcess daemon({kOccmapd, "--config", file.string()}, site.folder / "daemon",
                      {{"NOTIFY_SOCKET", systemd.path().string()}, {"WATCHDOG_USEC", "2000000"}});
  ASSERT_TRUE(systemd.collect(testing::eventually(20s), "READY=1")) << daemon.err();
  ASSERT_TRUE(systemd.collect(5s, "STATUS=")) << daemon.err();
  const long long published_before = mapsPublished(systemd.messages().back().text);

  // The new config has three cameras, one of them with a corrupt background: the four of the
  // running config must stay.
  std::string three = testing::simRoomConfig();
  three = three.substr(0, three.find("  - {name: c2"));
  // Lines 7 to 10, after the first two sim cameras.
  three += "  - name: files\n    source: \"files://" + site.path("frames") + "/*.png\"\n" +
           "    calibration: " + site.path("down.xml") + "\n" +
           "    background: " + site.path("truncated.png") + "\n";
  writeText(file, three);
  const auto refusedWith = [&](const std::string& text) {
    return daemon.err().find("reload refused, the running config stays: " + text) !=
           std::string::npos;
  };
  daemon.signal(SIGHUP);
  ASSERT_TRUE(systemd.collect(testing::eventually(20s), "READY=1")) << daemon.err();
  EXPECT_TRUE(refusedWith(file.string() + ":10: cameras[2].background: cannot decode image " +
                          site.path("truncated.png")))
      << daemon.err();
  // The next STATUS= (one every 2 s) is the running config's: its four cameras.
  ASSERT_TRUE(systemd.collect(5s, "STATUS=")) << daemon.err();
  EXPECT_NE(systemd.messages().back().text.find("4 of 4 cameras streaming"), std::string::npos)
      << systemd.messages().back().text;
  // The same pipeline went on: its count of maps carried on, it did not start again from 0.
  EXPECT_GT(mapsPublished(systemd.messages().back().text), published_before)
      << systemd.messages().back().text;

  // The config file gone altogether: the same.
  fs::remove(file);
  daemon.signal(SIGHUP);
  ASSERT_TRUE(systemd.collect(testing::eventually(20s), "READY=1")) << daemon.err();
  EXPECT_TRUE(refusedWith(file.string() + ": cannot read config file: No such file or directory"))
      << daemon.err();
  const std::size_t pings = systemd.count("WATCHDOG=1");
  systemd.collect(1500ms);
  EXPECT_GT(systemd.count("WATCHDOG=1"), pings) << "fusion goes on with the old config";
  EXPECT_TRUE(daemon.running());
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.waitExit(testing::eventually(5s)), 0) << daemon.err();
}

}  // namespace
}  // namespace occmap
