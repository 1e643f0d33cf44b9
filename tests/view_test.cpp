// `occmap view` and `occmap status` against a live publisher over LCM's UDP multicast, with the
// default URL, inside a network namespace of the test's own (tests/network_namespace.h).
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "child_process.h"
#include "command_runner.h"
#include "map_scenes.h"
#include "network_namespace.h"
#include "temporary_folder.h"
#include "timing.h"
#include "tools/footprint_pictures.h"
#include "transport/footprints_message.h"
#include "transport/lcm_bus.h"
#include "transport/map_codec.h"

namespace occmap {
namespace {

using namespace std::chrono_literals;
using testing::ChildProcess;
using testing::runCommand;
using testing::TemporaryFolder;

const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";
const std::string kPublisher = OCCMAP_BINARY_DIR "/tests/map_publisher";

class LiveLcm : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string& problem = testing::enterPrivateNetwork();
    if (!problem.empty()) GTEST_SKIP() << problem;
  }

  // Starts `occmap view` with `arguments` and waits until it listens.
  std::unique_ptr<ChildProcess> startView(std::vector<std::string> arguments) {
    arguments.insert(arguments.begin(), {kOccmap, "view"});
    auto view = std::make_unique<ChildProcess>(arguments, folder_ / "view");
    EXPECT_TRUE(view->waitForOutput("listening for maps", 10s))
        << "occmap view did not start listening:\n"
        << view->out() << view->err();
    return view;
  }

  // Runs the publisher to its end.
  void publish(std::vector<std::string> arguments) {
    arguments.insert(arguments.begin(), kPublisher);
    const auto result = runCommand(arguments);
    ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  }

  TemporaryFolder folder_;
};

int countVideoFrames(const std::string& file, int api) {
  cv::VideoCapture video(file, api);
  if (!video.isOpened()) return -1;
  int frames = 0;
  cv::Mat frame;
  while (video.read(frame)) {
    EXPECT_EQ(frame.cols, 512);
    EXPECT_EQ(frame.rows, 512);
    ++frames;
  }
  return frames;
}

// Ctrl-C is how a person stops a viewer without --count: it ends with the summary, exit 0.
TEST_F(LiveLcm, ViewStoppedWithCtrlCPrintsItsSummary) {
  auto view = startView({"--timeout", "20"});
  publish({"--count", "10", "--rate", "30", "--encoding", "zstd"});
  view->signal(SIGINT);
  const auto code = view->waitExit(testing::eventually(5s));
  ASSERT_TRUE(code) << "occmap view did not stop on SIGINT";
  EXPECT_EQ(*code, 0) << view->out() << view->err();
  // The publisher has sent all 10 when it returns, but the viewer may not have read the last
  // datagram off its socket yet when the signal comes (a busy machine): the summary counts what it
  // read, with none lost between.
  const std::string out = view->out();
  const std::size_t at = out.find("summary: received ");
  ASSERT_NE(at, std::string::npos) << out;
  const long received = std::atol(out.c_str() + at + std::strlen("summary: received "));
  EXPECT_GE(received, 1) << out;
  EXPECT_LE(received, 10) << out;
  EXPECT_NE(out.find(", lost 0 (0 seq gaps)", at), std::string::npos) << out;
  EXPECT_EQ(view->err().find("failed"), std::string::npos) << view->err();
}

