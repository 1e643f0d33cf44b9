// The page of `occmap web` in a real browser (issue 17): headless Chromium (Debian's `chromium`),
// driven over its DevTools protocol, loads the page against the simulated room's occmapd in a
// private network namespace. The map on the canvas is the map (sampled pixels against /map.png of
// the same seq), the camera table is what `occmap status --json` says, a camera made to fail shows
// as down within 2 s, and the page recovers by itself when occmapd restarts and when the server
// does. Skips without Chromium or without a network namespace.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include "command_runner.h"
#include "network_namespace.h"
#include "tsai_xml.h"
#include "web_test_support.h"

namespace occmap {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using testing::eventually;
using testing::FeedSocket;
using testing::httpRequest;
using testing::kSanitized;
using testing::runCommand;
using testing::TemporaryFolder;
using testing::WebProcess;
using testing::WebTestDaemon;
using Json = nlohmann::json;

// Chromium on the PATH (Debian's package `chromium`), or "".
std::string findChromium() {
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/bin:/bin";
  for (std::size_t start = 0; start <= dirs.size();) {
    const std::size_t end = std::min(dirs.find(':', start), dirs.size());
    for (const char* name : {"chromium", "chromium-browser"}) {
      const fs::path candidate = fs::path(dirs.substr(start, end - start)) / name;
      if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
    }
    start = end + 1;
  }
  return "";
}

// Headless Chromium in a process group of its own (its renderer and helper processes go with it),
// with a DevTools port of its choosing.
class Browser {
 public:
  Browser(const std::string& chromium, const fs::path& profile, const fs::path& log) : log_(log) {
    std::fflush(nullptr);
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::setpgid(0, 0);
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(125);
      if (std::freopen(log.c_str(), "w", stderr) == nullptr) ::_exit(126);
      if (std::freopen("/dev/null", "w", stdout) == nullptr) ::_exit(126);
      const std::string profile_flag = "--user-data-dir=" + profile.string();
      // As root Chromium runs only without its sandbox; no GPU here; timers and animation
      // frames at full rate although no one looks.
      const char* argv[] = {chromium.c_str(),
                            "--headless=new",
                            "--no-sandbox",
                            "--disable-gpu",
                            "--remote-debugging-port=0",
                            profile_flag.c_str(),
                            "--no-first-run",
                            "--no-default-browser-check",
                            "--disable-extensions",
                            "--disable-background-networking",
                            "--disable-component-update",
                            "--disable-sync",
                            "--disable-background-timer-throttling",
                            "--disable-renderer-backgrounding",
                            "--disable-backgrounding-occluded-windows",
                            "--window-size=1400,1000",
                            "about:blank",
                            nullptr};
      ::execv(argv[0], const_cast<char* const*>(argv));
      ::_exit(127);
    }
    if (pid_ > 0) ::setpgid(pid_, pid_);
  }
  ~Browser() {
    if (pid_ > 0) {
      ::kill(-pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  Browser(const Browser&) = delete;
  Browser& operator=(const Browser&) = delete;

  // The port and path of "DevTools listening on ws://127.0.0.1:PORT/devtools/browser/ID".
  std::optional<std::pair<std::uint16_t, std::string>> devTools() const {
    const std::string said = "DevTools listening on ws://127.0.0.1:";
    const auto end = std::chrono::steady_clock::now() + eventually(20s);
    while (std::chrono::steady_clock::now() < end) {
      const std::string log = testing::readWhole(log_);
      const std::size_t at = log.find(said);
      if (at != std::string::npos && log.find('\n', at) != std::string::npos) {
        const std::size_t port_at = at + said.size();
        const std::size_t slash = log.find('/', port_at);
        const std::size_t line_end = log.find('\n', at);
        return std::pair{static_cast<std::uint16_t>(std::stoi(log.substr(port_at))),
                         log.substr(slash, line_end - slash)};
      }
      std::this_thread::sleep_for(50ms);
    }
    return std::nullopt;
  }
  std::string log() const { return testing::readWhole(log_); }

 private:
  fs::path log_;
  pid_t pid_ = -1;
};

// Chromium's DevTools protocol over its WebSocket: commands and their answers, for one page.
class DevTools {
 public:
  DevTools(std::uint16_t port, const std::string& path) : socket_(port, "", path) {}
  bool connected() const { return socket_.connected(); }
  const std::string& error() const { return socket_.error(); }

  // The command's "result", or nothing (an error answer, or none in time).
  std::optional<Json> call(const std::string& method, const Json& params = Json::object(),
                           std::chrono::milliseconds timeout = eventually(10s)) {
    const int id = ++last_id_;
    Json command = {{"id", id}, {"method", method}, {"params", params}};
    if (!session_.empty()) command["sessionId"] = session_;
    if (!socket_.write(command.dump())) return std::nullopt;
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      const auto message = socket_.read(timeout);
      if (!message) return std::nullopt;
      const Json answer = Json::parse(message->data, nullptr, false);
      if (!answer.is_object() || !answer.contains("id") || answer["id"] != id) continue;  // events
      if (answer.contains("error")) {
        last_error_ = answer["error"].dump();
        return std::nullopt;
      }
      return answer["result"];
    }
    return std::nullopt;
  }

  // Opens `url` in a new page; the commands after go to it.
  bool open(const std::string& url) {
    const auto target = call("Target.createTarget", {{"url", url}});
    if (!target) return false;
    const auto attached =
        call("Target.attachToTarget", {{"targetId", (*target)["targetId"]}, {"flatten", true}});
    if (!attached) return false;
    session_ = (*attached)["sessionId"].get<std::string>();
    return true;
  }

  // The value of a JavaScript expression in the page (null when it threw, or on no answer).
  Json evaluate(const std::string& expression) {
    const auto result =
        call("Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}});
    if (!result || result->contains("exceptionDetails")) return nullptr;
    const Json& value = (*result)["result"];
    return value.contains("value") ? value["value"] : Json();
  }

  // Evaluates `expression` every 50 ms until `accept` takes its value (returned) or `timeout`.
  template <typename Accept>
  std::optional<Json> waitFor(const std::string& expression, Accept accept,
                              std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    do {
      Json value = evaluate(expression);
      if (accept(value)) return value;
      std::this_thread::sleep_for(50ms);
    } while (std::chrono::steady_clock::now() < end);
    return std::nullopt;
  }

  const std::string& lastError() const { return last_error_; }

 private:
  FeedSocket socket_;
  std::string session_;
  int last_id_ = 0;
  std::string last_error_;
};

// What the page's tables say of the cameras: [host, camera, state] for each row.
const char* const kCameraRows =
    "[...document.querySelectorAll('tr[data-camera]')].map("
    "r => [r.dataset.host, r.dataset.camera, r.dataset.state])";
// The page's probe (web/page/app.js): the seq drawn and the colour of every fourth cell.
const char* const kProbe =
    "(() => { const cells = []; for (let r = 1; r < 256; r += 4) for (let c = 1; c < 256; c += 4) "
    "cells.push([r, c]); return window.occmapProbe ? window.occmapProbe(cells) : null; })()";
const char* const kDoorState =
    "(() => { const r = document.querySelector('tr[data-camera=\"door\"]'); "
    "return r ? [r.dataset.state, r.cells[6].textContent, r.cells[5].textContent] : null; })()";

class WebBrowser : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    problem_ = new std::string;
    const std::string chromium = findChromium();
    if (chromium.empty()) {
      *problem_ =
          "no Chromium (Debian's package `chromium`, scripts/setup installs it) to load "
          "the page in";
      return;
    }
    *problem_ = testing::enterPrivateNetwork();
    if (!problem_->empty()) return;
    folder_ = new TemporaryFolder;
    // A fifth camera besides the simulator's four: a files:// camera looking down at the floor
    // whose pictures the test can take away (as a camera that stops delivering).
    folder_->write("door.xml", testing::kDownwardXml);
    const cv::Mat grey(100, 100, CV_8UC1, cv::Scalar(120));
    cv::imwrite((*folder_ / "door-background.png").string(), grey);
    fs::create_directories(*folder_ / "door");
    cv::imwrite((*folder_ / "door" / "frame1.png").string(), grey);
    cv::imwrite((*folder_ / "door" / "frame2.png").string(), grey);
    config_ = new std::string(testing::webRoomConfig(
        "  - {name: door, source: \"files://door/*.png\", calibration: door.xml, background: "
        "door-background.png, fps: 30}\n"));
    daemon_ = new std::optional<WebTestDaemon>(std::in_place, *folder_, *config_, "occmapd");
    daemon_ready_ = (*daemon_)->ready();
    web_ = new std::optional<WebProcess>(std::in_place, *folder_, "web");
    web_serving_ = (*web_)->serving();
    browser_ = new Browser(chromium, *folder_ / "chromium", *folder_ / "chromium.log");
    if (const auto endpoint = browser_->devTools()) {
      devtools_ = new DevTools(endpoint->first, endpoint->second);
      page_open_ = devtools_->connected() &&
                   devtools_->open("http://127.0.0.1:" + std::to_string((*web_)->port) + "/");
    }
  }
  static void TearDownTestSuite() {
    delete devtools_;
    delete browser_;
    delete web_;
    delete daemon_;
    delete config_;
    delete folder_;
    delete problem_;
    devtools_ = nullptr;
    browser_ = nullptr;
    web_ = nullptr;
    daemon_ = nullptr;
    config_ = nullptr;
    folder_ = nullptr;
    problem_ = nullptr;
  }
  void SetUp() override {
    if (!problem_->empty()) GTEST_SKIP() << *problem_;
    ASSERT_TRUE(daemon_ready_) << (*daemon_)->process.err();
    ASSERT_TRUE(web_serving_) << (*web_)->process.err();
    ASSERT_NE(devtools_, nullptr) << "Chromium gave no DevTools address:\n" << browser_->log();
    ASSERT_TRUE(page_open_) << devtools_->error() << devtools_->lastError() << browser_->log();
  }

  static std::uint16_t port() { return (*web_)->port; }

  // Waits until the page has drawn a map; its probe.
  static Json drawnMap(std::chrono::milliseconds timeout = eventually(15s)) {
    return devtools_
        ->waitFor(
            kProbe, [](const Json& v) { return v.is_object(); }, timeout)
        .value_or(Json());
  }

  // `occmap status --json`'s cameras as [host, camera, state].
  static Json statusCameras() {
    const auto printed =
        runCommand({testing::kOccmap, "status", "--lcm-url", testing::kLcmUrl, "--json"});
    Json rows = Json::array();
    if (printed.exit_code != 0) return rows;
    const Json status = Json::parse(printed.out);
    for (const Json& camera : status["cameras"]) {
      rows.push_back({status["hostname"], camera["name"], camera["state_name"]});
    }
    return rows;
  }

  static std::string* problem_;
  static TemporaryFolder* folder_;
  static std::string* config_;
  static std::optional<WebTestDaemon>* daemon_;
  static std::optional<WebProcess>* web_;
  static Browser* browser_;
  static DevTools* devtools_;
  static bool daemon_ready_, web_serving_, page_open_;
};

std::string* WebBrowser::problem_ = nullptr;
TemporaryFolder* WebBrowser::folder_ = nullptr;
std::string* WebBrowser::config_ = nullptr;
std::optional<WebTestDaemon>* WebBrowser::daemon_ = nullptr;
std::optional<WebProcess>* WebBrowser::web_ = nullptr;
Browser* WebBrowser::browser_ = nullptr;
DevTools* WebBrowser::devtools_ = nullptr;
bool WebBrowser::daemon_ready_ = false;
bool WebBrowser::web_serving_ = false;
bool WebBrowser::page_open_ = false;

TEST_F(WebBrowser, TheCanvasShowsTheNewestMapAsMapPngDrawsIt) {
  // Once the page has been taking maps for a second (not just the first after loading).
  const Json probe =
      devtools_
          ->waitFor(
              kProbe, [](const Json& v) { return v.is_object() && v["received"].get<int>() >= 30; },
              eventually(15s))
          .value_or(Json());
  ASSERT_TRUE(probe.is_object()) << "the page drew no map:\n" << browser_->log();
  const std::int64_t seq = probe["seq"].get<std::int64_t>();
  // 503 is the server saying its picture thread has too many pictures waiting (the page's own
  // among them; slow under a sanitizer, where a clean run once got it): asked again, as the answer
  // says, while the map is still among the last 30 held.
  testing::HttpAnswer same = httpRequest(port(), "/map.png?seq=" + std::to_string(seq));
  for (int again = 0; same.status == 503 && again < 20; ++again) {
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
    same = httpRequest(port(), "/map.png?seq=" + std::to_string(seq));
  }
  ASSERT_EQ(same.status, 200) << "map " << seq << ": " << same.body;
  const testing::HttpAnswer newest = httpRequest(port(), "/map.png");
  ASSERT_EQ(newest.status, 200);
  const std::int64_t newest_seq = std::atoll(newest.header("x-map-seq").c_str());
  std::printf(
      "the page drew map %lld (%d pixels a cell; it had received %d maps and skipped %d); "
      "the newest was %lld\n",
      static_cast<long long>(seq), probe["scale"].get<int>(), probe["received"].get<int>(),
      probe["dropped"].get<int>(), static_cast<long long>(newest_seq));
  // The newest, give or take the maps that came while the probe's answer and the two requests
  // travelled (30 a second).
  EXPECT_LE(newest_seq - seq, kSanitized ? 120 : 30) << "the page shows an old map";
  EXPECT_EQ(probe["width"], 256);
  EXPECT_EQ(probe["height"], 256);

  const cv::Mat plan =
      cv::imdecode(std::vector<std::uint8_t>(same.body.begin(), same.body.end()), cv::IMREAD_COLOR);
  ASSERT_FALSE(plan.empty());
  const int per_cell = plan.cols / 256;
  const cv::Vec3b cell_colours[] = {{245, 245, 245}, {35, 35, 35}, {170, 140, 120}};
  int compared = 0, differ = 0, index = 0;
  std::string first_difference;
  for (int r = 1; r < 256; r += 4) {
    for (int c = 1; c < 256; c += 4, ++index) {
      const cv::Vec3b png =
          plan.at<cv::Vec3b>((255 - r) * per_cell + per_cell / 2, c * per_cell + per_cell / 2);
      if (std::find(std::begin(cell_colours), std::end(cell_colours), png) ==
          std::end(cell_colours)) {
        continue;  // the scale bar drawn over the PNG
      }
      const Json& rgb = probe["colours"][static_cast<std::size_t>(index)];
      ++compared;
      if (rgb[0] != png[2] || rgb[1] != png[1] || rgb[2] != png[0]) {
        if (differ++ == 0) {
          first_difference = "cell (" + std::to_string(r) + ", " + std::to_string(c) +
                             "): canvas " + rgb.dump() + ", /map.png BGR " +
                             std::to_string(png[0]) + "," + std::to_string(png[1]) + "," +
                             std::to_string(png[2]);
        }
      }
    }
  }
  EXPECT_GT(compared, 64 * 64 * 95 / 100);
  EXPECT_EQ(differ, 0) << "of " << compared << " cells sampled; first " << first_difference;
}

TEST_F(WebBrowser, TheCameraTableIsWhatOccmapStatusSays) {
  const Json printed = statusCameras();
  ASSERT_EQ(printed.size(), 5u) << printed.dump();
  const auto shown = devtools_->waitFor(
      kCameraRows, [&](const Json& rows) { return rows == printed; }, eventually(5s));
  EXPECT_TRUE(shown) << "page: " << devtools_->evaluate(kCameraRows).dump()
                     << "\noccmap status: " << printed.dump();
  for (const Json& row : printed) EXPECT_EQ(row[2], "streaming") << row.dump();
  // The zone is listed with its state, the map channel's companions on the page.
  const Json zone = devtools_->evaluate(
      "(() => { const r = document.querySelector('tr[data-zone=\"walkway\"]'); "
      "return r ? r.dataset.state : null; })()");
  EXPECT_TRUE(zone == "free" || zone == "occupied" || zone == "unseen") << zone.dump();
  // A card per camera.
  EXPECT_EQ(devtools_->evaluate("document.querySelectorAll('.camera-card').length"), 5);
}

// Each camera card shows the camera's picture (the daemon's preview, asked for while the page is
// open) with its changed pixels over it; the pointer over a card highlights that camera's cells on
// the map; the coverage switch shows /coverage.png over the map.
TEST_F(WebBrowser, EachCameraCardShowsItsPictureAndHoveringHighlightsItsCells) {
  constexpr const char* kPictures =
      "Array.from(document.querySelectorAll('.camera-card')).map((card) => {"
      "  const f = card.querySelector('img.frame'), c = card.querySelector('img.changed');"
      "  return [card.dataset.camera, f && f.complete ? f.naturalWidth : 0,"
      "          c && c.complete ? c.naturalWidth : 0]; })";
  const auto all_loaded = [](const Json& v) {
    return v.is_array() && v.size() == 5 && std::all_of(v.begin(), v.end(), [](const Json& card) {
             return card[1].get<int>() > 0 && card[2].get<int>() > 0;
           });
  };
  const auto started = std::chrono::steady_clock::now();
  const auto loaded = devtools_->waitFor(kPictures, all_loaded, eventually(8s));
  ASSERT_TRUE(loaded) << devtools_->evaluate(kPictures).dump();
  std::printf("every camera's picture and changed pixels showed within %.2f s: %s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(),
              loaded->dump().c_str());
  // The simulated room's cameras are 640 x 480: previews of 320 x 240 (the door's is smaller).
  for (const Json& card : *loaded) {
    if (card[0] != "door") {
      EXPECT_EQ(card[1], 320) << card.dump();
    }
  }

  // The pointer over c1's card: the page says so, and draws its cells over the map.
  const Json entered = devtools_->evaluate(
      "(() => { const card = document.querySelector('.camera-card[data-camera=\"c1\"]');"
      " card.dispatchEvent(new MouseEvent('mouseenter')); return card.dataset.host; })()");
  ASSERT_TRUE(entered.is_string()) << entered.dump();
  const std::string highlighted = entered.get<std::string>() + "/c1";
  const std::string cells_expression =
      "(() => { const c = document.getElementById('cells'); "
      "return [document.body.dataset.highlighted || null, c.hidden, c.naturalWidth]; })()";
  const auto shown = devtools_->waitFor(
      cells_expression,
      [&](const Json& v) {
        return v.is_array() && v[0] == highlighted && v[1] == false && v[2] == 256;
      },
      eventually(3s));
  EXPECT_TRUE(shown) << devtools_->evaluate(cells_expression).dump();
  devtools_->evaluate(
      "document.querySelector('.camera-card[data-camera=\"c1\"]')"
      ".dispatchEvent(new MouseEvent('mouseleave'))");
  EXPECT_EQ(devtools_->evaluate(cells_expression)[0], nullptr);
  EXPECT_EQ(devtools_->evaluate(cells_expression)[1], true);

  // The coverage switch.
  devtools_->evaluate("document.getElementById('show-coverage').click()");
  const auto coverage = devtools_->waitFor(
      "(() => { const c = document.getElementById('coverage'); "
      "return [c.hidden, c.naturalWidth]; })()",
      [](const Json& v) { return v.is_array() && v[0] == false && v[1] == 256; }, eventually(3s));
  EXPECT_TRUE(coverage) << "the coverage picture did not show";

  // For docs/web.md: the page with the previews, taken when asked (OCCMAP_WEB_SCREENSHOT=FILE,
  // written as base64; `base64 -d` makes the PNG).
  if (const char* screenshot = std::getenv("OCCMAP_WEB_SCREENSHOT")) {
    devtools_->evaluate("document.getElementById('show-coverage').click()");
    devtools_->evaluate(
        "document.querySelector('.camera-card[data-camera=\"c1\"]')"
        ".dispatchEvent(new MouseEvent('mouseenter'))");
    std::this_thread::sleep_for(1500ms);
    const auto shot = devtools_->call("Page.captureScreenshot", {{"format", "png"}});
    ASSERT_TRUE(shot) << devtools_->lastError();
    std::ofstream(screenshot) << (*shot)["data"].get<std::string>();
  } else {
    devtools_->evaluate("document.getElementById('show-coverage').click()");
  }
}

TEST_F(WebBrowser, ACameraMadeToFailShowsAsDownWithinTwoSeconds) {
  const auto streaming = [](const Json& v) { return v.is_array() && v[0] == "streaming"; };
  ASSERT_TRUE(devtools_->waitFor(kDoorState, streaming, eventually(5s)))
      << devtools_->evaluate(kDoorState).dump();
  // The camera's pictures go away: every read fails, no frame arrives.
  fs::rename(*folder_ / "door", *folder_ / "door-away");
  const auto failed_at = std::chrono::steady_clock::now();
  const auto down = devtools_->waitFor(
      kDoorState, [](const Json& v) { return v.is_array() && v[0] == "down"; }, eventually(5s));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - failed_at).count();
  fs::rename(*folder_ / "door-away", *folder_ / "door");
  ASSERT_TRUE(down) << "not down after " << seconds
                    << " s: " << devtools_->evaluate(kDoorState).dump();
  std::printf("the page showed the camera down %.2f s after its pictures went: %s\n", seconds,
              down->dump().c_str());
  if (!kSanitized) {
    EXPECT_LT(seconds, 2.0);
  }
  EXPECT_FALSE((*down)[1].get<std::string>().empty()) << "no last error shown";
  EXPECT_TRUE((*down)[2].get<std::string>().starts_with("down: ")) << down->dump();
  // And back when its pictures are.
  EXPECT_TRUE(devtools_->waitFor(kDoorState, streaming, eventually(10s)))
      << devtools_->evaluate(kDoorState).dump();
}

