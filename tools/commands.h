#pragma once

#include <functional>

#include <CLI/CLI.hpp>

namespace occmap::tools {

// Each sub-command adds itself to the app and returns the function that runs it after parsing; the
// function returns the process's exit code (config/exit_codes.h) or throws InputError (exit 2).
using Command = std::function<int()>;

Command addProjectCommand(CLI::App& app);
Command addFuseCommand(CLI::App& app);
Command addDetectCommand(CLI::App& app);
Command addTrackCommand(CLI::App& app);
Command addCoverageCommand(CLI::App& app);
Command addBackgroundCommand(CLI::App& app);
Command addViewCommand(CLI::App& app);
Command addStatusCommand(CLI::App& app);
Command addControlCommand(CLI::App& app);
Command addRecordCommand(CLI::App& app);
Command addScoreCommand(CLI::App& app);
Command addTruthCommand(CLI::App& app);
Command addMergeCommand(CLI::App& app);
Command addWebCommand(CLI::App& app);
// occmap calibrate and its steps (each adds itself to `calibrate`).
Command addCalibrateCommand(CLI::App& app);
Command addCalibrateBoardCommand(CLI::App& calibrate);
Command addCalibrateIntrinsicsCommand(CLI::App& calibrate);
Command addCalibratePoseCommand(CLI::App& calibrate);
Command addCalibrateCheckCommand(CLI::App& calibrate);
Command addCalibrateSimulateCommand(CLI::App& calibrate);

}  // namespace occmap::tools
