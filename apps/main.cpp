// The kanedyn command-line tool: see docs/cli.md.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <iostream>
#include <new>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "commands.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/version.hpp"

namespace {

/// Exit code of every usage error (docs/cli.md).
constexpr int kUsageError = 2;

int usage_error(const std::string& message, const std::string& help) {
  std::cerr << "kanedyn: error: " << kanedyn::io::printable(message) << " (see " << help << ")\n";
  return kUsageError;
}

/// Names of a command's options: "--t-end", "-o", ... (help included).
std::vector<std::string> option_names(const CLI::App& cmd) {
  std::vector<std::string> names{"--help", "-h"};
  for (const CLI::Option* opt : cmd.get_options()) {
    for (const std::string& n : opt->get_lnames()) names.push_back("--" + n);
    for (const std::string& n : opt->get_snames()) names.push_back("-" + n);
  }
  return names;
}

bool looks_like_number(std::string_view s) {
  return s.size() > 1 && s[0] == '-' &&
         (std::isdigit(static_cast<unsigned char>(s[1])) || s[1] == '.');
}

/// Finds, before CLI11 parses, what CLI11 would only call "not expected": an unknown command
/// or option, with the nearest known one as a hint. Returns the exit code, or nothing.
std::optional<int> check_words(CLI::App& app, int argc, char** argv) {
  std::vector<std::string> commands;
  for (const CLI::App* cmd : app.get_subcommands({})) commands.push_back(cmd->get_name());
  int i = 1;
  while (i < argc && std::string_view(argv[i]).starts_with('-')) ++i;  // --help, --version
  if (i == argc) return std::nullopt;
  const std::string word = argv[i];
  CLI::App* cmd = nullptr;
  for (CLI::App* c : app.get_subcommands({}))
    if (c->get_name() == word) cmd = c;
  if (!cmd) {
    std::string all;
    for (const std::string& c : commands) all += (all.empty() ? "" : ", ") + c;
    const std::string near = kanedyn::io::closest_word(word, commands);
    return usage_error("unknown command '" + word + "'" +
                           (near.empty() ? "" : "; did you mean '" + near + "'?") +
                           " Commands: " + all,
                       "kanedyn --help");
  }
  const std::vector<std::string> names = option_names(*cmd);
  for (int j = i + 1; j < argc; ++j) {
    const std::string_view arg = argv[j];
    if (arg == "--") break;  // positional arguments only from here on
    if (!arg.starts_with('-') || arg == "-" || looks_like_number(arg)) continue;
    const std::string name(arg.substr(0, arg.find('=')));
    // A short option may carry its value glued on (-orun.csv).
    const bool known = std::find(names.begin(), names.end(), name) != names.end() ||
                       (!name.starts_with("--") &&
                        std::find(names.begin(), names.end(), name.substr(0, 2)) != names.end());
    if (known) continue;
    const std::string near = kanedyn::io::closest_word(name, names);
    return usage_error("unknown option '" + name + "' for '" + word + "'" +
                           (near.empty() ? "" : "; did you mean '" + near + "'?"),
                       "kanedyn " + word + " --help");
  }
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kanedyn: dynamics of multibody systems by Kane's equations", "kanedyn"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "kanedyn " KANEDYN_VERSION);
  auto registry = kanedyn::cli::command_registry();
  std::sort(registry.begin(), registry.end(),
            [](const auto& a, const auto& b) { return a.order < b.order; });
  for (const auto& entry : registry) entry.add(app);
  // `kanedyn` alone asks what the tool does: the help, on stdout, as for --help (docs/cli.md).
  if (argc <= 1) {
    std::cout << app.help();
    return 0;
  }
  if (const auto code = check_words(app, argc, argv)) return *code;
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    CLI::App* cmd = app.get_subcommands().empty() ? nullptr : app.get_subcommands().front();
    return usage_error(e.what(), cmd ? "kanedyn " + cmd->get_name() + " --help" : "kanedyn --help");
  } catch (const std::bad_alloc&) {
    std::cerr << "kanedyn: error: out of memory (the model or the run is too large for this "
                 "machine)\n";
    return 1;
  } catch (const std::exception& e) {
    // Messages can quote the user's files: no control byte reaches the terminal.
    std::cerr << "kanedyn: error: " << kanedyn::io::printable(e.what()) << "\n";
    return 1;
  }
  return 0;
}
