// occmap calibrate: a camera calibrated with occmap itself (issue 15, docs/calibration.md), from
// the board to print to the checked calibration. Each step is a sub-command of its own.
#include <map>
#include <memory>

#include "tools/commands.h"

namespace occmap::tools {

Command addCalibrateCommand(CLI::App& app) {
  CLI::App* calibrate = app.add_subcommand(
      "calibrate",
      "A camera calibrated with occmap itself, in four steps (docs/calibration.md): 'board' makes "
      "a board to print; 'intrinsics' finds the camera's lens from its pictures of the board; "
      "'pose' finds where the camera stands from ArUco markers laid on the floor; 'check' draws "
      "the calibration into a picture to see at a glance that it is right.");
  calibrate->require_subcommand(1);
  auto steps = std::make_shared<std::map<CLI::App*, Command>>();
  const auto add = [&](Command (*make)(CLI::App&), const char* name) {
    Command step = make(*calibrate);
    (*steps)[calibrate->get_subcommand(name)] = std::move(step);
  };
  add(addCalibrateBoardCommand, "board");
  add(addCalibrateIntrinsicsCommand, "intrinsics");
  add(addCalibratePoseCommand, "pose");
  add(addCalibrateCheckCommand, "check");
  add(addCalibrateSimulateCommand, "simulate");
  return [calibrate, steps] { return steps->at(calibrate->get_subcommands().front())(); };
}

}  // namespace occmap::tools
