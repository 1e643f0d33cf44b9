// occmap: the command-line tool of the occupancy mapper. One binary, one sub-command per job.
#include <cstdio>
#include <exception>
#include <map>

#include "config/exit_codes.h"
#include "config/input_error.h"
#include "tools/commands.h"

int main(int argc, char** argv) {
  using namespace occmap;
  CLI::App app(
      "occmap: a live 2-D occupancy map of a floor from fixed, calibrated cameras (Hoover & Olsen, "
      "1999).\n"
      "Each camera pixel that matches its background image shows a clear ray to the floor, so the "
      "floor it sees is free; what no camera clears stays occupied.\n\n"
      "Exit codes: 0 done; 1 failed at run time; 2 invalid input (config, calibration, image or "
      "command line: the message names the file and line or field); 3 no result.",
      "occmap");
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Show the help of every sub-command");
  std::map<CLI::App*, tools::Command> commands;
  auto add = [&](tools::Command (*make)(CLI::App&), const char* name) {
    tools::Command command = make(app);
    commands[app.get_subcommand(name)] = std::move(command);
  };
  add(tools::addProjectCommand, "project");
  add(tools::addFuseCommand, "fuse");
  add(tools::addDetectCommand, "detect");
  add(tools::addTrackCommand, "track");
  add(tools::addCoverageCommand, "coverage");
  add(tools::addBackgroundCommand, "background");
  add(tools::addViewCommand, "view");
  add(tools::addStatusCommand, "status");
  add(tools::addControlCommand, "control");
  add(tools::addRecordCommand, "record");
  add(tools::addScoreCommand, "score");
  add(tools::addTruthCommand, "truth");
  add(tools::addMergeCommand, "merge");
  add(tools::addWebCommand, "web");
  add(tools::addCalibrateCommand, "calibrate");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    std::fprintf(stderr, "Run 'occmap --help' or 'occmap <command> --help' for usage.\n");
    return kExitInvalidInput;
  }
  try {
    for (CLI::App* sub : app.get_subcommands()) return commands.at(sub)();
  } catch (const InputError& e) {
    std::fprintf(stderr, "occmap: error: %s\n", e.what());
    return kExitInvalidInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "occmap: failed: %s\n", e.what());
    return kExitFailure;
  }
  return kExitFailure;
}
