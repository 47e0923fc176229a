// `kanedyn import ROBOT.urdf -o robot.yaml [--floating]`: a URDF robot as a kanedyn-model/1
// file (docs/urdf.md). What the mapping drops (limits, friction, geometry) goes to stderr.

#include <cstdio>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/io/urdf.hpp"
#include "options.hpp"

namespace kanedyn::cli {
namespace {

struct Options {
  std::string urdf, out;
  bool floating = false;
};

std::string read_file(const std::string& path) {
  try {
    // The model file's limit: a robot description is kilobytes to a few megabytes.
    return io::read_whole_file(io::open_regular_file(path), std::size_t{256} << 20, "a URDF file");
  } catch (const std::runtime_error& e) {
    throw io::ModelFileError(path, 0, 0, "", e.what());
  }
}

void run(const Options& o) {
  // Before reading anything: a tool without urdfdom says so whatever the file.
  if (!io::urdf_supported()) io::urdf_to_model_yaml("", o.urdf, {}, nullptr);
  const bool to_stdout = o.out == "-";
  if (!to_stdout) io::check_output_path(o.out, input_files());
  io::UrdfOptions options;
  options.floating = o.floating;
  std::vector<std::string> notes;
  const std::string yaml = io::urdf_to_model_yaml(read_file(o.urdf), o.urdf, options, &notes);
  for (const std::string& note : notes)
    std::cerr << "kanedyn: note: " << io::printable(note) << "\n";
  if (to_stdout) {
    io::write_to_stdout(yaml);
    return;
  }
  io::write_file_atomically(o.out, yaml, input_files());
  std::printf("wrote %s\n", io::printable(o.out).c_str());
}

void add_import(CLI::App& app) {
  auto* cmd = app.add_subcommand("import", "Convert a URDF robot into a kanedyn model file");
  auto o = std::make_shared<Options>();
  cmd->footer(
      "Links with mass become bodies, massless links frames (a massless root is the ground); "
      "revolute and continuous joints become revolute, prismatic prismatic, fixed weld, "
      "floating free; joint damping becomes a joint_spring. What is dropped is listed on "
      "stderr. Details: docs/urdf.md.");
  add_input_file(cmd, "URDF", o->urdf, "robot description (.urdf)")->required();
  cmd->add_option("--out,-o", o->out, "model file to write (YAML; - for standard output)")
      ->required();
  cmd->add_flag("--floating", o->floating,
                "a floating base: the root link free (6 DOF) instead of welded to the ground; "
                "below a massless root, the first link with mass");
  cmd->callback([o] { run(*o); });
}

}  // namespace
KANEDYN_COMMAND(45, add_import);
}  // namespace kanedyn::cli
