// The bus's parts without a network: the in-memory bus the tests put between programs, the rate at
// which status requests are answered, with time passed in, and the status, tracks and zones as they
// are read from the network (transport/).
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <occmap/status_request_t.hpp>

#include "transport/footprints_message.h"
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

template <typename Message>
std::vector<std::uint8_t> encoded(const Message& message) {
  std::vector<std::uint8_t> data(static_cast<std::size_t>(message.getEncodedSize()));
  EXPECT_EQ(message.encode(data.data(), 0, static_cast<int>(data.size())),
            static_cast<int>(data.size()));
  return data;
}

// What a decoder of a message from the network promises about damaged bytes: `data` cut short at
// every length is refused, each time with a reason, and each time by the walk over the bytes,
// before LCM's generated decoder (which trusts the counts) sees them.
template <typename Decode>
void expectEveryCutRefusedByTheWalk(const std::vector<std::uint8_t>& data, Decode decode) {
  for (std::size_t size = 0; size < data.size(); ++size) {
    std::string reason;
    EXPECT_FALSE(decode(data.data(), size, &reason)) << "cut to " << size << " bytes";
    EXPECT_FALSE(reason.empty()) << "cut to " << size << " bytes: refused without a reason";
    EXPECT_EQ(reason.find("LCM's decoder"), std::string::npos)
        << "cut to " << size << " bytes: only LCM's decoder noticed (" << reason << ")";
  }
}

// `data` with the big-endian int16 at `at` replaced by `count`.
std::vector<std::uint8_t> withCount(std::vector<std::uint8_t> data, std::size_t at,
                                    std::int16_t count) {
  const auto bits = static_cast<std::uint16_t>(count);
  data.at(at) = static_cast<std::uint8_t>(bits >> 8);
  data.at(at + 1) = static_cast<std::uint8_t>(bits & 0xFF);
  return data;
}

occmap::tracks_t someTracks() {
  occmap::tracks_t sent{};
  sent.utime = 1'700'000'000'123'456;
  sent.seq = 1205;
  sent.hostname = "cell-3";
  sent.footprints = {{1.2, 0.35, 0.21, 0.62, 1.75}, {-0.4, 2.1, 0.18, 0.31, 1.75}, {3.0, 3.0, 0.05, 0.6, 0.5}};
  sent.num_footprints = 3;
  occmap::track_t person{};
  person.id = 4;
  person.x_m = 1.21;
  person.y_m = 0.34;
  person.vx_m_s = 0.8;
  person.vy_m_s = -0.1;
  person.area_m2 = 0.21;
  person.age_s = 12.5;
  person.unseen_s = 0;
  sent.tracks = {person, person};
  sent.tracks[1].id = 7;
  sent.tracks[1].x_m = -0.4;
  sent.tracks[1].unseen_s = 0.1;
  sent.num_tracks = 2;
  return sent;
}

occmap::zone_t someZone(const std::string& name, std::int8_t state, int corners) {
  occmap::zone_t zone{};
  zone.name = name;
  zone.state = state;
  zone.state_s = 3.25;
  zone.cells = 2500;
  zone.occupied_cells = state == occmap::zone_t::OCCUPIED ? 41 : 0;
  zone.unseen_cells = state == occmap::zone_t::UNSEEN ? 120 : 0;
  for (int k = 0; k < corners; ++k) {
    zone.corner_x_m.push_back(0.5 * k);
    zone.corner_y_m.push_back(k % 2 == 0 ? 1.0 : -1.0);
  }
  zone.num_corners = static_cast<std::int16_t>(corners);
  return zone;
}

occmap::zones_t someZones() {
  occmap::zones_t sent{};
  sent.utime = 1'700'000'000'123'456;
  sent.seq = 1207;
  sent.hostname = "cell-3";
  sent.zones = {someZone("robot-cell", occmap::zone_t::OCCUPIED, 4),
                someZone("door", occmap::zone_t::FREE, 3),
                someZone("desk", occmap::zone_t::UNSEEN, 5)};
  sent.num_zones = 3;
  return sent;
}

bool tracksDecode(const std::uint8_t* bytes, std::size_t size, std::string* why) {
  return decodeTracks(bytes, size, why).has_value();
}
bool zonesDecode(const std::uint8_t* bytes, std::size_t size, std::string* why) {
  return decodeZones(bytes, size, why).has_value();
}

