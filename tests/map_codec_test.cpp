// map_frame_t on the wire: maps survive the trip in both encodings; a 512 x 512 map fits one UDP
// datagram when zstd-encoded; the decoder refuses hostile messages with a reason and never
// allocates more than the message or the map it declares; the encoder allocates nothing after it is
// built.
#include "transport/map_codec.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <random>

#include <gtest/gtest.h>
#include <occmap/status_t.hpp>
#include <zstd.h>

#include "allocation_counter.h"
#include "capture/sim/renderer.h"
#include "capture/sim/scene.h"
#include "core/reference_fusion.h"
#include "core/tsai_camera.h"
#include "damaged_bytes.h"
#include "map_scenes.h"

namespace occmap {
namespace {

using testing::AllocationCounter;
using testing::cellShares;
using testing::fillScene;
using testing::sceneCameraNames;

MapFrame sceneFrame(const MapGeometry& geometry, std::size_t cameras, std::int64_t number) {
  MapFrame frame(geometry, cameras);
  frame.utime = 1'700'000'000'000'000 + number * 33'333;
  fillScene(frame, number);
  return frame;
}

void expectSameMap(const MapFrame& sent, const DecodedMap& got,
                   const std::vector<std::string>& names) {
  ASSERT_TRUE(got.ok()) << got.error;
  EXPECT_EQ(got.seq, sent.seq);
  EXPECT_EQ(got.utime, sent.utime);
  EXPECT_EQ(got.geometry.width, sent.map.geometry.width);
  EXPECT_EQ(got.geometry.height, sent.map.geometry.height);
  EXPECT_EQ(got.geometry.cell_size_m, sent.map.geometry.cell_size_m);
  EXPECT_EQ(got.geometry.origin_x_m, sent.map.geometry.origin_x_m);
  EXPECT_EQ(got.geometry.origin_y_m, sent.map.geometry.origin_y_m);
  ASSERT_EQ(got.cells.size(), sent.map.cells.size());
  EXPECT_TRUE(
      std::equal(got.cells.begin(), got.cells.end(), sent.map.cells.begin(),
                 [](std::uint8_t a, CellState b) { return a == static_cast<std::uint8_t>(b); }))
      << "the cells differ";
  ASSERT_EQ(got.cameras.size(), sent.cameras.size());
  for (std::size_t k = 0; k < sent.cameras.size(); ++k) {
    EXPECT_EQ(got.cameras[k].name, names[k]);
    EXPECT_EQ(got.cameras[k].state, sent.cameras[k].state) << "camera " << k;
    EXPECT_EQ(got.cameras[k].used, sent.cameras[k].used) << "camera " << k;
    EXPECT_EQ(got.cameras[k].sequence, sent.cameras[k].sequence) << "camera " << k;
    EXPECT_EQ(got.cameras[k].capture_utime, sent.cameras[k].capture_time_us) << "camera " << k;
  }
}

TEST(MapEncoding, ParsesTheConfigWords) {
  EXPECT_EQ(parseMapEncoding("raw"), MapEncoding::kRaw);
  EXPECT_EQ(parseMapEncoding("zstd"), MapEncoding::kZstd);
  EXPECT_EQ(parseMapEncoding("ZSTD"), std::nullopt);
  EXPECT_EQ(parseMapEncoding(""), std::nullopt);
  EXPECT_STREQ(mapEncodingName(MapEncoding::kZstd), "zstd");
}

TEST(MapCodec, RoundTripsInBothEncodings) {
  const MapGeometry geometry{-1.25, 2.5, 0.035, 131, 77};  // odd sizes, not a power of two
  const std::vector<std::string> names = {"c0", "left door", "a-much-longer-camera-name-3"};
  for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
    MapEncoder encoder(geometry, names, encoding);
    MapDecoder decoder;
    for (std::int64_t n = 0; n < 10; ++n) {
      const MapFrame frame = sceneFrame(geometry, names.size(), n);
      const auto message = encoder.encode(frame);
      ASSERT_FALSE(message.empty()) << encoder.lastError();
      const DecodedMap& got = decoder.decode(message.data(), message.size());
      SCOPED_TRACE(std::string(mapEncodingName(encoding)) + " frame " + std::to_string(n));
      EXPECT_EQ(got.encoding, encoding);
      EXPECT_EQ(got.message_size, message.size());
      expectSameMap(frame, got, names);
    }
  }
}

TEST(MapCodec, RoundTripsAMapWithNoCamerasAndOneCell) {
  const MapGeometry geometry{0, 0, 1.0, 1, 1};
  for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
    MapEncoder encoder(geometry, {}, encoding);
    MapFrame frame(geometry, 0);
    frame.map.cells[0] = CellState::kOccupied;
    frame.seq = 42;
    const auto message = encoder.encode(frame);
    MapDecoder decoder;
    expectSameMap(frame, decoder.decode(message.data(), message.size()), {});
  }
}

