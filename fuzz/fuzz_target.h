#pragma once
// What the fuzz targets share (docs/fuzzing.md). A target takes one input that a stranger can hand
// occmap, handles it as the program that receives it does, and returns whether it was accepted.
// Being refused the documented way (an InputError for a file, "undecodable" for a message) is an
// expected outcome. Anything else is a finding: a crash, a sanitizer report, a hang, an exception
// of another type escaping, or a Finding, which a target throws when an input it accepted breaks a
// promise made about accepted input (a map cell above 2, a config whose map encoding the daemon
// cannot make, a status table that writes control characters to the user's terminal).
//
// The same functions run two ways: under libFuzzer, each target its own binary built with
// OCCMAP_LIBFUZZER (fuzz/CMakeLists.txt, clang), and in tests/fuzz_regression_test.cpp (the normal
// build), which replays every seed in fuzz/corpus/ and every input ever found in fuzz/regressions/.

#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "transport/control_message.h"

namespace occmap::fuzz {

using Input = std::span<const std::uint8_t>;

// An accepted input that breaks a promise; its message names the promise.
class Finding : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

inline void require(bool holds, const std::string& promise) {
  if (!holds) throw Finding(promise);
}

inline std::string_view asText(Input input) {
  return {reinterpret_cast<const char*>(input.data()), input.size()};
}

// The targets. Each one's name is its folder under fuzz/corpus/ and fuzz/regressions/ and, after
// "fuzz_", its binary.
bool fuzzConfig(Input input);                // config: occmapd's config file
bool fuzzTsaiCalibration(Input input);       // tsai_calibration: ETISEO/PETS XML
bool fuzzOpenCvCalibration(Input input);     // opencv_calibration: cv::FileStorage YAML
bool fuzzOpenCvXmlCalibration(Input input);  // opencv_xml_calibration: cv::FileStorage XML
bool fuzzStatusRequest(Input input);         // status_request: status_request_t, read by occmapd
bool fuzzMapFrame(Input input);              // map_frame: map_frame_t, read by occmap view
bool fuzzStatus(Input input);                // status: status_t, read by occmap status
bool fuzzControlRequest(Input input);        // control_request: control_request_t, read by occmapd
bool fuzzControlStatus(Input input);   // control_status: control_status_t, read by occmap status
bool fuzzControlReply(Input input);    // control_reply: control_reply_t, read by occmap control
bool fuzzLightingStatus(Input input);  // lighting_status: lighting_status_t, read by occmap status
bool fuzzViewStatus(Input input);      // view_status: view_status_t, read by occmap status
bool fuzzTracks(Input input);          // tracks: tracks_t, read by occmap status
bool fuzzZones(Input input);           // zones: zones_t, read by occmap status
bool fuzzMapTile(Input input);         // map_tile: map_tile_t messages, put together by MapReceiver
bool fuzzMergeStatus(Input input);     // merge_status: merge_status_t, read by occmap status
bool fuzzCameraPreview(Input input);   // camera_preview: camera_preview_t, read by occmap web
bool fuzzCameraPreviewRequest(Input input);  // camera_preview_request: read by occmapd

// The key the control_request seeds are signed with (fuzz_make_seeds): bytes 0, 1, ..., 31. Not
// a secret: it exists so that fuzzing starts from requests whose mac holds.
inline const ControlKey& controlFuzzKey() {
  static const ControlKey key = [] {
    ControlKey made;
    made.size = ControlKey::kMinBytes;
    for (std::size_t i = 0; i < made.size; ++i) made.bytes[i] = static_cast<std::uint8_t>(i);
    return made;
  }();
  return key;
}

struct Target {
  const char* name;
  bool (*run)(Input input);
};

inline constexpr Target kTargets[] = {
    {"config", fuzzConfig},
    {"tsai_calibration", fuzzTsaiCalibration},
    {"opencv_calibration", fuzzOpenCvCalibration},
    {"opencv_xml_calibration", fuzzOpenCvXmlCalibration},
    {"status_request", fuzzStatusRequest},
    {"map_frame", fuzzMapFrame},
    {"status", fuzzStatus},
    {"control_request", fuzzControlRequest},
    {"control_status", fuzzControlStatus},
    {"control_reply", fuzzControlReply},
    {"lighting_status", fuzzLightingStatus},
    {"view_status", fuzzViewStatus},
    {"tracks", fuzzTracks},
    {"zones", fuzzZones},
    {"map_tile", fuzzMapTile},
    {"merge_status", fuzzMergeStatus},
    {"camera_preview", fuzzCameraPreview},
    {"camera_preview_request", fuzzCameraPreviewRequest},
};

}  // namespace occmap::fuzz

// libFuzzer's entry point, in the fuzz binaries only: the regression test links every target into
// one program. An exception escaping it terminates the process, which libFuzzer reports as a crash.
#ifdef OCCMAP_LIBFUZZER
#define OCCMAP_FUZZ_ENTRY(function)                                                   \
  extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) { \
    (void)function(occmap::fuzz::Input(data, size));                                  \
    return 0;                                                                         \
  }
#else
#define OCCMAP_FUZZ_ENTRY(function)
#endif