// `decode` refuses `data`, with a reason that holds `why` (any reason when `why` is empty: where
// the walk notices depends on what the damaged bytes happen to say).
template <typename Decode>
void expectRefused(Decode decode, const std::vector<std::uint8_t>& data, const std::string& why) {
  std::string reason;
  EXPECT_FALSE(decode(data.data(), data.size(), &reason)) << why;
  EXPECT_FALSE(reason.empty()) << "refused without a reason; expected: " << why;
  EXPECT_NE(reason.find(why), std::string::npos) << "refused, but the reason is: " << reason;
}

// The channels are named after the map's, as occmapd names them.
TEST(FootprintsMessages, AreOnChannelsNamedAfterTheMapChannel) {
  EXPECT_EQ(tracksChannel("OCCMAP_MAP"), "OCCMAP_MAP_TRACKS");
  EXPECT_EQ(zonesChannel("OCCMAP_MAP"), "OCCMAP_MAP_ZONES");
  EXPECT_EQ(zonesChannel("HALL_2"), "HALL_2_ZONES");
}

// A tracks_t from anyone on the network: decoded to what was sent when it is exactly one message.
TEST(Tracks, AreDecodedToWhatWasSent) {
  for (const occmap::tracks_t& sent : {someTracks(), occmap::tracks_t{}}) {
    const std::vector<std::uint8_t> data = encoded(sent);
    std::string error;
    const auto decoded = decodeTracks(data.data(), data.size(), &error);
    ASSERT_TRUE(decoded) << error;
    EXPECT_EQ(decoded->seq, sent.seq);
    EXPECT_EQ(decoded->utime, sent.utime);
    EXPECT_EQ(decoded->hostname, sent.hostname);
    ASSERT_EQ(decoded->footprints.size(), sent.footprints.size());
    ASSERT_EQ(decoded->tracks.size(), sent.tracks.size());
    for (std::size_t k = 0; k < sent.footprints.size(); ++k) {
      EXPECT_EQ(decoded->footprints[k].x_m, sent.footprints[k].x_m);
      EXPECT_EQ(decoded->footprints[k].score, sent.footprints[k].score);
      EXPECT_EQ(decoded->footprints[k].height_m, sent.footprints[k].height_m);
    }
    for (std::size_t k = 0; k < sent.tracks.size(); ++k) {
      EXPECT_EQ(decoded->tracks[k].id, sent.tracks[k].id);
      EXPECT_EQ(decoded->tracks[k].x_m, sent.tracks[k].x_m);
      EXPECT_EQ(decoded->tracks[k].vy_m_s, sent.tracks[k].vy_m_s);
      EXPECT_EQ(decoded->tracks[k].unseen_s, sent.tracks[k].unseen_s);
    }
    EXPECT_EQ(encoded(*decoded), data) << "every field, encoded again: the same bytes";
  }
}

// Damaged or forged tracks_t bytes: refused, each with its reason, never an exception.
TEST(Tracks, AreRefusedWithAReasonWhenTheBytesAreNotExactlyOne) {
  const occmap::tracks_t sent = someTracks();
  const std::vector<std::uint8_t> data = encoded(sent);
  expectEveryCutRefusedByTheWalk(data, tracksDecode);
  expectRefused(tracksDecode, {data.begin(), data.begin() + 7}, "too short");
  expectRefused(tracksDecode, {data.begin(), data.end() - 1}, "the tracks are truncated");

  std::vector<std::uint8_t> longer = data;
  longer.push_back(0);
  expectRefused(tracksDecode, longer, "bytes left over");
  std::vector<std::uint8_t> other = data;
  other[7] ^= 0x01;
  expectRefused(tracksDecode, other, "not an occmap.tracks_t (fingerprint)");
  expectRefused(tracksDecode, encoded(someZones()), "not an occmap.tracks_t (fingerprint)");

  // num_footprints follows the fingerprint, utime, seq and the hostname (length, text, NUL);
  // num_tracks follows the footprints, 5 doubles each.
  const std::size_t footprints_at = 8 + 8 + 8 + 4 + sent.hostname.size() + 1;
  const std::size_t tracks_at = footprints_at + 2 + sent.footprints.size() * 5 * 8;
  ASSERT_EQ(data.size(), tracks_at + 2 + sent.tracks.size() * (4 + 7 * 8)) << "the layout above";
  expectRefused(tracksDecode, withCount(data, footprints_at, -1), "num_footprints is negative");
  expectRefused(tracksDecode, withCount(data, tracks_at, -3), "num_tracks is negative");
  // A count larger than the bytes behind it: refused before anything is sized by it.
  expectRefused(tracksDecode, withCount(data, footprints_at, 32767),
                "the footprints are truncated");
  expectRefused(tracksDecode, withCount(data, tracks_at, 3), "the tracks are truncated");
  // One footprint fewer than the bytes hold: the rest is left over.
  expectRefused(tracksDecode, withCount(data, footprints_at, 2), "");

  std::vector<std::uint8_t> unterminated = data;
  unterminated[footprints_at - 1] = 'x';
  expectRefused(tracksDecode, unterminated, "hostname is not a string that fits");
  EXPECT_FALSE(decodeTracks(nullptr, 0)) << "no data";
}