TEST(MapCodec, EncoderRefusesFramesThatDoNotFit) {
  const MapGeometry geometry{0, 0, 0.02, 64, 32};
  MapEncoder encoder(geometry, sceneCameraNames(2), MapEncoding::kZstd);
  EXPECT_TRUE(encoder.encode(MapFrame({0, 0, 0.02, 32, 64}, 2)).empty());
  EXPECT_STRNE(encoder.lastError(), "");
  EXPECT_TRUE(encoder.encode(MapFrame(geometry, 3)).empty());
  EXPECT_FALSE(encoder.encode(MapFrame(geometry, 2)).empty());
  EXPECT_STREQ(encoder.lastError(), "");
  EXPECT_THROW(MapEncoder({0, 0, 0.02, 8193, 1}, {}, MapEncoding::kRaw), std::invalid_argument);
  EXPECT_THROW(MapEncoder({0, 0, 0.02, 0, 5}, {}, MapEncoding::kRaw), std::invalid_argument);
}

// The whole LCM message must fit one UDP datagram. LCM (lcm_udpm.c) sends a message as one
// datagram when the channel name, its NUL and the message take at most LCM_SHORT_MESSAGE_MAX_SIZE
// = 65 499 bytes (its 8-byte header comes on top); larger ones go in fragments, and the whole
// message is lost when one fragment is. Checked here with the header counted too.
TEST(MapCodec, A512x512MapFitsOneDatagramWithZstd) {
  const MapGeometry geometry{-0.5, -1.5, 0.02, 512, 512};
  const auto names = sceneCameraNames(4);
  MapEncoder encoder(geometry, names, MapEncoding::kZstd);
  MapDecoder decoder;
  std::size_t largest = 0;
  double seconds = 0;
  constexpr int kFrames = 12;
  for (std::int64_t n = 0; n < kFrames; ++n) {
    const MapFrame frame = sceneFrame(geometry, names.size(), 5 * n);
    const auto start = std::chrono::steady_clock::now();
    const auto message = encoder.encode(frame);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_FALSE(message.empty()) << encoder.lastError();
    largest = std::max(largest, message.size());
    expectSameMap(frame, decoder.decode(message.data(), message.size()), names);
    if (n == 0) {
      const auto shares = cellShares(frame.map.cells);
      std::printf("scene: %.1f %% free, %.1f %% occupied, %.1f %% unseen\n", 100 * shares.free,
                  100 * shares.occupied, 100 * shares.unseen);
      ASSERT_GT(shares.free, 0.5);
      ASSERT_GT(shares.occupied, 0.02);
      ASSERT_GT(shares.unseen, 0.15);
    }
  }
  const std::size_t datagram = 8 + std::string("OCCMAP_MAP").size() + 1 + largest;
  std::printf(
      "512 x 512 zstd map_frame_t: largest message %zu bytes (%zu in its datagram, "
      "LCM's limit 65499); encode %.3f ms on average\n",
      largest, datagram, 1000 * seconds / kFrames);
  EXPECT_LT(largest, 20000u) << "a realistic 512 x 512 map should compress far below a datagram";
  EXPECT_LE(datagram, 65499u);
}

