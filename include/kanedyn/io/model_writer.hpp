// Writing a model file: the model, a state as its initial state, and the simulation defaults,
// as YAML of format kanedyn-model/1 (docs/model-format.md). What `equilibrium -o` writes.
#pragma once

#include <string>

#include "kanedyn/io/model_file.hpp"
#include "kanedyn/model.hpp"

namespace kanedyn::io {

/// The text of a model file that loads as `model` with (q, z) as its initial state and
/// `simulation` as its section. Every number is written with the fewest digits that read back
/// as the same double, in a form YAML 1.1 and 1.2 readers both take as a float (`8.0e-04`, never
/// `8e-04`), so the bodies' mass properties, the force elements, the inputs, the constraints'
/// points, radii and lengths and the state come back bit for bit; a joint frame or a frame's
/// rotation is written as an axis and an angle, and a constraint's axes and plane normal are
/// normalized again when read: they come back to within a unit in the last place. The chosen
/// independent speeds are written by name, in z's order. `comment` (lines without '#') heads the
/// file. Throws std::invalid_argument for a force element of a type a model file cannot hold.
/// With `parameters` (a loaded file's), its `parameters` section is written, and every number the
/// file gave as an expression is written as that expression where its value is the number to
/// write (bit for bit; a direction when its components give the model's unit vector); a number
/// that changed is written as the number (docs/model-format.md, "Parameters").
std::string model_file_text(const Model& model, const VectorX& q, const VectorX& z,
                            const SimulationSection& simulation = {},
                            const std::string& comment = "", const Parameters& parameters = {});

/// A double as model_file_text writes it: shortest round-trip digits, a float under YAML 1.1.
std::string yaml_float(double v);

}  // namespace kanedyn::io
