// `gat` — gatcore's command-line tool: `gat <command> [options]`. Options are
// declared per command with CLI11 (cli_options.hpp); this file registers the
// commands, `gat help [CMD]`, `gat --version`, and turns every error into one
// line naming the command and what went wrong.
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <iostream>
#include <new>
#include <string>
#include <system_error>

#include "cli_options.hpp"
#include "commands.hpp"
#include "gat_version.hpp"
#include "gatcore/backend.hpp"
#include "gatcore/dist/communicator.hpp"
#include "gatcore/error.hpp"
#include "gatcore/vulkan.hpp"
#include "progress.hpp"

namespace {

constexpr gat::Command kCommands[] = {
    {"demo", gat::setup_demo},
    {"train", gat::setup_train},
    {"eval", gat::setup_eval},
    {"info", gat::setup_info},
    {"errormap", gat::setup_errormap},
    {"dataset", gat::setup_dataset},
    {"predict-weights", gat::setup_predict_weights},
    {"deform", gat::setup_deform},
    {"distill", gat::setup_distill},
    {"calibrate", gat::setup_calibrate},
    {"upgrade-checkpoint", gat::setup_upgrade_checkpoint},
};

std::string version_text() {
  std::string s = "gat (gatcore) " GATCORE_VERSION ", git " GAT_GIT_HASH "\n";
  s += std::string("CPU kernels: SIMD ") + gatcore::cpu_simd_level_name() + " (the CPU supports " +
       gatcore::cpu_detected_simd_level_name() + ")\n";
  if (!gatcore::vulkan::compiled()) return s + "Vulkan: not in this build\n";
  const auto devices = gatcore::vulkan::list_devices();
  if (devices.empty()) return s + "Vulkan: no device found\n";
  s += "Vulkan devices:";
  for (const auto& d : devices) s += "\n  " + std::to_string(d.index) + ": " + d.name + " (" + d.type + ")";
  return s + "\n";
}

// "while predicting skin weights" when a command said what it was doing.
std::string during() {
  const std::string& a = gat::current_activity();
  return a.empty() ? std::string() : " while " + a;
}

// Standard-library exceptions carry terse names ("stof", "std::bad_alloc");
// say in words what failed. gatcore's own errors already name file and value.
std::string describe(const std::exception& e) {
  const std::string what = e.what();
  if (dynamic_cast<const gatcore::Error*>(&e))
    return what.find("out of memory") != std::string::npos ? what + during() : what;
  if (dynamic_cast<const std::bad_alloc*>(&e))
    return "out of memory" + during() + " (use smaller inputs, fewer --samples / --batch, or more memory)";
  if (dynamic_cast<const std::filesystem::filesystem_error*>(&e)) return "file system error" + during() + ": " + what;
  if (dynamic_cast<const std::system_error*>(&e)) return "system error" + during() + ": " + what;
  const bool number = what.rfind("sto", 0) == 0;  // std::stoi / stof / stol ... name themselves
  if (number && dynamic_cast<const std::invalid_argument*>(&e))
    return "a value that should be a number is not one" + during() + " (std::" + what + ")";
  if (number && dynamic_cast<const std::out_of_range*>(&e))
    return "a number is out of range" + during() + " (std::" + what + ")";
  return "unexpected error" + during() + ": " + what + " (please report this with the command line)";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("gatcore's command-line tool: skin weights and corrective deformation with graph-attention "
               "networks", "gat");
  app.require_subcommand(0, 1);
  app.set_help_flag("-h,--help", "print this help (gat help CMD, gat CMD --help: a command's options)");
  app.set_version_flag("--version", version_text, "print the version, git hash, SIMD level and Vulkan devices");
  app.footer("Run `gat help CMD` (or `gat CMD --help`) for a command's options.");
  app.formatter(gat::help_formatter());
  std::vector<std::pair<CLI::App*, gat::Runner>> runners;
  for (const auto& c : kCommands) {
    gat::Runner r = c.setup(app);
    runners.emplace_back(app.get_subcommand(c.name), std::move(r));
  }
  std::vector<std::string> help_topic;
  CLI::App* help = app.add_subcommand("help", "print the help of a command (gat help CMD [SUBCMD]) or this list");
  help->add_option("command", help_topic, "a command's name (and a subcommand's: gat help dataset build)");

  const auto fail = [&](const std::string& who, const std::string& msg) {
    std::fprintf(stderr, "%s: %s\n", who.c_str(), msg.c_str());
  };
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One line naming the command and the argument; the command's help is
    // one `gat help CMD` away.
    const auto subs = app.get_subcommands();
    // Nested (gat dataset build): the full command path.
    std::string path = "gat";
    for (const CLI::App* s = subs.empty() ? nullptr : subs.front(); s;) {
      path += " " + s->get_name();
      const auto inner = s->get_subcommands();
      s = inner.empty() ? nullptr : inner.front();
    }
    fail(path, std::string(e.what()) + " (see gat help " + (subs.empty() ? "" : subs.front()->get_name()) + ")");
    return e.get_exit_code() ? 2 : 0;
  }
  if (help->parsed()) {
    if (help_topic.empty()) {
      // app.help() would print the selected subcommand's (help's own) help.
      std::cout << app.get_formatter()->make_help(&app, "gat", CLI::AppFormatMode::Normal);
      return 0;
    }
    const CLI::App* topic = &app;
    std::string path;
    for (const std::string& word : help_topic) {
      path += (path.empty() ? "" : " ") + word;
      const CLI::App* next = nullptr;
      for (const CLI::App* sub : topic->get_subcommands({}))
        if (sub->get_name() == word && sub != help) next = sub;
      if (!next) {
        fail("gat help", "unknown command '" + path + "'");
        return 2;
      }
      topic = next;
    }
    std::cout << topic->help();
    return 0;
  }
  for (auto& [cmd, run] : runners) {
    if (!cmd->parsed()) continue;
    std::string path = "gat " + cmd->get_name();
    for (const CLI::App* s : cmd->get_subcommands()) path += " " + s->get_name();
    try {
      return run();
    } catch (const CLI::ParseError& e) {
      // An argument checked after parsing (one that depends on another, e.g.
      // CHARACTER, which --target can stand in for): the same line and exit
      // code as CLI11's own checks.
      fail(path, std::string(e.what()) + " (see gat help " + cmd->get_name() + ")");
      return 2;
    } catch (const std::exception& e) {
      // One of several MPI ranks: end them all (they may be waiting for this
      // one in a collective), naming the rank.
      if (gatcore::dist::launched_by_mpi() && gatcore::dist::world().size() > 1) {
        auto& w = gatcore::dist::world();
        w.abort(path + ": rank " + std::to_string(w.rank()) + " of " + std::to_string(w.size()) + ": " + describe(e) +
                    " (stopping all ranks)",
                1);
      }
      fail(path, describe(e));
      return 1;
    }
  }
  std::cerr << app.help();
  return 2;
}
