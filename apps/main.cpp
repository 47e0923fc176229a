// The kanedyn command-line tool: see docs/cli.md.
#include <algorithm>
#include <exception>
#include <iostream>

#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"kanedyn: dynamics of multibody systems by Kane's equations", "kanedyn"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "kanedyn 0.1.0");
  auto registry = kanedyn::cli::command_registry();
  std::sort(registry.begin(), registry.end(),
            [](const auto& a, const auto& b) { return a.order < b.order; });
  for (const auto& entry : registry) entry.add(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "kanedyn: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
