// `kanedyn import ROBOT.urdf -o robot.yaml [--floating]`: a URDF robot as a kanedyn-model/1
// file (docs/urdf.md). What the mapping drops (limits, friction, geometry) goes to stderr.
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/io/urdf.hpp"
#include "page.hpp"

namespace kanedyn::cli {
namespace {

struct Options {
  std::string urdf, out;
  bool floating = false;
};

std::string read_file(const std::string& path) {
  const auto fail = [&](const std::string& problem) {
    throw io::ModelFileError(path, 0, 0, "", problem);
  };
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) fail(std::string("cannot open: ") + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) fail("cannot read: not a regular file");
  // The model file's limit: a robot description is kilobytes to a few megabytes.
  if (st.st_size > (off_t{256} << 20))
    fail("the file is larger than 256 MiB, the limit for a URDF file");
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail(std::string("cannot open: ") + std::strerror(errno));
  std::string text;
  char buf[65536];
  std::size_t got = 0;
  while ((got = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, got);
  const bool bad = std::ferror(f);
  std::fclose(f);
  if (bad) fail("cannot read");
  return text;
}

void run(const Options& o) {
  // Before reading anything: a tool without urdfdom says so whatever the file.
  if (!io::urdf_supported()) io::urdf_to_model_yaml("", o.urdf, {}, nullptr);
  io::check_output_path(o.out, o.urdf);
  io::UrdfOptions options;
  options.floating = o.floating;
  std::vector<std::string> notes;
  const std::string yaml = io::urdf_to_model_yaml(read_file(o.urdf), o.urdf, options, &notes);
  for (const std::string& note : notes)
    std::cerr << "kanedyn: note: " << io::printable(note) << "\n";
  // The same whole-file write as `view`'s page: OUT.partial, renamed to OUT when complete.
  view::write_page(o.out, o.urdf, yaml);
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
  cmd->add_option("URDF", o->urdf, "robot description (.urdf)")->required();
  cmd->add_option("--out,-o", o->out, "model file to write (YAML)")->required();
  cmd->add_flag("--floating", o->floating,
                "the root link free (6 DOF) instead of welded to the ground");
  cmd->callback([o] { run(*o); });
}

}  // namespace
KANEDYN_COMMAND(45, add_import);
}  // namespace kanedyn::cli
