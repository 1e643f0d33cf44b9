// Control requests (docs/control.md) to the live pipeline in process (memq://): off by default and
// then only counted; when enabled, a signed set_threshold changes the maps at once and a
// recapture_background makes the camera's next frames its background; forged, damaged, replayed
// and stale requests are ignored and counted; the key file must be the service's alone. Also the
// parts on their own: the replay window, the background handover, the frame recorder, the config.
#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <occmap/control_reply_t.hpp>
#include <occmap/control_request_t.hpp>
#include <occmap/control_status_t.hpp>
#include <occmap/status_request_t.hpp>
#include <occmap/status_t.hpp>
#include <sys/stat.h>

#include "allocation_counter.h"
#include "bus_listener.h"
#include "capture/image_file.h"
#include "command_runner.h"
#include "config/config.h"
#include "config/control_key_file.h"
#include "config/input_error.h"
#include "core/background_handover.h"
#include "core/frame_recorder.h"
#include "daemon/pipeline.h"
#include "sim_room_config.h"
#include "temporary_folder.h"
#include "transport/control_message.h"
#include "transport/lcm_bus.h"
#include "transport/map_codec.h"
#include "transport/memory_bus.h"
#include "transport/replay_window.h"
#include "transport/status_message.h"

namespace occmap {
namespace {

using namespace std::chrono_literals;
using testing::TemporaryFolder;

std::int64_t nowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::vector<std::uint8_t> signedRequest(const ControlKey& key, std::string_view command,
                                        const std::string& camera, int value,
                                        std::optional<std::int64_t> utime = std::nullopt) {
  static std::atomic<std::int64_t> next{1};
  occmap::control_request_t request{};
  request.request_id = next++;
  request.utime = utime.value_or(nowUtime());
  request.nonce = randomControlNonce();
  request.command = std::string(command);
  request.camera = camera;
  request.value = value;
  return encodeControlRequest(key, request);
}

std::int64_t requestIdOf(const std::vector<std::uint8_t>& bytes) {
  return parseControlRequest(bytes.data(), bytes.size())->request_id;
}

// The daemon's pipeline on the simulated room, with what a program on the network would see and
// send: its maps, its status, the control replies (checked under the key), and a way to publish.
class Daemon {
 public:
  // `control` is the config's control section ("" for none: the default, off).
  // With `black_backgrounds`, each camera's config background is a black picture instead of its
  // scene's empty room, so that (before a recapture) nearly every pixel differs from it.
  explicit Daemon(const std::string& control, bool with_state_directory = false,
                  bool black_backgrounds = false) {
    writeNewControlKey(folder_ / "control.key");
    key_ = loadControlKey(folder_ / "control.key", {"control.key", 0, ""});
    // Against a black background no change of light explains a view (core/lighting_model.h), and
    // the light's model would leave every camera out; this test is about the recapture itself.
    std::string cameras =
        testing::simRoomConfig("memq://", black_backgrounds ? ", lighting: {adapt: false}" : "");
    if (black_backgrounds) {
      const Rig scene_rig = Rig::open(loadConfig(folder_.write("room.yaml", cameras)));
      cameras = cameras.substr(0, cameras.find("cameras:\n")) + "cameras:\n";
      for (const RigCamera& camera : scene_rig.cameras()) {
        std::string error;
        const auto file = folder_ / ("black-" + camera.name + ".png");
        EXPECT_TRUE(writeGreyPng(
            file, Image(camera.background.width(), camera.background.height(), 0), error))
            << error;
        cameras += "  - {name: " + camera.name + ", source: \"sim://room/" + camera.name +
                   "\", background: " + file.filename().string() + "}\n";
      }
    }
    const auto file = folder_.write("room.yaml", cameras + control);
    const Config config = loadConfig(file);
    PipelineOptions options;
    if (with_state_directory) {
      std::filesystem::create_directories(folder_ / "state");
      options.state_directory = folder_ / "state";
    }
    listener_.subscribe("OCCMAP_MAP", [this](const std::uint8_t* data, std::size_t size) {
      if (quiet_.load()) return;
      const DecodedMap& map = decoder_.decode(data, size);
      if (!map.ok()) return;
      std::lock_guard lock(mutex_);
      latest_cells_ = map.cells;
      ++maps_;
    });
    listener_.subscribe("OCCMAP_STATUS", [this](const std::uint8_t* data, std::size_t size) {
      if (quiet_.load()) return;
      std::optional<occmap::status_t> status = decodeStatus(data, size);
      std::lock_guard lock(mutex_);
      if (status) status_ = std::move(status);
    });
    listener_.subscribe(
        "OCCMAP_STATUS_CONTROL_STATUS", [this](const std::uint8_t* data, std::size_t size) {
          if (quiet_.load()) return;
          std::optional<occmap::control_status_t> decoded = decodeControlStatus(data, size);
          std::lock_guard lock(mutex_);
          if (decoded) control_status_ = std::move(decoded);
        });
    listener_.subscribe(
        "OCCMAP_STATUS_CONTROL_REPLY", [this](const std::uint8_t* data, std::size_t size) {
          if (quiet_.load()) return;
          std::optional<occmap::control_reply_t> reply = decodeControlReply(key_, data, size);
          std::lock_guard lock(mutex_);
          if (reply) {
            replies_.push_back(*reply);
          } else {
            ++unverified_replies_;
          }
        });
    // Room for the floods some tests send and what the daemon answers meanwhile, so that neither
    // side's bus allocates while a test counts allocations.
    listener_.reserve(kRoom, kRoomBytes);
    listener_.start();
    std::unique_ptr<MemoryBus> bus = network_.connect();
    bus->reserve(kRoom, kRoomBytes);
    pipeline_ = std::make_unique<Pipeline>(prepareRig(config), std::move(bus), options);
    pipeline_->start();
  }
  ~Daemon() {
    pipeline_->stop();
    listener_.stop();
  }

