#pragma once
// The `gat` tool's option conventions, in one place, on CLI11 (Debian's
// libcli11-dev, header-only): every command declares its options here-style,
// so `--opt value` and `--opt=value`, `--help`, `gat help CMD`, the help
// layout and the one-line error for a missing or invalid argument are the
// same everywhere. Why CLI11: it is packaged in Debian 12 (no vendoring),
// header-only (nothing to link or install for library users), supports
// subcommands, validators that see the raw text (so an error can quote it)
// and generated help; cxxopts has no subcommands, Boost.Program_options needs
// a compiled Boost library, getopt_long has neither help nor validation.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace gat {

// Validators; each error quotes the value, and CLI11 prefixes the option's
// name: "--epochs: expects an integer in [1, 1000000], got '0'".
CLI::Validator int_in(long long lo, long long hi);
CLI::Validator number_in(double lo, double hi);  // finite, lo <= x <= hi
CLI::Validator positive_number();                // finite, x > 0
CLI::Validator one_of(std::vector<std::string> choices);
// x as printf's %g writes it ("0.3", "1e-05"), for messages and labels.
std::string number_text(double x);

// The options most commands share, with the same names and help everywhere.
struct CommonOptions {
  bool quiet = false;      // --quiet: no progress line, no per-item lines; the summary only
  long threads = 0;        // --threads: OpenMP threads (0: all cores)
  std::string device = "cpu";  // --device cpu|vulkan|auto
};
void add_quiet(CLI::App& cmd, CommonOptions& o);
void add_threads(CLI::App& cmd, CommonOptions& o);
void add_device(CLI::App& cmd, CommonOptions& o);
// --seed with its default in the help.
CLI::Option* add_seed(CLI::App& cmd, long& seed, const std::string& what);
// -o,--out FILE.
CLI::Option* add_out(CLI::App& cmd, std::string& out, const std::string& what);
// An option given once per value (--motion a.bvh --motion b.bvh): each
// occurrence takes one value, so positionals after it stay positionals.
CLI::Option* add_repeatable(CLI::App& cmd, const std::string& name, std::vector<std::string>& values,
                            const std::string& what);
// Applies --threads (omp_set_num_threads) when given.
void apply_threads(const CommonOptions& o);

// A subcommand: `setup` adds it to the `gat` app with its options and returns
// what runs it after a successful parse (the exit code).
using Runner = std::function<int()>;
struct Command {
  const char* name;
  Runner (*setup)(CLI::App& gat);
};

// `gat CMD ...` with the command's one-line summary (the `gat --help` list).
CLI::App& add_command(CLI::App& gat, const char* name, const char* summary);
// The paragraph(s) `gat help CMD` prints under the summary.
void set_details(CLI::App& cmd, std::string text);
// The help layout of every command: "Usage: gat CMD ...", text wrapped to
// the terminal's usual 100 columns. Set on the `gat` app before commands are added.
std::shared_ptr<CLI::Formatter> help_formatter();

}  // namespace gat
