// The bus's parts without a network: the in-memory bus the tests put between programs, the rate at
// which status requests are answered, with time passed in, and the lighting status as it is read
// from the network (transport/).
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <occmap/status_request_t.hpp>

#include "transport/memory_bus.h"
#include "transport/status_message.h"
#include "transport/status_requests.h"

namespace occmap {
namespace {

std::vector<std::uint8_t> bytes(std::initializer_list<std::uint8_t> values) { return values; }

TEST(MemoryBus, EveryBusSubscribedToAChannelHearsEachMessageInOrderIncludingItsSender) {
  MemoryNetwork network;
  auto a = network.connect();
  auto b = network.connect();
  auto c = network.connect();
  std::vector<std::uint8_t> heard_a, heard_b;
  a->subscribe("MAPS", [&](const std::uint8_t* d, std::size_t n, std::int64_t utime) {
    heard_a.insert(heard_a.end(), d, d + n);
    EXPECT_GT(utime, 0) << "a receive time, as LCM gives";
  });
  b->subscribe("MAPS", [&](const std::uint8_t* d, std::size_t n, std::int64_t) {
    heard_b.insert(heard_b.end(), d, d + n);
  });
  b->subscribe("OTHER", [&](const std::uint8_t*, std::size_t, std::int64_t) {
    ADD_FAILURE() << "a message on MAPS reached a handler of OTHER";
  });
  for (std::uint8_t i = 0; i < 100; ++i) EXPECT_TRUE(a->publish("MAPS", bytes({i, i})));
  EXPECT_TRUE(c->publish("NOBODY", bytes({7})));
  EXPECT_EQ(c->pending(), 0u) << "c subscribed to nothing";
  EXPECT_EQ(b->pending(), 100u) << "none lost, none dropped while b was not handling";
  while (a->handleTimeout(0) > 0) {
  }
  while (b->handleTimeout(0) > 0) {
  }
  ASSERT_EQ(heard_a.size(), 200u);
  ASSERT_EQ(heard_b, heard_a);
  for (std::size_t i = 0; i < 100; ++i) ASSERT_EQ(heard_b[2 * i], i) << "out of order";
  EXPECT_EQ(b->handleTimeout(0), 0) << "nothing left: a time-out";
}

TEST(MemoryBus, ItsDescriptorWakesAPollerInAnotherThread) {
  MemoryNetwork network;
  auto sender = network.connect();
  auto receiver = network.connect();
  std::size_t heard = 0;
  receiver->subscribe("X", [&](const std::uint8_t*, std::size_t, std::int64_t) { ++heard; });
  std::thread listener([&] {
    while (heard < 3) ASSERT_GE(receiver->handleTimeout(5000), 0);
  });
  for (int i = 0; i < 3; ++i) sender->publish("X", bytes({1}));
  listener.join();
  EXPECT_EQ(heard, 3u);
}

std::vector<std::uint8_t> statusRequest(std::int64_t id) {
  occmap::status_request_t request{};
  request.utime = 1;
  request.request_id = id;
  std::vector<std::uint8_t> data(static_cast<std::size_t>(request.getEncodedSize()));
  request.encode(data.data(), 0, static_cast<int>(data.size()));
  return data;
}

TEST(StatusRequests, AreAnsweredOldestFirstAtTheBoundedRateAndAFloodIsShedAndCounted) {
  constexpr std::int64_t kS = 1'000'000'000;
  StatusRequests requests(20.0, 0);
  for (std::int64_t id = 0; id < 40; ++id) {
    const auto data = statusRequest(id);
    requests.take(data.data(), data.size());
  }
  const std::uint8_t garbage[] = {1, 2, 3};
  requests.take(garbage, sizeof garbage);
  EXPECT_EQ(requests.waiting(), StatusRequests::kMaxPending);
  EXPECT_EQ(requests.ignored(), 40 - StatusRequests::kMaxPending + 1) << "shed and malformed";
  std::vector<std::int64_t> answered;
  auto answer = [&](std::int64_t id) { answered.push_back(id); };
  requests.answer(0, answer);  // the bucket starts full: 20 tokens, 16 waiting
  ASSERT_EQ(answered.size(), StatusRequests::kMaxPending);
  for (std::size_t i = 0; i < answered.size(); ++i) EXPECT_EQ(answered[i], static_cast<int>(i));
  // Now empty of requests, and 4 tokens left; 30 more come at once, 16 are kept.
  answered.clear();
  for (std::int64_t id = 100; id < 130; ++id) {
    const auto data = statusRequest(id);
    requests.take(data.data(), data.size());
  }
  requests.answer(0, answer);
  EXPECT_EQ(answered.size(), 4u) << "only the tokens left";
  requests.answer(kS / 10, answer);  // 0.1 s: two more tokens
  EXPECT_EQ(answered.size(), 6u);
  requests.answer(10 * kS, answer);  // the bucket holds at most 20
  EXPECT_EQ(answered.size(), 16u);
  EXPECT_EQ(answered.back(), 115);
  EXPECT_EQ(requests.waiting(), 0u);
}

// The bytes of `data` (a message with the per-camera companions' head: fingerprint, utime,
// request_id, `hostname`, num_cameras, ...) cut short, made longer, of another fingerprint and with
// a negative camera count: each refused by `decode` with its reason.
template <typename Decode>
void expectEachDamageRefused(const std::vector<std::uint8_t>& data, const std::string& hostname,
                             Decode decode) {
  auto refused = [&](std::vector<std::uint8_t> bytes_in, const std::string& why) {
    std::string reason;
    EXPECT_FALSE(decode(bytes_in.data(), bytes_in.size(), &reason)) << why;
    EXPECT_NE(reason.find(why), std::string::npos) << reason;
  };
  refused({data.begin(), data.end() - 1}, "truncated in the cameras' figures");
  std::vector<std::uint8_t> longer = data;
  longer.push_back(0);
  refused(longer, "bytes left over");
  std::vector<std::uint8_t> other = data;
  other[0] ^= 0xFF;
  refused(other, "fingerprint");
  // num_cameras sits after the fingerprint, utime, request_id and the hostname (length + text +
  // NUL): made negative.
  std::vector<std::uint8_t> negative = data;
  const std::size_t count_at = 8 + 8 + 8 + 4 + hostname.size() + 1;
  negative[count_at] = 0xFF;
  negative[count_at + 1] = 0xFE;
  refused(negative, "num_cameras is negative");
}

// A lighting_status_t from anyone on the network: decoded when it is exactly one, refused with a
// reason when a count, a length or the fingerprint does not fit, never an exception.
TEST(LightingStatus, IsDecodedWhenWholeAndRefusedWithAReasonOtherwise) {
  occmap::lighting_status_t sent{};
  sent.utime = 1'700'000'000'000'000;
  sent.request_id = 7;
  sent.hostname = "cell-3";
  sent.num_cameras = 2;
  sent.camera_name = {"c0", "c1"};
  sent.adapt = {1, 1};
  sent.gain = {0.62, 1.0};
  sent.agreement = {0.93, 0.12};
  sent.explained = {1, 0};
  sent.unexplained_frames = {0, 450};
  std::vector<std::uint8_t> data(static_cast<std::size_t>(sent.getEncodedSize()));
  ASSERT_EQ(sent.encode(data.data(), 0, static_cast<int>(data.size())),
            static_cast<int>(data.size()));
  std::string error;
  const auto decoded = decodeLightingStatus(data.data(), data.size(), &error);
  ASSERT_TRUE(decoded) << error;
  EXPECT_EQ(decoded->camera_name, sent.camera_name);
  EXPECT_EQ(decoded->gain, sent.gain);
  EXPECT_EQ(decoded->explained, sent.explained);
  EXPECT_EQ(decoded->unexplained_frames, sent.unexplained_frames);

  expectEachDamageRefused(data, sent.hostname,
                          [](const std::uint8_t* bytes, std::size_t size, std::string* why) {
                            return decodeLightingStatus(bytes, size, why).has_value();
                          });
}

// A view_status_t likewise.
TEST(ViewStatus, IsDecodedWhenWholeAndRefusedWithAReasonOtherwise) {
  occmap::view_status_t sent{};
  sent.utime = 1'700'000'000'000'000;
  sent.request_id = -1;
  sent.hostname = "cell-3";
  sent.num_cameras = 3;
  sent.camera_name = {"c0", "c1", "c2"};
  sent.view = {occmap::view_status_t::AS_CALIBRATED, occmap::view_status_t::MOVED,
               occmap::view_status_t::UNEXPLAINED};
  sent.shift_x_px = {0, 10.5, 0};
  sent.shift_y_px = {0, -3.25, 0};
  sent.turn_deg = {0, 1.01, 0};
  sent.residual_px = {0, 0.3, 0};
  sent.checked_utime = {0, 1'700'000'000'500'000, 1'700'000'000'400'000};
  sent.reposes = {0, 2, 0};
  sent.reposed_turn_deg = {0, 0.98, 0};
  sent.reposed_utime = {0, 1'700'000'000'100'000, 0};
  std::vector<std::uint8_t> data(static_cast<std::size_t>(sent.getEncodedSize()));
  ASSERT_EQ(sent.encode(data.data(), 0, static_cast<int>(data.size())),
            static_cast<int>(data.size()));
  std::string error;
  const auto decoded = decodeViewStatus(data.data(), data.size(), &error);
  ASSERT_TRUE(decoded) << error;
  EXPECT_EQ(decoded->camera_name, sent.camera_name);
  EXPECT_EQ(decoded->view, sent.view);
  EXPECT_EQ(decoded->shift_y_px, sent.shift_y_px);
  EXPECT_EQ(decoded->turn_deg, sent.turn_deg);
  EXPECT_EQ(decoded->checked_utime, sent.checked_utime);
  EXPECT_EQ(decoded->reposes, sent.reposes);
  EXPECT_EQ(decoded->reposed_utime, sent.reposed_utime);

  expectEachDamageRefused(data, sent.hostname,
                          [](const std::uint8_t* bytes, std::size_t size, std::string* why) {
                            return decodeViewStatus(bytes, size, why).has_value();
                          });
}

}  // namespace
}  // namespace occmap