  const ControlKey& key() const { return key_; }
  Pipeline& pipeline() { return *pipeline_; }
  const TemporaryFolder& folder() const { return folder_; }

  // Sent from this side's own program on the bus, at its next round.
  void send(std::vector<std::uint8_t> bytes) { listener_.send(channel_, std::move(bytes)); }
  // While quiet, this side decodes nothing it hears (decoding allocates; the daemon must not).
  void setQuiet(bool quiet) { quiet_.store(quiet); }
  bool waitUntil(const std::function<bool()>& done, std::chrono::milliseconds timeout = 20s) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      if (done()) return true;
      std::this_thread::sleep_for(10ms);
    }
    return done();
  }
  // Waits for `count` more maps, then says how many cells of the newest are occupied.
  std::size_t occupiedAfter(std::size_t count) {
    std::size_t until = 0;
    {
      std::lock_guard lock(mutex_);
      until = maps_ + count;
    }
    waitUntil([&] {
      std::lock_guard lock(mutex_);
      return maps_ >= until;
    });
    std::lock_guard lock(mutex_);
    return static_cast<std::size_t>(std::count(latest_cells_.begin(), latest_cells_.end(),
                                               static_cast<std::uint8_t>(CellState::kOccupied)));
  }
  std::vector<occmap::control_reply_t> replies() {
    std::lock_guard lock(mutex_);
    return replies_;
  }
  // The reply to `request_id` with this outcome, waiting for it.
  std::optional<occmap::control_reply_t> reply(std::int64_t request_id, std::int8_t outcome,
                                               std::chrono::milliseconds timeout = 20s) {
    std::optional<occmap::control_reply_t> found;
    waitUntil(
        [&] {
          for (const auto& reply : replies()) {
            if (reply.request_id == request_id && reply.outcome == outcome) found = reply;
          }
          return found.has_value();
        },
        timeout);
    return found;
  }
  // The newest status and control status, if both have come and they were published together.
  std::optional<std::pair<occmap::status_t, occmap::control_status_t>> pairedStatus() {
    std::lock_guard lock(mutex_);
    if (!status_ || !control_status_ || status_->utime != control_status_->utime) {
      return std::nullopt;
    }
    return std::pair{*status_, *control_status_};
  }
  // A control status (published with each status) made after every message sent so far was
  // handled.
  occmap::control_status_t freshControlStatus() {
    const std::int64_t after = nowUtime();
    std::optional<occmap::control_status_t> control;
    waitUntil([&] {
      std::lock_guard lock(mutex_);
      if (control_status_ && control_status_->utime > after) control = control_status_;
      return control.has_value();
    });
    return control.value_or(occmap::control_status_t{});
  }

