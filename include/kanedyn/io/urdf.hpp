// URDF import (docs/urdf.md): a robot description in the Unified Robot Description Format,
// read with liburdfdom, written as the text of a kanedyn-model/1 file with the mapping form of
// `joint` (docs/model-format.md).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "kanedyn/io/model_file.hpp"

namespace kanedyn::io {

struct UrdfOptions {
  /// The root link free instead of welded to the ground (`--floating`); when the root has no
  /// mass, the first link with mass below it (docs/urdf.md, "A massless root with --floating").
  bool floating = false;
  /// Inertial components. A URDF file carries no gravity; robots are described z up.
  std::array<double, 3> gravity{0.0, 0.0, -9.81};
};

/// The deepest nesting of XML elements a URDF file may have (the root element is level 1; a
/// robot needs under 20). The XML parser under liburdfdom recurses once per level, so a deeper
/// file is refused before it is parsed (docs/urdf.md, "Limits").
inline constexpr int kMaxUrdfDepth = 100;

/// False when the library was built without liburdfdom: urdf_to_model_yaml then throws.
bool urdf_supported();

/// The text of a kanedyn-model/1 file for the robot in `urdf_text` (docs/urdf.md gives the
/// mapping). `source_name` stands for the file in messages. What is dropped on the way
/// (limits, friction, ...) is described in `notes` (when not null), one line per kind.
/// Throws ModelFileError naming `source_name` and the element (`joint 'elbow'`,
/// `link 'base'`) as the key path, line 0: a file urdfdom cannot parse, a joint kanedyn has no
/// counterpart for (planar, mimic), a closed loop, a massless link moved by a joint, a bad
/// mass or inertia; XML nested deeper than kMaxUrdfDepth, a NUL byte or text that is not
/// UTF-8 (with the line and column); a model whose numbers do not compose to one the model
/// loader reads (the text is read back with parse_model_file before it is returned); and "built
/// without URDF support" when !urdf_supported().
std::string urdf_to_model_yaml(const std::string& urdf_text, const std::string& source_name,
                               const UrdfOptions& options, std::vector<std::string>* notes);

}  // namespace kanedyn::io