// A zones_t likewise.
TEST(Zones, AreDecodedToWhatWasSent) {
  for (const occmap::zones_t& sent : {someZones(), occmap::zones_t{}}) {
    const std::vector<std::uint8_t> data = encoded(sent);
    std::string error;
    const auto decoded = decodeZones(data.data(), data.size(), &error);
    ASSERT_TRUE(decoded) << error;
    EXPECT_EQ(decoded->seq, sent.seq);
    EXPECT_EQ(decoded->utime, sent.utime);
    EXPECT_EQ(decoded->hostname, sent.hostname);
    ASSERT_EQ(decoded->zones.size(), sent.zones.size());
    for (std::size_t k = 0; k < sent.zones.size(); ++k) {
      const occmap::zone_t& zone = decoded->zones[k];
      EXPECT_EQ(zone.name, sent.zones[k].name);
      EXPECT_EQ(zone.state, sent.zones[k].state);
      EXPECT_EQ(zone.state_s, sent.zones[k].state_s);
      EXPECT_EQ(zone.cells, sent.zones[k].cells);
      EXPECT_EQ(zone.occupied_cells, sent.zones[k].occupied_cells);
      EXPECT_EQ(zone.unseen_cells, sent.zones[k].unseen_cells);
      EXPECT_EQ(zone.corner_x_m, sent.zones[k].corner_x_m);
      EXPECT_EQ(zone.corner_y_m, sent.zones[k].corner_y_m);
    }
    EXPECT_EQ(encoded(*decoded), data) << "every field, encoded again: the same bytes";
  }
}

TEST(Zones, AreRefusedWithAReasonWhenTheBytesAreNotExactlyOne) {
  const occmap::zones_t sent = someZones();
  const std::vector<std::uint8_t> data = encoded(sent);
  expectEveryCutRefusedByTheWalk(data, zonesDecode);
  expectRefused(zonesDecode, {data.begin(), data.end() - 1}, "a zone's corners are truncated");

  std::vector<std::uint8_t> longer = data;
  longer.insert(longer.end(), {0, 0, 0});
  expectRefused(zonesDecode, longer, "bytes left over");
  std::vector<std::uint8_t> other = data;
  other[0] ^= 0x80;
  expectRefused(zonesDecode, other, "not an occmap.zones_t (fingerprint)");
  expectRefused(zonesDecode, encoded(someTracks()), "not an occmap.zones_t (fingerprint)");

  // num_zones follows the head; the first zone's name (length, text, NUL) follows it, then its
  // state (1), state_s (8), three cell counts (4 each) and num_corners.
  const std::size_t zones_at = 8 + 8 + 8 + 4 + sent.hostname.size() + 1;
  const std::size_t name_at = zones_at + 2;
  const std::size_t corners_at = name_at + 4 + sent.zones[0].name.size() + 1 + 1 + 8 + 3 * 4;
  expectRefused(zonesDecode, withCount(data, zones_at, -1), "num_zones is negative");
  expectRefused(zonesDecode, withCount(data, zones_at, 32767), "");
  expectRefused(zonesDecode, withCount(data, corners_at, -2), "a zone's num_corners is negative");
  expectRefused(zonesDecode, withCount(data, corners_at, 32767), "a zone's corners are truncated");

  // A zone's name without its NUL, and with a NUL before its end: no LCM encoder sends either.
  std::vector<std::uint8_t> unterminated = data;
  const std::size_t nul_at = name_at + 4 + sent.zones[0].name.size();
  ASSERT_EQ(unterminated.at(nul_at), 0) << "the layout above";
  unterminated[nul_at] = 'x';
  expectRefused(zonesDecode, unterminated, "a zone's name is not a string that fits");
  std::vector<std::uint8_t> nul_inside = data;
  nul_inside[name_at + 4 + 2] = 0;
  expectRefused(zonesDecode, nul_inside, "a zone's name is not a string that fits");
  // A name's length past the end of the message.
  std::vector<std::uint8_t> too_long = data;
  too_long[name_at] = 0x7F;
  expectRefused(zonesDecode, too_long, "a zone's name is not a string that fits");
  EXPECT_FALSE(decodeZones(nullptr, 0)) << "no data";
}

}  // namespace
}  // namespace occmap