TEST_F(LiveLcm, ViewReceivesEveryMapAndWritesThePictureAndTheVideo) {
  const std::string png = (folder_ / "last.png").string();
  const std::string avi = (folder_ / "maps.avi").string();
  auto view = startView({"--count", "60", "--png", png, "--video", avi, "--timeout", "20"});
  // 60 zstd maps of 512 x 512 cells at 30 Hz on the default URL and channel.
  publish({"--count", "60", "--rate", "30", "--encoding", "zstd"});
  const auto code = view->waitExit(20s);
  ASSERT_TRUE(code) << "occmap view did not stop after 60 maps:\n" << view->out() << view->err();
  const std::string out = view->out();
  ASSERT_EQ(*code, 0) << out << view->err();
  EXPECT_NE(out.find("summary: received 60 maps"), std::string::npos) << out;
  EXPECT_NE(out.find("lost 0 (0 seq gaps), undecodable 0"), std::string::npos) << out;
  EXPECT_NE(out.find("maps/s  latency mean"), std::string::npos) << "no per-second line:\n" << out;
  EXPECT_EQ(view->err(), "");

  // The last map (seq 59) as a floor plan, +y up: picture row 511 - r shows map row r, each cell
  // in its state's colour (the scale bar at the bottom left aside).
  const cv::Mat picture = cv::imread(png);
  ASSERT_FALSE(picture.empty()) << "no picture at " << png;
  ASSERT_EQ(picture.cols, 512);
  ASSERT_EQ(picture.rows, 512);
  MapFrame expected(MapGeometry{-0.5, -1.5, 0.02, 512, 512}, 4);
  testing::fillScene(expected, 59);
  const cv::Vec3b colours[] = {{245, 245, 245}, {35, 35, 35}, {170, 140, 120}};
  int wrong = 0;
  for (int row = 0; row < 512; ++row) {
    for (int column = 0; column < 512; ++column) {
      if (row < 40 && column < 200) continue;  // the scale bar
      const auto state = static_cast<std::size_t>(expected.map.at(row, column));
      wrong += picture.at<cv::Vec3b>(511 - row, column) != colours[state];
    }
  }
  EXPECT_EQ(wrong, 0) << "pixels of the picture that do not show their cell's state";

  // The video holds every map, readable by OpenCV's own reader and, where OpenCV has it, FFmpeg.
  EXPECT_EQ(countVideoFrames(avi, cv::CAP_OPENCV_MJPEG), 60);
  const int ffmpeg_frames = countVideoFrames(avi, cv::CAP_FFMPEG);
  if (ffmpeg_frames >= 0) {
    EXPECT_EQ(ffmpeg_frames, 60) << "FFmpeg reads another frame count";
  }
}

TEST_F(LiveLcm, ViewCountsLostAndUndecodableMaps) {
  auto view = startView({"--count", "26", "--timeout", "20"});
  // 30 sequence numbers, 4 of them never sent (two gaps), after 3 messages that are not maps.
  publish({"--count", "30", "--rate", "60", "--width", "200", "--height", "100", "--drop", "5",
           "--drop", "6", "--drop", "7", "--drop", "20", "--garbage", "3"});
  const auto code = view->waitExit(20s);
  ASSERT_TRUE(code) << view->out() << view->err();
  EXPECT_EQ(*code, 0) << view->out() << view->err();
  EXPECT_NE(view->out().find("received 26 maps"), std::string::npos) << view->out();
  EXPECT_NE(view->out().find("lost 4 (2 seq gaps), undecodable 3"), std::string::npos)
      << view->out();
  EXPECT_NE(view->err().find("not an occmap.map_frame_t"), std::string::npos) << view->err();
}

// Raw maps above 65 499 bytes travel in LCM fragments (LC03); a 256 x 256 raw map takes two.
TEST_F(LiveLcm, ViewReceivesRawMapsInFragments) {
  auto view = startView({"--count", "20", "--timeout", "20"});
  publish(
      {"--count", "20", "--rate", "20", "--encoding", "raw", "--width", "256", "--height", "256"});
  const auto code = view->waitExit(20s);
  ASSERT_TRUE(code) << view->out() << view->err();
  EXPECT_EQ(*code, 0) << view->out() << view->err();
  EXPECT_NE(view->out().find("received 20 maps"), std::string::npos) << view->out();
}

// occmapd's side of the bus from within the test: maps of the scene (tests/map_scenes.h) and the
// zones_t and tracks_t that follow them, built with the generated types, on the default URL and
// channels.
class FakeDaemon {
 public:
  static constexpr MapGeometry kGeometry{-0.5, -1.5, 0.02, 512, 512};

