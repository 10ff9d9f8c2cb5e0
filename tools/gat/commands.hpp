#pragma once
// The `gat` tool's subcommands: one file per command (cmd_<name>.cpp), each a
// setup function that adds the command and its options to the `gat` app
// (cli_options.hpp) and returns what runs it. Adding a command is one
// declaration here and one row in kCommands (main.cpp). Commands throw
// gatcore::Error for bad input; main prints it on one line and exits 1.
#include "cli_options.hpp"

namespace gat {

Runner setup_demo(CLI::App& gat);
Runner setup_train(CLI::App& gat);
Runner setup_eval(CLI::App& gat);
Runner setup_info(CLI::App& gat);
Runner setup_errormap(CLI::App& gat);
Runner setup_dataset(CLI::App& gat);
Runner setup_predict_weights(CLI::App& gat);
Runner setup_deform(CLI::App& gat);
Runner setup_distill(CLI::App& gat);
Runner setup_upgrade_checkpoint(CLI::App& gat);
Runner setup_calibrate(CLI::App& gat);

}  // namespace gat