 private:
  static constexpr std::size_t kRoom = 256;
  static constexpr std::size_t kRoomBytes = 128 * 1024;
  TemporaryFolder folder_;
  MemoryNetwork network_;
  testing::BusListener listener_{network_};
  ControlKey key_;
  MapDecoder decoder_;  // the listener's thread only
  std::mutex mutex_;
  std::vector<std::uint8_t> latest_cells_;
  std::size_t maps_ = 0;
  std::optional<occmap::status_t> status_;
  std::optional<occmap::control_status_t> control_status_;
  std::vector<occmap::control_reply_t> replies_;
  std::size_t unverified_replies_ = 0;
  std::atomic<bool> quiet_{false};
  const std::string channel_ = "OCCMAP_STATUS_CONTROL";  // made once: publishing allocates nothing
  std::unique_ptr<Pipeline> pipeline_;
};

const std::string kEnabled = "control: {enabled: true, key_file: control.key}\n";

TEST(ControlRequests, AreIgnoredAndCountedWhenTheConfigDoesNotEnableThem) {
  Daemon daemon("");  // no control section: off
  daemon.occupiedAfter(3);
  daemon.send(signedRequest(daemon.key(), kSetThreshold, "c0", 200));
  ASSERT_TRUE(daemon.waitUntil([&] { return daemon.pipeline().controlCounts().disabled == 1; }))
      << "a request to a daemon with control off is counted as such";
  const occmap::control_status_t status = daemon.freshControlStatus();
  EXPECT_FALSE(status.control_enabled);
  EXPECT_EQ(status.disabled, 1);
  EXPECT_EQ(status.accepted, 0);
  EXPECT_EQ(daemon.pipeline().threshold(0), 20) << "a correctly signed request changed a daemon "
                                                   "whose config does not enable control";
  EXPECT_TRUE(daemon.replies().empty()) << "a daemon with control off answers nothing";
}

// status_t is the type it was before control requests (its fingerprint is its version): the
// counters come in a control_status_t of their own, published with every status and carrying its
// utime, request_id and hostname, so that a client can pair the two.
TEST(ControlStatus, ComesWithEveryStatusAndPairsWithIt) {
  Daemon daemon("");
  std::optional<std::pair<occmap::status_t, occmap::control_status_t>> paired;
  ASSERT_TRUE(daemon.waitUntil([&] { return (paired = daemon.pairedStatus()).has_value(); }))
      << "no control_status_t with the utime of a status_t";
  const auto& [status, control] = *paired;
  EXPECT_EQ(control.request_id, status.request_id);
  EXPECT_EQ(control.hostname, status.hostname);
  EXPECT_FALSE(control.hostname.empty());
  EXPECT_FALSE(control.control_enabled);
  ASSERT_EQ(control.num_cameras, status.num_cameras);
  for (std::size_t k = 0; k < status.cameras.size(); ++k) {
    EXPECT_EQ(control.camera_name[k], status.cameras[k].name);
    EXPECT_EQ(control.camera_threshold[k], 20);
    EXPECT_EQ(control.camera_background_utime[k], 0) << "the config's background";
  }
}