  FakeDaemon()
      : bus_("udpm://239.255.76.67:7667?ttl=0"),
        encoder_(kGeometry, testing::sceneCameraNames(4), MapEncoding::kZstd),
        frame_(kGeometry, 4) {}
  bool good() const { return bus_.good(); }

  // Map `seq` of the scene; returns its utime.
  std::int64_t publishMap(std::int64_t seq) {
    frame_.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                       std::chrono::system_clock::now().time_since_epoch())
                       .count();
    testing::fillScene(frame_, seq);
    EXPECT_TRUE(bus_.publish("OCCMAP_MAP", encoder_.encode(frame_)));
    return frame_.utime;
  }
  void publishZones(const occmap::zones_t& zones) { publish(zonesChannel("OCCMAP_MAP"), zones); }
  void publishTracks(const occmap::tracks_t& tracks) {
    publish(tracksChannel("OCCMAP_MAP"), tracks);
  }
  void publishBytes(const std::string& channel, const std::vector<std::uint8_t>& bytes) {
    EXPECT_TRUE(bus_.publish(channel, bytes));
  }

  template <typename Message>
  static std::vector<std::uint8_t> encoded(const Message& message) {
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(message.getEncodedSize()));
    EXPECT_EQ(message.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
              static_cast<int>(bytes.size()));
    return bytes;
  }

 private:
  template <typename Message>
  void publish(const std::string& channel, const Message& message) {
    publishBytes(channel, encoded(message));
  }

  LcmBus bus_;
  MapEncoder encoder_;
  MapFrame frame_;
};

// A square zone, 2 m a side, in the scene's room.
occmap::zones_t squareZone(std::int64_t seq, std::int64_t utime, std::int8_t state) {
  occmap::zone_t zone{};
  zone.name = "robot-cell";
  zone.state = state;
  zone.cells = 10000;
  zone.occupied_cells = state == occmap::zone_t::OCCUPIED ? 120 : 0;
  zone.corner_x_m = {1.0, 3.0, 3.0, 1.0};
  zone.corner_y_m = {1.0, 1.0, 3.0, 3.0};
  zone.num_corners = 4;
  occmap::zones_t zones{};
  zones.utime = utime;
  zones.seq = seq;
  zones.hostname = "test-host";
  zones.zones = {zone};
  zones.num_zones = 1;
  return zones;
}

// One person found and followed, walking towards +y at 0.5 m/s, outside the zone.
occmap::tracks_t onePerson(std::int64_t seq, std::int64_t utime) {
  occmap::tracks_t tracks{};
  tracks.utime = utime;
  tracks.seq = seq;
  tracks.hostname = "test-host";
  tracks.footprints = {occmap::footprint_t{4.5, 2.0, 0.25, 0.6, 1.75}};
  tracks.num_footprints = 1;
  occmap::track_t track{};
  track.id = 7;
  track.x_m = 4.5;
  track.y_m = 2.0;
  track.vx_m_s = 0.0;
  track.vy_m_s = 0.5;
  track.area_m2 = 0.25;
  track.age_s = 3.0;
  tracks.tracks = {track};
  tracks.num_tracks = 1;
  return tracks;
}

// Where a floor point lands in view's picture of a kGeometry map: +x right, +y up, from the
// map's origin at the bottom left, as many pixels a cell as the picture is wider than the map.
cv::Point pixelOf(const cv::Mat& picture, double x, double y) {
  const MapGeometry& g = FakeDaemon::kGeometry;
  const double scale = static_cast<double>(picture.cols) / g.width;
  return {static_cast<int>(std::lround((x - g.origin_x_m) / g.cell_size_m * scale)),
          static_cast<int>(std::lround((g.height - (y - g.origin_y_m) / g.cell_size_m) * scale))};
}