// The same on maps that the reference fusion makes of the simulated room (columns of 0.3 m).
TEST(MapCodec, TheSimulatedRoomsMapsFitOneDatagramWithZstd) {
  const auto scene = sim::makeScene("room");
  const MapGeometry map{-0.62, -1.87, 0.02, 512, 512};
  std::vector<std::unique_ptr<sim::Renderer>> renderers;
  std::vector<CarveTable> tables;
  for (std::size_t k = 0; k < scene->cameras().size(); ++k) {
    renderers.push_back(std::make_unique<sim::Renderer>(
        *scene,
        Camera(std::make_shared<TsaiCamera>(scene->cameras()[k].calibration),
               LengthUnit::kMillimetre, 640, 480),
        static_cast<int>(k)));
    tables.push_back(
        buildCarveTable(renderers[k]->camera(), map, 0.3, renderers[k]->floorMask().view()));
  }
  MapEncoder encoder(map, sceneCameraNames(renderers.size()), MapEncoding::kZstd);
  std::size_t largest = 0;
  for (int n = 0; n < 3; ++n) {
    std::vector<Image> live(renderers.size());
    std::vector<CameraFrame> frames;
    for (std::size_t k = 0; k < renderers.size(); ++k) {
      renderers[k]->render(scene->objectsAt(2.3 * n), static_cast<std::uint64_t>(n), live[k]);
      frames.push_back({&tables[k], live[k].view(), renderers[k]->background().view(), 20});
    }
    MapFrame frame(map, renderers.size());
    frame.map = fuseReference(map, frames);
    const auto message = encoder.encode(frame);
    ASSERT_FALSE(message.empty()) << encoder.lastError();
    largest = std::max(largest, message.size());
  }
  std::printf("simulated room, 512 x 512 zstd map_frame_t: largest message %zu bytes\n", largest);
  EXPECT_LT(8 + 11 + largest, 65499u);
}

TEST(MapCodec, EncodeAllocatesNothingAfterConstruction) {
  const MapGeometry geometry{-0.5, -1.5, 0.02, 512, 512};
  const auto names = sceneCameraNames(4);
  std::vector<MapFrame> frames;
  for (std::int64_t n = 0; n < 8; ++n) frames.push_back(sceneFrame(geometry, names.size(), n));
  for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
    MapEncoder encoder(geometry, names, encoding);
    std::size_t total = 0;
    long allocations = 0;
    {
      AllocationCounter counter;
      for (int round = 0; round < 5; ++round) {
        for (const MapFrame& frame : frames) total += encoder.encode(frame).size();
      }
      allocations = counter.allocations();
    }
    EXPECT_EQ(allocations, 0) << mapEncodingName(encoding) << ": encode() allocated";
    EXPECT_GT(total, 0u);
  }
}

// ---------------------------------------------------------------------------------------------
// Hostile messages

// A valid message of a small map, built field by field so that tests can break any field.
struct MessageBuilder {
  occmap::map_frame_t message{};

