// The Java side of the LCM types, for lcm-spy: the jar the build makes holds a class for every
// message type, lcm-spy's type database finds each by the fingerprint of a message the C++ code
// encoded and decodes it to the same values, and the build's lcm-spy wrapper starts and sees them.
#include <gtest/gtest.h>
#include <occmap/status_request_t.hpp>
#include <occmap/status_t.hpp>
#include <occmap/tracks_t.hpp>
#include <occmap/zones_t.hpp>

#include "command_runner.h"
#include "map_scenes.h"
#include "network_namespace.h"
#include "temporary_folder.h"
#include "transport/map_codec.h"

namespace occmap {
namespace {

using testing::runCommand;
using testing::TemporaryFolder;

const std::string kJar = OCCMAP_LCMTYPES_JAR;  // "" when CMake found no JDK or no lcm.jar
const std::string kLcmJar = OCCMAP_LCM_JAR;

template <typename Message>
void writeMessage(const std::filesystem::path& file, const Message& message) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(message.getEncodedSize()));
  ASSERT_EQ(message.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

class LcmTypesJava : public ::testing::Test {
 protected:
  void SetUp() override {
    if (kJar.empty()) {
      GTEST_SKIP() << "no occmap_lcmtypes.jar: CMake found no JDK or no " << kLcmJar
                   << " (Debian: apt install openjdk-17-jdk-headless liblcm-java), see its "
                      "configure message";
    }
    ASSERT_TRUE(std::filesystem::exists(kJar)) << kJar << " was not built";
  }
};

TEST_F(LcmTypesJava, LcmSpysTypeDatabaseDecodesWhatCppEncoded) {
  TemporaryFolder folder;
  const MapGeometry geometry{-0.5, -1.5, 0.02, 64, 48};
  MapFrame frame(geometry, 2);
  frame.utime = 1'700'000'000'123'456;
  testing::fillScene(frame, 42);
  MapEncoder encoder(geometry, testing::sceneCameraNames(2), MapEncoding::kZstd);
  const auto map = encoder.encode(frame);
  std::ofstream(folder / "map", std::ios::binary)
      .write(reinterpret_cast<const char*>(map.data()), static_cast<std::streamsize>(map.size()));
  occmap::status_t status{};
  status.request_id = 77;
  status.hostname = "camera-pc";
  status.maps_per_s = 29.5;
  writeMessage(folder / "status", status);
  occmap::status_request_t request{};
  request.utime = 5;
  request.request_id = 1234567890123;
  writeMessage(folder / "request", request);
  occmap::camera_frame_t camera{};
  camera.name = "c7";
  camera.sequence = 9;
  writeMessage(folder / "camera", camera);
  // The messages beside the maps, whose parts are types of their own (zone_t, footprint_t,
  // track_t): the fingerprint covers them, so a jar without them would find no class.
  occmap::zones_t zones{};
  zones.utime = 1'700'000'000'123'456;
  zones.seq = 42;
  zones.hostname = "camera-pc";
  occmap::zone_t zone{};
  zone.name = "robot-cell";
  zone.state = occmap::zone_t::OCCUPIED;
  zone.corner_x_m = {0, 1, 1};
  zone.corner_y_m = {0, 0, 1};
  zone.num_corners = 3;
  zones.zones = {zone};
  zones.num_zones = 1;
  writeMessage(folder / "zones", zones);
  occmap::tracks_t tracks{};
  tracks.utime = 1'700'000'000'100'000;
  tracks.seq = 41;
  tracks.hostname = "camera-pc";
  tracks.footprints = {{1.5, 0.25, 0.2, 0.5, 1.75}};
  tracks.num_footprints = 1;
  tracks.tracks = {{4, 1.5, 0.25, 0.5, 0, 0.2, 3, 0}, {7, 0, 1, 0, 0, 0.2, 1, 0.1}};
  tracks.num_tracks = 2;
  writeMessage(folder / "tracks", tracks);

  const auto result = runCommand(
      {OCCMAP_JAVA, "-cp", kLcmJar + ":" + kJar, OCCMAP_SOURCE_DIR "/tests/java/LcmTypesCheck.java",
       (folder / "map").string(), (folder / "status").string(), (folder / "request").string(),
       (folder / "camera").string(), (folder / "zones").string(), (folder / "tracks").string()});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  for (const char* expected :
       {"occmap.map_frame_t utime=1700000000123456 seq=42 width=64 height=48 cell_size_m=0.02 "
        "origin_x_m=-0.5 origin_y_m=-1.5 encoding=1",
        "occmap.status_t utime=0 request_id=77 hostname=camera-pc",
        "occmap.status_request_t utime=5 request_id=1234567890123",
        "occmap.camera_frame_t name=c7 state=0 used=false sequence=9 capture_utime=0",
        "occmap.zones_t utime=1700000000123456 seq=42 hostname=camera-pc num_zones=1",
        "occmap.tracks_t utime=1700000000100000 seq=41 hostname=camera-pc num_footprints=1 "
        "num_tracks=2"}) {
    EXPECT_NE(result.out.find(expected), std::string::npos) << "no '" << expected << "' in\n"
                                                            << result.out;
  }
}

// Debian's /usr/bin/lcm-spy passes -Xincgc (Java 9 and later refuse to start) and -cp (which hides
// $CLASSPATH); the build's wrapper does neither. Without a display lcm-spy stops at its window,
// after it has listed the types it found.
TEST_F(LcmTypesJava, TheBuildsLcmSpyFindsTheTypes) {
  const std::string& problem = testing::enterPrivateNetwork();  // lcm-spy opens LCM's default URL
  if (!problem.empty()) GTEST_SKIP() << problem;
  const auto result = runCommand({"/usr/bin/env", "-u", "DISPLAY", "-u", "WAYLAND_DISPLAY",
                                  OCCMAP_BINARY_DIR "/lcmtypes/lcm-spy"});
  // Every type of lcmtypes/, as many as the build generated.
  const std::string found = "Found " + std::to_string(OCCMAP_LCM_TYPE_COUNT) + " LCM types";
  EXPECT_NE(result.out.find(found), std::string::npos) << result.out << result.err;
  EXPECT_EQ(result.err.find("Unrecognized option"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace occmap