cv::Vec3b bgr(const cv::Scalar& colour) {
  return {static_cast<std::uint8_t>(colour[0]), static_cast<std::uint8_t>(colour[1]),
          static_cast<std::uint8_t>(colour[2])};
}

// Points along the middle three fifths of each edge of a zone's polygon, in the picture.
std::vector<cv::Point> alongEdges(const cv::Mat& picture, const occmap::zone_t& zone) {
  std::vector<cv::Point> points;
  for (std::size_t k = 0; k < zone.corner_x_m.size(); ++k) {
    const std::size_t next = (k + 1) % zone.corner_x_m.size();
    for (double t = 0.2; t <= 0.8; t += 0.05) {
      points.push_back(
          pixelOf(picture, zone.corner_x_m[k] + t * (zone.corner_x_m[next] - zone.corner_x_m[k]),
                  zone.corner_y_m[k] + t * (zone.corner_y_m[next] - zone.corner_y_m[k])));
    }
  }
  return points;
}

// Counted serially: cv::Mat::forEach runs on OpenCV's threads (a shared count there is a race).
int countPixels(const cv::Mat& picture, const cv::Scalar& colour) {
  const cv::Vec3b wanted = bgr(colour);
  int count = 0;
  for (int row = 0; row < picture.rows; ++row) {
    for (int column = 0; column < picture.cols; ++column) {
      count += picture.at<cv::Vec3b>(row, column) == wanted ? 1 : 0;
    }
  }
  return count;
}

