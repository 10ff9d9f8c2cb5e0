#pragma once
// The `gat` tool's subcommands: one file per command (cmd_<name>.cpp), each
// a function taking the arguments after the command name. Adding a command is
// one declaration here and one row in kCommands (main.cpp).
namespace gat {

// argv[0] is the command name; returns the process exit code. Commands throw
// gatcore::Error for bad input; main prints it and exits 1.
using CommandFn = int (*)(int argc, char** argv);

struct Command {
  const char* name;
  CommandFn run;
  const char* summary;
};

int cmd_demo(int argc, char** argv);
int cmd_train(int argc, char** argv);
int cmd_eval(int argc, char** argv);
int cmd_info(int argc, char** argv);
int cmd_errormap(int argc, char** argv);
int cmd_dataset(int argc, char** argv);
int cmd_predict_weights(int argc, char** argv);
int cmd_deform(int argc, char** argv);
int cmd_distill(int argc, char** argv);

}  // namespace gat
