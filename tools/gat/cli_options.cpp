#include "cli_options.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>

#include <omp.h>

namespace gat {

namespace {

std::string range_text(long long lo, long long hi) {
  return "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
}

constexpr std::size_t kHelpWidth = 100, kColumn = 34;

// Greedy word wrap to `width` columns; existing line breaks are kept.
std::string wrap(const std::string& text, std::size_t width) {
  std::string out, line;
  std::istringstream paragraphs(text);
  std::string para;
  bool first_para = true;
  while (std::getline(paragraphs, para)) {
    if (!first_para) out += '\n';
    first_para = false;
    std::istringstream words(para);
    std::string w;
    line.clear();
    while (words >> w) {
      if (!line.empty() && line.size() + 1 + w.size() > width) {
        out += line + '\n';
        line.clear();
      }
      line += (line.empty() ? "" : " ") + w;
    }
    out += line;
  }
  return out;
}

std::map<const CLI::App*, std::string>& details() {
  static std::map<const CLI::App*, std::string> d;
  return d;
}

class GatFormatter : public CLI::Formatter {
 public:
  GatFormatter() { column_width(kColumn); }
  std::string make_usage(const CLI::App* app, std::string) const override {
    std::string path;
    for (const CLI::App* a = app; a; a = a->get_parent()) path = a->get_name() + (path.empty() ? "" : " ") + path;
    return CLI::Formatter::make_usage(app, path);
  }
  std::string make_description(const CLI::App* app) const override {
    std::string d = app->get_description();
    const auto it = details().find(app);
    if (it != details().end()) d += (d.empty() ? "" : "\n") + it->second;
    return d.empty() ? std::string() : wrap(d, kHelpWidth) + "\n";
  }
  std::string make_option_desc(const CLI::Option* o) const override {
    return wrap(CLI::Formatter::make_option_desc(o), kHelpWidth - kColumn);
  }
  std::string make_footer(const CLI::App* app) const override {
    const std::string f = CLI::Formatter::make_footer(app);
    return f.empty() ? f : wrap(f, kHelpWidth) + "\n";
  }
};

}  // namespace

std::string number_text(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", x);
  return b;
}

void set_details(CLI::App& cmd, std::string text) { details()[&cmd] = std::move(text); }

std::shared_ptr<CLI::Formatter> help_formatter() { return std::make_shared<GatFormatter>(); }

CLI::Validator int_in(long long lo, long long hi) {
  return CLI::Validator(
      [lo, hi](std::string& v) -> std::string {
        char* end = nullptr;
        errno = 0;
        const long long x = std::strtoll(v.c_str(), &end, 10);
        if (v.empty() || *end || errno == ERANGE || x < lo || x > hi)
          return "expects an integer in " + range_text(lo, hi) + ", got '" + v + "'";
        return {};
      },
      "INT in " + range_text(lo, hi), "int_in");
}

CLI::Validator number_in(double lo, double hi) {
  return CLI::Validator(
      [lo, hi](std::string& v) -> std::string {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (v.empty() || *end || !std::isfinite(x) || x < lo || x > hi)
          return "expects a number in [" + number_text(lo) + ", " + number_text(hi) + "], got '" + v + "'";
        return {};
      },
      "NUMBER in [" + number_text(lo) + ", " + number_text(hi) + "]", "number_in");
}

CLI::Validator positive_number() {
  return CLI::Validator(
      [](std::string& v) -> std::string {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (v.empty() || *end || !std::isfinite(x) || !(x > 0)) return "expects a positive number, got '" + v + "'";
        return {};
      },
      "NUMBER > 0", "positive_number");
}

CLI::Validator one_of(std::vector<std::string> choices) {
  std::string list;
  for (std::size_t i = 0; i < choices.size(); ++i)
    list += (i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ") + choices[i];
  return CLI::Validator(
      [choices, list](std::string& v) -> std::string {
        for (const auto& c : choices)
          if (v == c) return {};
        return "expects " + list + ", got '" + v + "'";
      },
      "", "one_of");
}

void add_quiet(CLI::App& cmd, CommonOptions& o) {
  cmd.add_flag("-q,--quiet", o.quiet, "no progress line and no per-item lines: only the summary");
}

void add_threads(CLI::App& cmd, CommonOptions& o) {
  cmd.add_option("--threads", o.threads, "OpenMP threads (default: all cores)")->check(int_in(1, 1024));
}

void add_device(CLI::App& cmd, CommonOptions& o) {
  cmd.add_option("--device", o.device,
                 "cpu (default), vulkan (the device GATCORE_VK_DEVICE selects, else the first GPU; lavapipe needs "
                 "GATCORE_VK_ALLOW_CPU=1) or auto (Vulkan when a GPU is there, else the CPU)")
      ->check(one_of({"cpu", "vulkan", "auto"}));
}

CLI::Option* add_seed(CLI::App& cmd, long& seed, const std::string& what) {
  return cmd.add_option("--seed", seed, what)->check(int_in(0, 2147483647LL))->capture_default_str();
}

CLI::Option* add_out(CLI::App& cmd, std::string& out, const std::string& what) {
  return cmd.add_option("-o,--out", out, what);
}

CLI::Option* add_repeatable(CLI::App& cmd, const std::string& name, std::vector<std::string>& values,
                            const std::string& what) {
  return cmd.add_option(name, values, what + " (repeatable)")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->allow_extra_args(false);
}

void apply_threads(const CommonOptions& o) {
  if (o.threads > 0) omp_set_num_threads(int(o.threads));
}

CLI::App& add_command(CLI::App& gat, const char* name, const char* summary) {
  CLI::App* cmd = gat.add_subcommand(name, summary);
  // Options after positionals, and `--opt=value`, work everywhere (CLI11's
  // defaults); an option given twice keeps the last value, as with getopt.
  cmd->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  return *cmd;
}

}  // namespace gat
