#pragma once
// Runs a program as a user would, for tests of the command-line tools: arguments quoted for the
// shell, standard output and error captured, the exit code returned.

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>

#include "temporary_folder.h"

namespace occmap::testing {

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string shellQuote(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

inline std::string readWhole(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

inline CommandResult runCommand(const std::vector<std::string>& arguments) {
  static int counter = 0;
  const auto base =
      std::filesystem::temp_directory_path() /
      ("occmap-command-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
  std::string command;
  for (const std::string& argument : arguments) command += shellQuote(argument) + " ";
  command += ">" + shellQuote(base.string() + ".out") + " 2>" + shellQuote(base.string() + ".err");
  const int status = std::system(command.c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = readWhole(base.string() + ".out");
  result.err = readWhole(base.string() + ".err");
  std::filesystem::remove(base.string() + ".out");
  std::filesystem::remove(base.string() + ".err");
  return result;
}

inline void writeText(const std::filesystem::path& file, const std::string& text) {
  std::ofstream(file) << text;
}

}  // namespace occmap::testing