TEST(ControlRequests, ASignedSetThresholdChangesTheMapsAtOnce) {
  Daemon daemon(kEnabled);
  const std::size_t before = daemon.occupiedAfter(5);
  ASSERT_GT(before, 100u) << "the room's people and furniture should occupy cells";
  // At 255 no pixel differs enough from its background: every camera clears all it sees.
  std::vector<std::int64_t> ids;
  for (const char* camera : {"c0", "c1", "c2", "c3"}) {
    auto request = signedRequest(daemon.key(), kSetThreshold, camera, 255);
    ids.push_back(requestIdOf(request));
    daemon.send(std::move(request));
  }
  for (const std::int64_t id : ids) {
    const auto done = daemon.reply(id, occmap::control_reply_t::OUTCOME_DONE);
    ASSERT_TRUE(done) << "no DONE reply to set_threshold " << id;
    EXPECT_NE(done->message.find("threshold 255 (was 20)"), std::string::npos) << done->message;
  }
  // From each camera's next frame on; under load a camera's newest frame may be a few frames old.
  std::size_t after = before;
  daemon.waitUntil([&] { return (after = daemon.occupiedAfter(1)) < before / 10; }, 3s);
  RecordProperty("occupied_cells_before", static_cast<int>(before));
  RecordProperty("occupied_cells_at_255", static_cast<int>(after));
  EXPECT_LT(after, before / 10) << "threshold 255 on every camera should clear nearly every cell";
  const occmap::control_status_t status = daemon.freshControlStatus();
  EXPECT_TRUE(status.control_enabled);
  EXPECT_EQ(status.accepted, 4);
  ASSERT_EQ(status.camera_threshold.size(), 4u);
  EXPECT_EQ(status.camera_name, (std::vector<std::string>{"c0", "c1", "c2", "c3"}));
  for (const std::int32_t threshold : status.camera_threshold) EXPECT_EQ(threshold, 255);
  // And back: the maps return to what they were.
  ids.clear();
  for (const char* camera : {"c0", "c1", "c2", "c3"}) {
    auto request = signedRequest(daemon.key(), kSetThreshold, camera, 20);
    ids.push_back(requestIdOf(request));
    daemon.send(std::move(request));
  }
  for (const std::int64_t id : ids) ASSERT_TRUE(daemon.reply(id, 1));
  std::size_t again = 0;
  daemon.waitUntil([&] { return (again = daemon.occupiedAfter(1)) > before / 2; }, 3s);
  EXPECT_GT(again, before / 2) << "threshold 20 again should bring the occupied cells back";
}