// What a site watching occmapd sees: each map with its own zones (free on map 1, occupied on map
// 2, which the picture must show) and the newest tracks, which lag the maps (found on map 1, drawn
// on map 2); and the line each second saying them.
TEST_F(LiveLcm, ViewDrawsEachMapsZonesAndTheNewestTracks) {
  const std::string png = (folder_ / "last.png").string();
  auto view = startView({"--count", "3", "--png", png, "--timeout", "20"});
  FakeDaemon daemon;
  ASSERT_TRUE(daemon.good());
  std::int64_t utime = daemon.publishMap(0);
  daemon.publishZones(squareZone(0, utime, occmap::zone_t::FREE));
  daemon.publishTracks(onePerson(0, utime));
  EXPECT_TRUE(view->waitForOutput("lost 0  tracks 1  zones: robot-cell free", 5s))
      << "no line saying the track and the zone's state:\n"
      << view->out() << view->err();
  // As occmapd sends them: each map then its zones; the tracks after the map they were found on,
  // here too late for the next map's turn.
  utime = daemon.publishMap(1);
  daemon.publishZones(squareZone(1, utime, occmap::zone_t::FREE));
  daemon.publishTracks(onePerson(1, utime));
  utime = daemon.publishMap(2);
  const occmap::zones_t zones = squareZone(2, utime, occmap::zone_t::OCCUPIED);
  daemon.publishZones(zones);

  const auto code = view->waitExit(20s);
  ASSERT_TRUE(code) << "occmap view did not stop after 3 maps:\n" << view->out() << view->err();
  const std::string out = view->out();
  ASSERT_EQ(*code, 0) << out << view->err();
  EXPECT_EQ(view->err(), "");
  EXPECT_NE(out.find("summary: received 3 maps"), std::string::npos) << out;
  EXPECT_NE(out.find("; zones_t: received 3, undecodable 0; tracks_t: received 2, undecodable 0"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("(the last map, seq 2, as a floor plan: +y up; with its zones; with the "
                     "tracks found on map 1)"),
            std::string::npos)
      << out;

  const cv::Mat picture = cv::imread(png);
  ASSERT_FALSE(picture.empty()) << "no picture at " << png;
  ASSERT_NE(bgr(tools::kZoneOccupiedColour), bgr(tools::kZoneFreeColour));
  // The zone's outline in map 1's state: occupied, all along its edges; map 0's state nowhere.
  int wrong = 0;
  const std::vector<cv::Point> edges = alongEdges(picture, zones.zones[0]);
  for (const cv::Point& at : edges) {
    wrong += picture.at<cv::Vec3b>(at) != bgr(tools::kZoneOccupiedColour);
  }
  EXPECT_EQ(wrong, 0) << "of " << edges.size() << " points along the zone's edges, not in red";
  EXPECT_EQ(countPixels(picture, tools::kZoneFreeColour), 0) << "map 1's zones drawn on map 2";
  // The track: a dot at its place, an arrow along 1 s of its motion; its footprint a circle.
  const occmap::track_t track = onePerson(0, 0).tracks[0];
  const cv::Point at = pixelOf(picture, track.x_m, track.y_m);
  EXPECT_EQ(picture.at<cv::Vec3b>(at), bgr(tools::kTrackColour)) << "no track at " << at;
  // Three quarters along the arrow: past the dot and the footprint's circle.
  const double along_s = 0.75 * tools::kTrackArrowSeconds;
  const cv::Point on_arrow =
      pixelOf(picture, track.x_m + along_s * track.vx_m_s, track.y_m + along_s * track.vy_m_s);
  EXPECT_EQ(picture.at<cv::Vec3b>(on_arrow), bgr(tools::kTrackColour))
      << "no arrow through " << on_arrow;
  const cv::Point on_circle = at - cv::Point(tools::kFootprintRadiusPx, 0);
  EXPECT_EQ(picture.at<cv::Vec3b>(on_circle), bgr(tools::kFootprintColour))
      << "no footprint circle through " << on_circle;
}

// Bytes on the zones and tracks channels that are not a message are counted, and nothing of them
// is drawn.
TEST_F(LiveLcm, ViewCountsUndecodableZonesAndTracksAndDrawsNone) {
  const std::string png = (folder_ / "last.png").string();
  auto view = startView({"--count", "1", "--png", png, "--timeout", "20"});
  FakeDaemon daemon;
  ASSERT_TRUE(daemon.good());
  const std::int64_t utime = daemon.publishMap(0);
  // The zones of that very map, one byte short: the decoder refuses them.
  const occmap::zones_t zones = squareZone(0, utime, occmap::zone_t::OCCUPIED);
  std::vector<std::uint8_t> bytes = FakeDaemon::encoded(zones);
  bytes.pop_back();
  daemon.publishBytes(zonesChannel("OCCMAP_MAP"), bytes);
  daemon.publishBytes(tracksChannel("OCCMAP_MAP"), std::vector<std::uint8_t>(100, 7));

  const auto code = view->waitExit(20s);
  ASSERT_TRUE(code) << view->out() << view->err();
  const std::string out = view->out();
  ASSERT_EQ(*code, 0) << out << view->err();
  EXPECT_NE(out.find("; zones_t: received 0, undecodable 1; tracks_t: received 0, undecodable 1"),
            std::string::npos)
      << out;
  EXPECT_NE(view->err().find("an undecodable message on OCCMAP_MAP_ZONES"), std::string::npos)
      << view->err();
  EXPECT_NE(view->err().find("an undecodable message on OCCMAP_MAP_TRACKS"), std::string::npos)
      << view->err();
  const cv::Mat picture = cv::imread(png);
  ASSERT_FALSE(picture.empty()) << "no picture at " << png;
  for (const cv::Point& at : alongEdges(picture, zones.zones[0])) {
    ASSERT_NE(picture.at<cv::Vec3b>(at), bgr(tools::kZoneOccupiedColour)) << at;
  }
  EXPECT_EQ(countPixels(picture, tools::kZoneOccupiedColour), 0);
  EXPECT_EQ(countPixels(picture, tools::kTrackColour), 0);
}

TEST_F(LiveLcm, ViewExitsThreeWhenNoMapArrives) {
  const auto result = runCommand({kOccmap, "view", "--timeout", "1"});
  EXPECT_EQ(result.exit_code, 3) << result.out << result.err;
  EXPECT_NE(result.err.find("no map on OCCMAP_MAP at udpm://239.255.76.67:7667?ttl=0 within 1 s"),
            std::string::npos)
      << result.err;
  EXPECT_NE(result.out.find("summary: received 0 maps"), std::string::npos) << result.out;
}

TEST_F(LiveLcm, StatusExitsThreeWhenNobodyAnswers) {
  const auto start = std::chrono::steady_clock::now();
  const auto result = runCommand({kOccmap, "status", "--timeout", "1"});
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(result.exit_code, 3) << result.out << result.err;
  EXPECT_NE(result.err.find("no occmapd answered within 1 s (2 requests on "
                            "OCCMAP_STATUS_REQUEST at udpm://239.255.76.67:7667?ttl=0)"),
            std::string::npos)
      << result.err;
  EXPECT_EQ(result.out, "");
  EXPECT_LT(seconds, 3.0);
}

TEST_F(LiveLcm, StatusPrintsTheAnswerAsATableAndAsJson) {
  ChildProcess daemon({kPublisher, "--answer-status", "20"}, folder_ / "daemon");
  ASSERT_TRUE(daemon.waitForOutput("answering status requests", 10s)) << daemon.err();
  auto result = runCommand({kOccmap, "status", "--timeout", "5"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  const std::string& table = result.out;
  for (const char* expected :
       {"occmapd on test-host (config /etc/occmap/test.yaml)", "state running, up 1:02:03",
        "maps published 111683 (30.0 maps/s), publish errors 2",
        "fusion per frame set: p50 3.25 ms, p99 7.50 ms",
        "camera       state       frames in   dropped     fps  last capture",
        "c0           streaming      111700         0    30.0  12 ms ago",
        "door-camera  down           106700         3     0.0  4.2 s ago"}) {
    EXPECT_NE(table.find(expected), std::string::npos) << "no '" << expected << "' in\n" << table;
  }
  // The publisher answers as a daemon from before control requests does: a status_t and no
  // control_status_t. That is the whole table, without a control section.
  EXPECT_EQ(table.find("control requests"), std::string::npos) << table;
  result = runCommand({kOccmap, "status", "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  for (const char* expected :
       {"{\"utime\":", "\"hostname\":\"test-host\"", "\"state_name\":\"running\"",
        "\"maps_published\":111683", "\"cameras\":[{\"name\":\"c0\",\"source\":\"sim://room/c0\"",
        "\"state_name\":\"down\"", "\"fusion_p99_ms\":7.5,"}) {
    EXPECT_NE(result.out.find(expected), std::string::npos)
        << "no " << expected << " in " << result.out;
  }
  EXPECT_EQ(std::count(result.out.begin(), result.out.end(), '\n'), 1) << result.out;
  EXPECT_EQ(result.out.find("control_"), std::string::npos) << result.out;
  const nlohmann::json status = nlohmann::json::parse(result.out, nullptr, false);
  ASSERT_TRUE(status.is_object()) << "not one JSON object: " << result.out;
  EXPECT_EQ(status["cameras"].size(), 2u) << result.out;
  EXPECT_EQ(status["cameras"][1]["name"], "door-camera") << result.out;
}

TEST(OccmapViewArguments, RefusesAVideoThatIsNotAvi) {
  // memq:// (in-process) so that nothing could reach a network even if the arguments were taken.
  const auto result = runCommand({kOccmap, "view", "--lcm-url", "memq://", "--video", "maps.mp4"});
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
  EXPECT_NE(result.err.find("maps.mp4: --video: the video is Motion JPEG in an AVI file"),
            std::string::npos)
      << result.err;
  EXPECT_EQ(runCommand({kOccmap, "view", "--lcm-url", "memq://", "--count", "0"}).exit_code, 2);
  EXPECT_EQ(runCommand({kOccmap, "status", "--lcm-url", "memq://", "--timeout", "-1"}).exit_code,
            2);
}

}  // namespace
}  // namespace occmap
