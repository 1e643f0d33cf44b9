// The fuzz targets' inputs, replayed in the normal build (and under ASan + UBSan in build-asan/):
// every seed in fuzz/corpus/<target>/ and every input fuzzing ever found in
// fuzz/regressions/<target>/, through the very functions the libFuzzer binaries call
// (fuzz/fuzz_target.h), each in a child process of its own. A refusal the documented way is fine;
// a crash, a sanitizer report, a hang or an exception escaping is the finding back again.
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include "fuzz/fuzz_target.h"

namespace occmap {
namespace {

namespace fs = std::filesystem;

const fs::path kFuzzFolder = fs::path(OCCMAP_SOURCE_DIR) / "fuzz";

std::vector<fs::path> filesIn(const fs::path& folder) {
  std::vector<fs::path> files;
  if (!fs::is_directory(folder)) return files;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    if (entry.is_regular_file() && entry.path().filename() != "README.md") {
      files.push_back(entry.path());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<std::uint8_t> bytesOf(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// What became of one input.
struct Outcome {
  bool accepted = false;
  std::string problem;  // what went wrong, empty when nothing did
};

// Runs one input in a child process, so that a crash or a hang names its file and the other
// inputs still run. A hang is an input still running after kLimitSeconds: the slowest seed takes
// milliseconds, under the sanitizers a hundred times that.
Outcome run(const fuzz::Target& target, const fs::path& file) {
  constexpr unsigned kLimitSeconds = 30;
  const std::vector<std::uint8_t> bytes = bytesOf(file);
  int report[2];
  if (::pipe(report) != 0) return {false, "cannot make a pipe"};
  std::fflush(nullptr);
  const pid_t child = ::fork();
  if (child < 0) return {false, "cannot fork"};
  if (child == 0) {
    ::close(report[0]);
    ::alarm(kLimitSeconds);  // SIGALRM ends a hang
    std::string problem;
    bool accepted = false;
    try {
      accepted = target.run(fuzz::Input(bytes.data(), bytes.size()));
    } catch (const fuzz::Finding& finding) {
      problem = std::string("broke a promise: ") + finding.what();
    } catch (const std::exception& error) {
      problem = std::string("an exception escaped: ") + error.what();
    } catch (...) {
      problem = "an exception of no std type escaped";
    }
    const std::string message = (accepted ? "1" : "0") + problem;
    if (::write(report[1], message.data(), message.size()) < 0) ::_exit(3);
    ::_exit(0);
  }
  ::close(report[1]);
  std::string message;
  char buffer[512];
  for (ssize_t n; (n = ::read(report[0], buffer, sizeof buffer)) > 0;) {
    message.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(report[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  if (WIFSIGNALED(status)) {
    if (WTERMSIG(status) == SIGALRM) {
      return {false, "still running after " + std::to_string(kLimitSeconds) + " s (a hang)"};
    }
    return {false, std::string("crashed: ") + ::strsignal(WTERMSIG(status)) +
                       " (the sanitizer's report is above)"};
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || message.empty()) {
    return {false, "ended with status " + std::to_string(status) + " (see above)"};
  }
  return {message[0] == '1', message.substr(1)};
}

TEST(FuzzCorpus, EveryTargetHasSeedsAndEveryFolderATarget) {
  std::set<std::string> names;
  for (const fuzz::Target& target : fuzz::kTargets) {
    names.insert(target.name);
    EXPECT_FALSE(filesIn(kFuzzFolder / "corpus" / target.name).empty())
        << "fuzz/corpus/" << target.name << "/ holds no seeds: libFuzzer would start from nothing";
  }
  for (const char* kind : {"corpus", "regressions"}) {
    for (const fs::directory_entry& entry : fs::directory_iterator(kFuzzFolder / kind)) {
      if (entry.is_directory()) {
        EXPECT_TRUE(names.count(entry.path().filename().string()))
            << "fuzz/" << kind << "/" << entry.path().filename().string()
            << "/ belongs to no target in fuzz/fuzz_target.h: its inputs would never run";
      }
    }
  }
}

// Seeds are valid inputs, so that fuzzing starts from messages and files that go all the way
// through: a seed refused (say, after a message type changed) would leave the deep code unfuzzed.
TEST(FuzzCorpus, SeedsAreAcceptedAndNothingEscapes) {
  for (const fuzz::Target& target : fuzz::kTargets) {
    for (const fs::path& file : filesIn(kFuzzFolder / "corpus" / target.name)) {
      const Outcome outcome = run(target, file);
      EXPECT_EQ(outcome.problem, "") << file;
      EXPECT_TRUE(outcome.accepted)
          << file << " is refused by " << target.name
          << "; seeds are valid inputs (regenerate the message seeds with "
             "fuzz_make_seeds, see docs/fuzzing.md)";
    }
  }
}

TEST(FuzzRegressions, NothingFuzzingFoundComesBack) {
  int replayed = 0;
  for (const fuzz::Target& target : fuzz::kTargets) {
    for (const fs::path& file : filesIn(kFuzzFolder / "regressions" / target.name)) {
      EXPECT_EQ(run(target, file).problem, "") << target.name << ": " << file;
      ++replayed;
    }
  }
  EXPECT_GT(replayed, 0) << "fuzz/regressions/ is empty: what fuzzing found is no longer held";
}

}  // namespace
}  // namespace occmap