TEST(ControlRequests, RecaptureMakesTheCamerasNextFramesItsBackground) {
  // Against black backgrounds nearly every pixel has changed, so nearly every cell in view is
  // occupied; recaptured, each camera's background is the room as it is, and the cells clear but
  // for those under the people who moved since.
  Daemon daemon(kEnabled, true, true);
  const std::size_t before = daemon.occupiedAfter(5);
  ASSERT_GT(before, 10'000u) << "against black backgrounds most cells in view should be occupied";
  for (const char* camera : {"c0", "c1", "c2", "c3"}) {
    const auto request = signedRequest(daemon.key(), kRecaptureBackground, camera, 5);
    const std::int64_t id = requestIdOf(request);
    daemon.send(request);
    // One at a time: another one while this runs (5 frames: 1/6 s) is refused, with the reason.
    const auto second = signedRequest(daemon.key(), kRecaptureBackground, "c0", 5);
    daemon.send(second);
    ASSERT_TRUE(daemon.reply(id, occmap::control_reply_t::OUTCOME_STARTED))
        << "no STARTED reply for " << camera;
    const auto busy = daemon.reply(requestIdOf(second), occmap::control_reply_t::OUTCOME_REFUSED);
    ASSERT_TRUE(busy) << "a second recapture while one runs should be refused";
    EXPECT_NE(busy->message.find("under way"), std::string::npos) << busy->message;
    const auto done = daemon.reply(id, occmap::control_reply_t::OUTCOME_DONE);
    ASSERT_TRUE(done) << "no DONE reply for " << camera;
    EXPECT_NE(done->message.find("median of 5 frames"), std::string::npos) << done->message;
    EXPECT_NE(done->message.find("saved to"), std::string::npos) << done->message;
    const auto saved = daemon.folder() / "state" / ("background-" + std::string(camera) + ".png");
    std::string error;
    const std::optional<Image> picture = readGreyImage(saved, error);
    ASSERT_TRUE(picture) << error;
    EXPECT_GT(std::count_if(picture->data(), picture->data() + picture->width() * picture->height(),
                            [](std::uint8_t v) { return v > 20; }),
              picture->width() * picture->height() / 2)
        << "the saved background should be the lit room, not the black picture";
  }
  std::size_t after = before;
  daemon.waitUntil([&] { return (after = daemon.occupiedAfter(1)) < before / 5; }, 3s);
  RecordProperty("occupied_cells_before", static_cast<int>(before));
  RecordProperty("occupied_cells_after", static_cast<int>(after));
  EXPECT_LT(after, before / 5) << "with the room itself for background the cells in view should "
                                  "clear (before "
                               << before << ", after " << after << ")";
  const occmap::control_status_t status = daemon.freshControlStatus();
  ASSERT_EQ(status.camera_background_utime.size(), 4u);
  for (const std::int64_t made : status.camera_background_utime) EXPECT_GT(made, 0);
}

TEST(ControlRequests, ForgedDamagedAndOddMessagesAreIgnoredAndCounted) {
  Daemon daemon(kEnabled);
  daemon.occupiedAfter(2);
  ControlKey other = makeRandomControlKey();
  const auto good = signedRequest(daemon.key(), kSetThreshold, "c0", 99);
  daemon.send(signedRequest(other, kSetThreshold, "c0", 99));  // wrong key
  auto flipped = good;
  flipped[flipped.size() - 33] ^= 0x01;  // the value's last byte: the mac no longer holds
  daemon.send(flipped);
  auto bad_mac = good;
  bad_mac.back() ^= 0x80;
  daemon.send(bad_mac);
  daemon.send(std::vector<std::uint8_t>(good.begin(), good.end() - 1));  // truncated
  auto oversized = good;
  oversized.resize(kMaxControlRequestBytes + 1, 0);
  daemon.send(oversized);
  auto trailing = good;
  trailing.push_back(0);
  daemon.send(trailing);
  occmap::status_request_t status_request{};
  std::vector<std::uint8_t> wrong_type(static_cast<std::size_t>(status_request.getEncodedSize()));
  status_request.encode(wrong_type.data(), 0, static_cast<int>(wrong_type.size()));
  daemon.send(wrong_type);  // another fingerprint
  auto fingerprint = good;
  fingerprint[0] ^= 0x01;
  daemon.send(fingerprint);
  daemon.send({});
  ASSERT_TRUE(daemon.waitUntil([&] {
    const ControlCounts counts = daemon.pipeline().controlCounts();
    return counts.bad_mac + counts.malformed == 9;
  })) << "every message counts";
  const ControlCounts counts = daemon.pipeline().controlCounts();
  EXPECT_EQ(counts.bad_mac, 3u) << "wrong key, a flipped byte, a flipped mac";
  EXPECT_EQ(counts.malformed, 6u)
      << "truncated, oversized, trailing, another type, fingerprint, empty";
  EXPECT_EQ(counts.accepted, 0u);
  EXPECT_EQ(daemon.pipeline().threshold(0), 20);
  // The good one still works, and is the only one answered.
  daemon.send(good);
  ASSERT_TRUE(daemon.reply(requestIdOf(good), occmap::control_reply_t::OUTCOME_DONE));
  EXPECT_EQ(daemon.pipeline().threshold(0), 99);
  EXPECT_EQ(daemon.replies().size(), 1u) << "unauthenticated messages get no reply";
  const occmap::control_status_t status = daemon.freshControlStatus();
  EXPECT_EQ(status.bad_mac, 3);
  EXPECT_EQ(status.malformed, 6);
  EXPECT_EQ(status.accepted, 1);
}

TEST(ControlRequests, AReplayIsIgnoredAndAStaleRequestRefused) {
  Daemon daemon(kEnabled);  // replay window: 30 s
  daemon.occupiedAfter(2);
  const auto request = signedRequest(daemon.key(), kSetThreshold, "c1", 42);
  daemon.send(request);
  ASSERT_TRUE(daemon.reply(requestIdOf(request), occmap::control_reply_t::OUTCOME_DONE));
  // Someone who saw it sends it again, after the threshold was set back.
  const auto back = signedRequest(daemon.key(), kSetThreshold, "c1", 20);
  daemon.send(back);
  ASSERT_TRUE(daemon.reply(requestIdOf(back), occmap::control_reply_t::OUTCOME_DONE));
  daemon.send(request);
  daemon.send(signedRequest(daemon.key(), kSetThreshold, "c1", 43, nowUtime() - 60'000'000));
  daemon.send(signedRequest(daemon.key(), kSetThreshold, "c1", 44, nowUtime() + 60'000'000));
  ASSERT_TRUE(daemon.waitUntil([&] { return daemon.pipeline().controlCounts().stale == 3; }))
      << "a replay, a request a minute old and one a minute ahead are all stale";
  EXPECT_EQ(daemon.pipeline().threshold(1), 20) << "the replay or a stale request was acted on";
  EXPECT_EQ(daemon.replies().size(), 2u);
  EXPECT_EQ(daemon.freshControlStatus().stale, 3);
}

TEST(ControlRequests, AnUnknownCameraOrABadValueIsRefusedWithAReason) {
  Daemon daemon(kEnabled);
  daemon.occupiedAfter(2);
  const struct {
    std::string_view command;
    const char* camera;
    int value;
    const char* reason;
  } cases[] = {{kSetThreshold, "c9", 30, "no camera named \"c9\"; the cameras are: c0, c1, c2, c3"},
               {kSetThreshold, "c0", 0, "threshold 0 is out of range"},
               {kSetThreshold, "c0", 256, "threshold 256 is out of range"},
               {kRecaptureBackground, "c0", 0, "0 frames is out of range"},
               {kRecaptureBackground, "c0", 1000, "1000 frames is out of range"},
               {"reboot", "c0", 1, "unknown command \"reboot\""}};
  for (const auto& c : cases) {
    const auto request = signedRequest(daemon.key(), c.command, c.camera, c.value);
    daemon.send(request);
    const auto refused =
        daemon.reply(requestIdOf(request), occmap::control_reply_t::OUTCOME_REFUSED);
    ASSERT_TRUE(refused) << c.reason;
    EXPECT_NE(refused->message.find(c.reason), std::string::npos) << refused->message;
  }
  EXPECT_EQ(daemon.pipeline().controlCounts().refused, std::size(cases));
  EXPECT_EQ(daemon.pipeline().threshold(0), 20);
}

// The LCM thread checks every control message without allocating: a flood of forged and broken
// requests, and valid ones answered, cost no operator new (as the status does not).
TEST(ControlRequests, HandlingThemAllocatesNothing) {
  Daemon daemon(kEnabled);
  daemon.occupiedAfter(3);
  // Warm up: the first reply and status fill their reused buffers.
  const auto warm = signedRequest(daemon.key(), kSetThreshold, "c2", 21);
  daemon.send(warm);
  ASSERT_TRUE(daemon.reply(requestIdOf(warm), 1));
  std::this_thread::sleep_for(1200ms);
  std::vector<std::vector<std::uint8_t>> messages;
  const ControlKey other = makeRandomControlKey();
  for (int i = 0; i < 20; ++i) {
    messages.push_back(signedRequest(other, kSetThreshold, "c0", 30));
    auto broken = signedRequest(daemon.key(), kSetThreshold, "c0", 30);
    broken.erase(broken.end() - 5, broken.end());  // truncated
    messages.push_back(broken);
  }
  for (int value = 22; value < 27; ++value) {
    messages.push_back(signedRequest(daemon.key(), kSetThreshold, "c2", value));
  }
  messages.push_back(signedRequest(daemon.key(), kSetThreshold, "nowhere", 30));
  long allocations = 0;
  daemon.setQuiet(true);
  std::this_thread::sleep_for(100ms);  // what the LCM thread was decoding for this side is done
  {
    testing::AllocationCounter counter;
    for (auto& message : messages) daemon.send(std::move(message));
    ASSERT_TRUE(daemon.waitUntil([&] {
      const ControlCounts counts = daemon.pipeline().controlCounts();
      return counts.bad_mac + counts.malformed == 40 && counts.accepted == 6 && counts.refused == 1;
    })) << "every message should have been handled";
    allocations = counter.allocations();
  }
  daemon.setQuiet(false);
  EXPECT_EQ(allocations, 0) << "handling and answering control requests allocated";
  EXPECT_EQ(daemon.pipeline().threshold(2), 26);
}

// --- The parts on their own ---

TEST(ReplayWindow, TakesEachRequestOnceWithinTheWindowAndRefusesRatherThanForgetWhenFull) {
  const std::int64_t now = 1'700'000'000'000'000;
  ReplayWindow window(30'000'000, 3);
  using V = ReplayWindow::Verdict;
  EXPECT_EQ(window.admit(now, 1, now), V::kFresh);
  EXPECT_EQ(window.admit(now, 1, now), V::kReplayed);
  EXPECT_EQ(window.admit(now, 2, now), V::kFresh) << "another nonce is another request";
  EXPECT_EQ(window.admit(now - 30'000'001, 3, now), V::kOutsideWindow);
  EXPECT_EQ(window.admit(now + 30'000'001, 3, now), V::kOutsideWindow);
  EXPECT_EQ(window.admit(INT64_MIN, 3, now), V::kOutsideWindow);
  EXPECT_EQ(window.admit(INT64_MAX, 3, now), V::kOutsideWindow);
  EXPECT_EQ(window.admit(now + 30'000'000, 3, now), V::kFresh) << "the window's edge is inside";
  EXPECT_EQ(window.admit(now, 4, now), V::kFull)
      << "three remembered, all in the window: the fourth is refused, none forgotten";
  EXPECT_EQ(window.admit(now, 1, now + 1), V::kReplayed) << "still remembered";
  // 31 s later the first two have left the window: their copies are refused by utime, and there
  // is room again.
  EXPECT_EQ(window.admit(now, 1, now + 31'000'000), V::kOutsideWindow);
  EXPECT_EQ(window.admit(now + 31'000'000, 5, now + 31'000'000), V::kFresh);
  EXPECT_EQ(window.remembered(), 2u);
}

// The capture thread reads the background of every frame while new ones are offered: no image it
// may still read is freed (ASan would say so), and it ends on the newest.
TEST(BackgroundHandover, NewBackgroundsWhileTheCaptureThreadReadsFreeNothingInUse) {
  const Image initial(64, 48, 0);
  BackgroundHandover handover(initial);
  std::atomic<bool> done{false};
  std::atomic<int> last_seen{-1};
  std::thread capture([&] {
    while (!done.load()) {
      const Image& background = handover.current();
      int sum = 0;
      for (int v = 0; v < background.height(); ++v) sum += background.row(v)[v % 64];
      // Every pixel of offer k is k: a freed or half-made image would show another value.
      const int value = background.at(0, 0);
      if (sum != value * background.height()) {
        last_seen.store(-2);
        return;
      }
      last_seen.store(value);
    }
  });
  for (int k = 1; k <= 200; ++k) {
    handover.offer(std::make_unique<Image>(64, 48, static_cast<std::uint8_t>(k)));
    if (k % 3 == 0) std::this_thread::sleep_for(50us);
    handover.collect();
  }
  const auto end = std::chrono::steady_clock::now() + 5s;
  while (!handover.collect() && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(1ms);
  }
  EXPECT_TRUE(handover.collect()) << "the capture thread never switched to the newest background";
  done.store(true);
  capture.join();
  EXPECT_EQ(last_seen.load(), 200) << "-2: the capture thread read an image that was not whole";
}

TEST(FrameRecorder, RecordsTheNextFramesAndLetsGoOfAnAbandonedRecording) {
  FrameRecorder recorder;
  Image frame(4, 3, 0);
  recorder.record(frame.view());  // not armed: nothing
  ASSERT_TRUE(recorder.arm(2, 4, 3));
  EXPECT_FALSE(recorder.arm(2, 4, 3)) << "one recording at a time";
  frame.at(1, 1) = 7;
  recorder.record(frame.view());
  recorder.record(Image(5, 3, 9).view());  // another size: not taken
  EXPECT_FALSE(recorder.filled());
  frame.at(1, 1) = 9;
  recorder.record(frame.view());
  ASSERT_TRUE(recorder.filled());
  ASSERT_EQ(recorder.frames().size(), 24u);
  EXPECT_EQ(recorder.frames()[5], 7);
  EXPECT_EQ(recorder.frames()[12 + 5], 9);
  recorder.finish();
  // Abandoned half-way: the capture thread lets go at its next frame, then it can be armed again.
  ASSERT_TRUE(recorder.arm(3, 4, 3));
  recorder.record(frame.view());
  recorder.finish();
  EXPECT_FALSE(recorder.arm(1, 4, 3)) << "the capture thread has not let go yet";
  recorder.record(frame.view());
  EXPECT_TRUE(recorder.arm(1, 4, 3));
}

// --- Config and key file ---

void expectInputError(const std::function<void()>& load, const std::string& location,
                      const std::string& words) {
  try {
    load();
    ADD_FAILURE() << "accepted; expected an error at " << location << " saying " << words;
  } catch (const InputError& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find(location), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << what;
  }
}

TEST(ControlConfig, IsOffByDefaultAndCheckedLikeEverySection) {
  const std::string base = testing::simRoomConfig();
  const Config plain = parseConfig(base, "/etc/occmap/a.yaml");
  EXPECT_FALSE(plain.control.enabled);
  EXPECT_EQ(plain.control.replay_window_s, 30);
  const Config on = parseConfig(
      base + "control:\n  enabled: true\n  key_file: keys/c.key\n  replay_window_s: 5\n",
      "/etc/occmap/a.yaml");
  EXPECT_TRUE(on.control.enabled);
  EXPECT_EQ(on.control.key_file, "/etc/occmap/keys/c.key") << "relative to the config";
  EXPECT_EQ(on.control.key_file_line, 11);
  EXPECT_EQ(on.control.replay_window_s, 5);
  auto parse = [&](const std::string& control) {
    return [&, control] { parseConfig(base + control, "/etc/occmap/a.yaml"); };
  };
  expectInputError(parse("control: {enabled: true}\n"), "a.yaml:9: control.key_file",
                   "occmap control --make-key");
  expectInputError(parse("control: {enabled: yes, key_file: k}\n"), "a.yaml:9: control.enabled",
                   "true or false");
  expectInputError(parse("control:\n  enabled: true\n  key_fiel: k\n"),
                   "a.yaml:11: control.key_fiel", "did you mean key_file?");
  expectInputError(parse("control: {key_file: k, replay_window_s: 0}\n"),
                   "a.yaml:9: control.replay_window_s", "from 1 to 3600");
  expectInputError(parse("control: {key_file: \"\"}\n"), "a.yaml:9: control.key_file", "empty");
}

TEST(ControlKeyFile, MustBeTheServicesAloneAndHoldAHexKey) {
  TemporaryFolder folder;
  const auto file = folder / "control.key";
  writeNewControlKey(file);
  struct stat info {};
  ASSERT_EQ(::stat(file.c_str(), &info), 0);
  EXPECT_EQ(info.st_mode & 0777, 0600u) << "--make-key writes the key for its owner alone";
  const std::string text = testing::readWhole(file);
  EXPECT_EQ(text.size(), 65u) << "64 hex digits and a newline";
  EXPECT_EQ(loadControlKey(file, {"x", 0, ""}).size, 32u);
  EXPECT_THROW(writeNewControlKey(file), InputError) << "a key in use is never replaced";
  const KeyFileOrigin origin{"/etc/occmap/occmapd.yaml", 12, "control.key_file"};
  ::chmod(file.c_str(), 0644);
  expectInputError([&] { loadControlKey(file, origin); }, "occmapd.yaml:12: control.key_file",
                   "mode 0644");
  expectInputError([&] { loadControlKey(file, origin); }, "occmapd.yaml:12", "chmod 600");
  expectInputError([&] { loadControlKey(file, origin); }, "occmapd.yaml:12", "chown occmap");
  ::chmod(file.c_str(), 0640);
  expectInputError([&] { loadControlKey(file, origin); }, "occmapd.yaml:12", "mode 0640");
  const auto short_key = folder.write("short.key", std::string(62, 'a') + "\n");
  ::chmod(short_key.c_str(), 0600);
  expectInputError([&] { loadControlKey(short_key, origin); }, "occmapd.yaml:12",
                   "holds 62 characters; it must hold 64 to 128 hex digits");
  const auto not_hex = folder.write("words.key", std::string(63, 'a') + "g\n");
  ::chmod(not_hex.c_str(), 0600);
  expectInputError([&] { loadControlKey(not_hex, origin); }, "occmapd.yaml:12",
                   "other than hex digits");
  expectInputError([&] { loadControlKey(folder / "absent.key", origin); }, "occmapd.yaml:12",
                   "occmap control --make-key");
}

TEST(ControlKeyFile, OccmapdCheckRefusesAKeyOthersCanRead) {
  TemporaryFolder folder;
  writeNewControlKey(folder / "control.key");
  const auto config = folder.write("room.yaml", testing::simRoomConfig() + kEnabled);
  const std::string occmapd = OCCMAP_BINARY_DIR "/daemon/occmapd";
  auto result = testing::runCommand({occmapd, "--check", "--config", config.string()});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  ::chmod((folder / "control.key").c_str(), 0644);
  result = testing::runCommand({occmapd, "--check", "--config", config.string()});
  EXPECT_EQ(result.exit_code, 2) << "a key file that others can read is invalid input";
  EXPECT_NE(result.err.find("room.yaml:9: control.key_file"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("chmod 600"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace occmap
