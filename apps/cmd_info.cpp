// `kanedyn info MODEL`: the topology of the notes (N, L(K), u_K, chains) and the total mass;
// for a jointed model each body's joint and its coordinates.
#include <algorithm>
#include <charconv>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/text.hpp"
#include "options.hpp"

namespace kanedyn::cli {
namespace {

// What a joint's q holds, for the table of joints (its row of the joint table).
const char* coordinates_meaning(JointType type) { return joint_type_info(type).meaning; }

std::string frame_label(const Model& model, int k) {
  if (k == kGround) return "0 (inertial frame R)";
  return std::to_string(k + 1) + " " + model.body(k).name;
}

void print_info(const io::ModelFile& file, std::ostream& out) {
  const Model& model = file.model;
  const int n = model.num_bodies();
  out << "model: " << io::printable(file.path);
  // The name is free text from the file: no control byte reaches the terminal.
  if (!model.name().empty()) out << " (" << io::printable(model.name()) << ")";
  out << "\nN = " << n << (n == 1 ? " body, " : " bodies, ") << model.num_x() << " coordinates x, "
      << model.num_y() << " speeds y\n";
  out << "L(K) = (";
  for (int k = 0; k < n; ++k) out << (k ? ", " : "") << model.lower_body(k) + 1;
  out << ")\nu_K  = (";
  for (int k = 0; k < n; ++k) out << (k ? ", " : "") << model.depth(k);
  out << ")\n\n";
  out << "  K  name                  mass  u_K  chain down to the inertial frame\n";
  for (int k = 0; k < n; ++k) {
    char head[96];
    std::snprintf(head, sizeof head, "%3d  %-18s %8.4g  %3d  ", k + 1, model.body(k).name.c_str(),
                  model.body(k).mass, model.depth(k));
    out << head;
    out << chain_text(model, k) << "\n";
  }
  if (file.jointed()) {
    const int nq = model.num_coordinates(), nz = model.num_speeds();
    out << "\njoints: " << nq << (nq == 1 ? " joint coordinate q, " : " joint coordinates q, ")
        << nz << (nz == 1 ? " independent speed z" : " independent speeds z") << " (y = [C] z)\n";
    out << "  K  name               joint        q (initial)\n";
    for (int k = 0; k < n; ++k) {
      const Joint& jt = model.joint(k);
      char head[96];
      std::snprintf(head, sizeof head, "%3d  %-18s %-12s ", k + 1, model.body(k).name.c_str(),
                    to_string(jt.type));
      out << head;
      const int nq = coordinate_count(jt.type);
      if (jt.type == JointType::free) {
        out << "the notes' own: eps_K, s'_K (7)";
      } else if (nq == 0) {
        out << "none";
      } else {
        const char* what = coordinates_meaning(jt.type);
        out << "[";
        for (int i = 0; i < nq; ++i)
          out << (i ? ", " : "") << file.q[model.coordinate_offset(k) + i];
        out << "] (" << what << ")";
      }
      out << "\n";
    }
    const auto on_joints = std::count_if(model.forces().begin(), model.forces().end(),
                                         [](const auto& f) { return f->acts_on_joints(); });
    if (on_joints > 0) out << "joint loads (joint_spring, joint_force): " << on_joints << "\n";
  }
  out << "\ntotal mass = " << model.total_mass() << "\n";
  out << "roots (bodies attached to R):";
  for (int k = 0; k < n; ++k)
    if (model.lower_body(k) == kGround) out << " " << frame_label(model, k);
  out << "\nforce elements: " << model.forces().size() << ", gravity = ["
      << model.gravity().transpose() << "]\n";
  if (const auto& parameters = file.parameters.parameters; !parameters.empty()) {
    // Each value as evaluated (shortest round-trip digits), and the expression that gave it.
    out << "parameters: " << parameters.size() << "\n";
    for (const io::Parameters::Parameter& p : parameters) {
      char value[32];
      const auto end = std::to_chars(value, value + sizeof value, p.value).ptr;
      out << "  " << p.name << " = " << std::string(value, end);
      if (!p.text.empty()) out << "  (= " << io::printable(p.text, 200) << ")";
      out << "\n";
    }
  }
  if (!model.frames().empty()) {
    out << "frames: " << model.frames().size() << "\n";
    for (const Frame& f : model.frames())
      out << "  " << f.name << " on " << (f.body == kGround ? "ground" : model.body(f.body).name)
          << " at [" << f.at.transpose() << "]\n";
  }
  if (model.num_constraints() > 0) {
    out << "constraints: " << constraint_summary(file) << "\n";
    for (const Constraint& c : model.constraints())
      out << "  " << c.name << ": " << to_string(c.type) << " on " << model.body(c.body).name
          << (c.type == ConstraintType::rolling_disc
                  ? std::string(", radius ") + std::to_string(c.radius)
                  : std::string(" to ") +
                        (c.other == kGround ? "ground" : model.body(c.other).name))
          << "\n";
  }
  if (model.inputs().empty()) return;
  out << "inputs: " << model.num_inputs() << " (u_1..u_m, in this order)\n";
  for (const Input& in : model.inputs()) {
    const std::string& body = model.body(in.body).name;
    out << "  " << in.name << ": ";
    switch (in.type) {
      case InputType::joint:
        out << "joint, speed " << in.speed + 1 << " of " << body << "\n";
        break;
      case InputType::force:
        out << "force along [" << in.direction.transpose() << "] at [" << in.point.transpose()
            << "] of " << body << "\n";
        break;
      case InputType::torque:
        out << "torque about [" << in.axis.transpose() << "] on " << body
            << (in.reaction ? ", and its reaction on the lower body" : "") << "\n";
        break;
    }
  }
}

void add_info(CLI::App& app) {
  auto* cmd =
      app.add_subcommand("info", "Print N, L(K), u_K, each body's chain and the total mass");
  auto path = std::make_shared<std::string>();
  add_input_file(cmd, "MODEL", *path, kModelHelp)->required();
  cmd->callback([path] { print_info(io::load_model_file(*path), std::cout); });
}

}  // namespace
KANEDYN_COMMAND(10, add_info);
}  // namespace kanedyn::cli