  MessageBuilder(int width, int height, MapEncoding encoding, std::size_t cameras = 2) {
    message.utime = 1;
    message.seq = 7;
    message.width = width;
    message.height = height;
    message.cell_size_m = 0.02;
    message.encoding = static_cast<std::int8_t>(encoding);
    std::vector<std::uint8_t> cells(static_cast<std::size_t>(width) *
                                    static_cast<std::size_t>(height));
    for (std::size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<std::uint8_t>(i % 3);
    setCells(cells, encoding);
    message.num_cameras = static_cast<std::int16_t>(cameras);
    for (std::size_t k = 0; k < cameras; ++k) {
      occmap::camera_frame_t camera{};
      camera.name = "cam" + std::to_string(k);
      camera.state = 1;
      camera.used = true;
      camera.sequence = 3;
      camera.capture_utime = 2;
      message.cameras.push_back(camera);
    }
  }
  void setCells(const std::vector<std::uint8_t>& cells, MapEncoding encoding) {
    if (encoding == MapEncoding::kRaw) {
      message.data = cells;
    } else {
      message.data.resize(ZSTD_compressBound(cells.size()));
      message.data.resize(
          ZSTD_compress(message.data.data(), message.data.size(), cells.data(), cells.size(), 1));
    }
    message.data_size = static_cast<std::int32_t>(message.data.size());
  }
  std::vector<std::uint8_t> bytes() const {
    std::vector<std::uint8_t> out(static_cast<std::size_t>(message.getEncodedSize()));
    EXPECT_EQ(message.encode(out.data(), 0, static_cast<int>(out.size())),
              static_cast<int>(out.size()));
    return out;
  }
};

// Decodes `bytes`, expects a refusal whose text contains `why`, and checks that no allocation was
// larger than the message itself or a small constant.
void expectRefused(const std::vector<std::uint8_t>& bytes, const std::string& why,
                   std::size_t allowed_cells = 0) {
  MapDecoder decoder;
  std::size_t largest = 0;
  std::string error;
  {
    AllocationCounter counter;
    const DecodedMap& got = decoder.decode(bytes.data(), bytes.size());
    largest = counter.largest();
    error = got.error;
  }
  EXPECT_NE(error, "") << "accepted a message that should be refused for: " << why;
  EXPECT_NE(error.find(why), std::string::npos)
      << "refused for '" << error << "', expected '" << why << "'";
  EXPECT_LE(largest, std::max<std::size_t>({bytes.size(), allowed_cells, 4096}))
      << "allocated " << largest << " bytes for a " << bytes.size() << "-byte message";
}

// Where the fields sit in an encoded map_frame_t (after the 8-byte fingerprint).
constexpr std::size_t kWidthAt = 8 + 16, kHeightAt = kWidthAt + 4, kCellSizeAt = kHeightAt + 4,
                      kEncodingAt = kCellSizeAt + 24, kDataSizeAt = kEncodingAt + 1,
                      kDataAt = kDataSizeAt + 4;

void putBigEndian(std::vector<std::uint8_t>& bytes, std::size_t at, std::uint64_t value, int size) {
  for (int i = 0; i < size; ++i) {
    bytes[at + static_cast<std::size_t>(i)] =
        static_cast<std::uint8_t>(value >> (8 * (size - 1 - i)));
  }
}

TEST(MapDecoder, RefusesEveryTruncation) {
  for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
    const auto bytes = MessageBuilder(9, 7, encoding).bytes();
    MapDecoder decoder;
    ASSERT_TRUE(decoder.decode(bytes.data(), bytes.size()).ok());
    for (std::size_t size = 0; size < bytes.size(); ++size) {
      const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<long>(size));
      const DecodedMap& got = decoder.decode(cut.data(), cut.size());
      EXPECT_FALSE(got.ok()) << mapEncodingName(encoding) << ": accepted " << size << " of "
                             << bytes.size() << " bytes";
    }
    EXPECT_FALSE(decoder.decode(nullptr, 0).ok());
  }
  expectRefused({1, 2, 3}, "too short");
  expectRefused(std::vector<std::uint8_t>(20, 0), "fingerprint");
}

TEST(MapDecoder, RefusesOtherTypesAndTrailingBytes) {
  auto bytes = MessageBuilder(9, 7, MapEncoding::kRaw).bytes();
  auto wrong = bytes;
  wrong[3] ^= 0x40;
  expectRefused(wrong, "not an occmap.map_frame_t: fingerprint");
  occmap::status_t status{};
  status.hostname = "host";
  std::vector<std::uint8_t> status_bytes(static_cast<std::size_t>(status.getEncodedSize()));
  status.encode(status_bytes.data(), 0, static_cast<int>(status_bytes.size()));
  expectRefused(status_bytes, "not an occmap.map_frame_t");
  bytes.push_back(0);
  expectRefused(bytes, "1 bytes left over");
}

