// The kanedyn tool's subcommands. Each apps/cmd_*.cpp registers one with a static
// KANEDYN_COMMAND(order, function) line; main() adds them to the CLI11 app in order.
// A command reports failure by throwing (std::exception); main prints
// "kanedyn: error: <what()>" on stderr and exits 1. Usage errors exit 2 (main.cpp).
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

namespace kanedyn::cli {

using AddCommand = void (*)(CLI::App& app);

struct CommandEntry {
  int order;
  AddCommand add;
};

inline std::vector<CommandEntry>& command_registry() {
  static std::vector<CommandEntry> registry;
  return registry;
}

struct RegisterCommand {
  RegisterCommand(int order, AddCommand add) { command_registry().push_back({order, add}); }
};

#define KANEDYN_COMMAND(order, fn) \
  static const ::kanedyn::cli::RegisterCommand kanedyn_command_registration_##fn { order, &fn }

}  // namespace kanedyn::cli