TEST_F(WebBrowser, ThePageRecoversByItselfWhenOccmapdRestarts) {
  const Json before = drawnMap();
  ASSERT_TRUE(before.is_object());
  ASSERT_EQ((*daemon_)->stop(), 0) << (*daemon_)->process.err();
  // No map: the page says so.
  EXPECT_TRUE(devtools_->waitFor(
      "document.body.dataset.stale", [](const Json& v) { return v == "yes"; }, eventually(6s)))
      << "the page does not say that maps stopped";
  const std::int64_t last_seq = drawnMap()["seq"].get<std::int64_t>();
  // The same config file: the same daemon to the page, back.
  daemon_->emplace(*folder_, *config_, "occmapd-again", "occmapd");
  ASSERT_TRUE((*daemon_)->ready()) << (*daemon_)->process.err();
  const auto started = std::chrono::steady_clock::now();
  // The restarted daemon numbers its maps from 0 again: a seq below the last is its map.
  const auto again = devtools_->waitFor(
      kProbe,
      [&](const Json& v) {
        return v.is_object() && v["seq"].get<std::int64_t>() < last_seq &&
               devtools_->evaluate("document.body.dataset.stale") == "no";
      },
      eventually(10s));
  ASSERT_TRUE(again) << "the page shows no map of the restarted daemon";
  std::printf("the page drew the restarted daemon's map %lld %.2f s after it was ready\n",
              static_cast<long long>((*again)["seq"].get<std::int64_t>()),
              std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  const Json printed = statusCameras();
  EXPECT_TRUE(devtools_->waitFor(
      kCameraRows, [&](const Json& rows) { return rows == printed; }, eventually(5s)))
      << devtools_->evaluate(kCameraRows).dump() << " vs " << printed.dump();
}

TEST_F(WebBrowser, ThePageReconnectsByItselfWhenTheServerRestarts) {
  const std::uint16_t web_port = port();
  ASSERT_EQ((*web_)->stop(), 0) << (*web_)->process.err();
  EXPECT_TRUE(devtools_->waitFor(
      "document.body.dataset.connection", [](const Json& v) { return v == "closed"; },
      eventually(8s)))
      << "the page did not notice the server went";
  const std::int64_t seq_gone = drawnMap()["seq"].get<std::int64_t>();
  web_->emplace(*folder_, "web-again", web_port);
  ASSERT_TRUE((*web_)->serving()) << (*web_)->process.err();
  const auto started = std::chrono::steady_clock::now();
  const auto back = devtools_->waitFor(
      kProbe,
      [&](const Json& v) {
        return v.is_object() && v["seq"].get<std::int64_t>() > seq_gone &&
               devtools_->evaluate("document.body.dataset.connection") == "open";
      },
      eventually(10s));
  ASSERT_TRUE(back) << "the page did not reconnect";
  std::printf("the page was back %.2f s after the server\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
}

}  // namespace
}  // namespace occmap