TEST(MapDecoder, RefusesBadHeaderFields) {
  const auto good = MessageBuilder(9, 7, MapEncoding::kRaw).bytes();
  auto bytes = good;
  putBigEndian(bytes, kWidthAt, 0, 4);
  expectRefused(bytes, "width 0 is outside 1..8192");
  bytes = good;
  putBigEndian(bytes, kHeightAt, static_cast<std::uint32_t>(-5), 4);
  expectRefused(bytes, "height -5 is outside");
  bytes = good;
  putBigEndian(bytes, kWidthAt, 100000, 4);
  putBigEndian(bytes, kHeightAt, 100000, 4);
  expectRefused(bytes, "width 100000 is outside");
  bytes = good;
  putBigEndian(bytes, kCellSizeAt, std::bit_cast<std::uint64_t>(std::nan("")), 8);
  expectRefused(bytes, "cell_size_m nan is not a positive number");
  bytes = good;
  putBigEndian(bytes, kCellSizeAt, std::bit_cast<std::uint64_t>(-0.02), 8);
  expectRefused(bytes, "is not a positive number");
  bytes = good;
  bytes[kEncodingAt] = 7;
  expectRefused(bytes, "unknown encoding 7");
}

TEST(MapDecoder, RefusesCountsThatDoNotAddUp) {
  const auto good = MessageBuilder(9, 7, MapEncoding::kRaw).bytes();
  auto bytes = good;
  putBigEndian(bytes, kDataSizeAt, static_cast<std::uint32_t>(-1), 4);
  expectRefused(bytes, "data_size -1 is negative");
  bytes = good;
  putBigEndian(bytes, kDataSizeAt, 0x7fffffff, 4);
  expectRefused(bytes, "truncated: data_size says 2147483647 bytes");
  bytes = good;
  putBigEndian(bytes, kDataSizeAt, 62, 4);  // one short of 9 * 7, the rest shifted
  expectRefused(bytes, "raw data_size 62 is not width * height = 63");
  // Raw sizes that agree with each other but not with width * height.
  MessageBuilder lying(9, 7, MapEncoding::kRaw);
  lying.message.width = 10;
  expectRefused(lying.bytes(), "raw data_size 63 is not width * height = 70");

  const std::size_t cameras_at = kDataAt + 63;
  bytes = good;
  putBigEndian(bytes, cameras_at, 0xffff, 2);
  expectRefused(bytes, "num_cameras -1 is negative");
  bytes = good;
  putBigEndian(bytes, cameras_at, 32767, 2);
  expectRefused(bytes, "camera 2 of 32767");
  bytes = good;
  putBigEndian(bytes, cameras_at, 1, 2);
  expectRefused(bytes, "bytes left over");
  for (const std::uint32_t name_size : {0u, 0xffffffffu, 0x7fffffffu, 1000u}) {
    bytes = good;
    putBigEndian(bytes, cameras_at + 2, name_size, 4);
    expectRefused(bytes, "camera 0 of 2: a name of");
  }
  bytes = good;
  bytes[cameras_at + 2 + 4 + 4] = 'x';  // "cam0\0" loses its NUL
  expectRefused(bytes, "does not end in NUL");
  bytes = good;
  bytes[cameras_at + 2 + 4 + 5] = 9;  // the state of camera 0
  expectRefused(bytes, "camera 0 of 2: unknown state 9");
  bytes = good;
  bytes[cameras_at + 2 + 4 + 5 + 1] = 2;  // 'used'
  expectRefused(bytes, "not a boolean");
}

TEST(MapDecoder, RefusesCellValuesAboveTwo) {
  for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
    MessageBuilder builder(9, 7, encoding);
    std::vector<std::uint8_t> cells(63, 0);
    cells[2 * 9 + 4] = 3;
    builder.setCells(cells, encoding);
    expectRefused(builder.bytes(), "cell (row 2, column 4) is 3");
  }
}

TEST(MapDecoder, RefusesZstdFramesThatLie) {
  std::vector<std::uint8_t> cells(9 * 7, 1);
  // A frame of 64 bytes for a 63-cell map: refused from its header, before decompressing.
  MessageBuilder builder(9, 7, MapEncoding::kZstd);
  std::vector<std::uint8_t> longer(64, 1);
  builder.setCells(longer, MapEncoding::kZstd);
  expectRefused(builder.bytes(), "the zstd frame says it holds 64 bytes, but width * height = 63");
  // A frame that claims 64 MiB (the largest map) for a 9 x 7 map: nothing near that is allocated.
  builder.setCells(cells, MapEncoding::kZstd);
  std::vector<std::uint8_t> big(8192u * 8192u, 0);
  builder.setCells(big, MapEncoding::kZstd);
  expectRefused(builder.bytes(), "says it holds 67108864 bytes");
  // The same frame on an 8192 x 8192 map is a valid map: that is what the limit allows.
  builder.message.width = 8192;
  builder.message.height = 8192;
  {
    MapDecoder decoder;
    const auto bytes = builder.bytes();
    EXPECT_TRUE(decoder.decode(bytes.data(), bytes.size()).ok());
  }
  big = {};
  // No content size in the frame header.
  builder = MessageBuilder(9, 7, MapEncoding::kZstd);
  {
    ZSTD_CCtx* context = ZSTD_createCCtx();
    ZSTD_CCtx_setParameter(context, ZSTD_c_contentSizeFlag, 0);
    std::vector<std::uint8_t> frame(ZSTD_compressBound(cells.size()));
    ZSTD_inBuffer in{cells.data(), cells.size(), 0};
    ZSTD_outBuffer out{frame.data(), frame.size(), 0};
    ZSTD_compressStream2(context, &out, &in, ZSTD_e_end);
    ZSTD_freeCCtx(context);
    frame.resize(out.pos);
    builder.message.data = frame;
    builder.message.data_size = static_cast<std::int32_t>(frame.size());
  }
  expectRefused(builder.bytes(), "does not declare its content size");
  // Not zstd at all.
  builder.message.data = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  builder.message.data_size = 9;
  expectRefused(builder.bytes(), "not a zstd frame");
  builder.message.data_size = 0;
  builder.message.data.clear();
  expectRefused(builder.bytes(), "the zstd data is empty");
  // A good frame with bytes after it.
  builder.setCells(cells, MapEncoding::kZstd);
  builder.message.data.push_back(0);
  builder.message.data_size += 1;
  expectRefused(builder.bytes(), "1 bytes after its zstd frame");
  // A good header over a damaged body.
  builder.setCells(cells, MapEncoding::kZstd);
  builder.message.data.resize(builder.message.data.size() - 2);
  builder.message.data_size -= 2;
  expectRefused(builder.bytes(), "corrupt zstd frame");
}

// Random damage to valid messages: never a crash or an allocation beyond the message and the cells
// its header declares (ASan runs this too); whatever is accepted is a valid map.
TEST(MapDecoder, SurvivesRandomDamage) {
  std::mt19937 rng(11);
  std::vector<std::vector<std::uint8_t>> originals;
  for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
    originals.push_back(MessageBuilder(33, 17, encoding, 3).bytes());
  }
  MapDecoder decoder;
  int accepted = 0;
  for (int trial = 0; trial < 6000; ++trial) {
    std::vector<std::uint8_t> bytes = originals[static_cast<std::size_t>(trial) % 2];
    testing::damageBytes(bytes, rng);
    std::size_t largest = 0;
    bool ok = false;
    {
      AllocationCounter counter;
      const DecodedMap& got = decoder.decode(bytes.data(), bytes.size());
      largest = counter.largest();
      ok = got.ok();
      if (ok) {
        ASSERT_EQ(got.cells.size(), got.geometry.cellCount());
        for (const std::uint8_t c : got.cells) ASSERT_LE(c, 2);
      } else {
        ASSERT_TRUE(got.cells.empty());
      }
    }
    accepted += ok;
    // The cells are the only allocation a header can size, and they are allocated only once the
    // data has been shown to hold exactly width * height cells; here those are 561 bytes.
    ASSERT_LE(largest, std::max<std::size_t>(bytes.size(), 4096)) << "trial " << trial;
  }
  std::printf("%d of 6000 damaged messages still decoded (damage to seq, times, camera fields)\n",
              accepted);
}

}  // namespace
}  // namespace occmap
