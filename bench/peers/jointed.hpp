// The jointed models of the peer comparison, built in kanedyn (a Model with joints), their
// random states, and their engine-neutral description (peer.hpp), shared by kanedyn_peers and
// kanedyn_peers_trajectory.
#pragma once

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "kanedyn/joints.hpp"
#include "kanedyn/model.hpp"
#include "peer.hpp"

namespace peers {

/// A kanedyn model with joints at a state. Dynamics keeps a reference to the model, so a
/// case is held by pointer and never moves.
struct JointedCase {
  std::string name;
  kanedyn::Model model;
  kanedyn::VectorX q, z;
  JointedCase(std::string n, const kanedyn::Model& m, std::vector<kanedyn::Joint> joints,
              std::vector<std::shared_ptr<const kanedyn::ForceElement>> loads)
      : name(std::move(n)), model(kanedyn::with_joints(m, std::move(joints), std::move(loads))) {}
  /// A model that has its joints already (e.g. a model file's), constraints and all.
  JointedCase(std::string n, kanedyn::Model m) : name(std::move(n)), model(std::move(m)) {}
  JointedCase(const JointedCase&) = delete;
  JointedCase& operator=(const JointedCase&) = delete;
};

/// The eight-body figure of `eight_body_file` (examples/eight_body.yaml) with joints: the torso
/// free on its bushing to the ground (the file's), the lumbar joint (pelvis) and the left elbow
/// revolute, the hips universal (flexion, then abduction as carried by it), the neck and both
/// shoulders spherical; joint springs and dampers from the file's rotational bushing constants
/// on the revolute and universal joints. The file's other bushings are left out (a bushing on
/// a jointed body would fight the joint). The figure has no knees: each leg is one body.
std::unique_ptr<JointedCase> jointed_eight_body(const std::string& eight_body_file);

/// A chain of n identical links (kanedyn::chain_model's bodies, without its bushings), each
/// on a revolute joint to the one before (the first to the ground at the origin), the axes
/// alternating between the lower link's x and y, light damping (0.1 N m s/rad) on each.
std::unique_ptr<JointedCase> revolute_chain(int n, unsigned seed);

/// One joint of every type on the bodies of kanedyn::random_tree_model(8, seed): free (the
/// root, on its bushing), revolute, prismatic, cylindrical, universal, spherical, weld,
/// revolute, with random joint frames and axes and joint springs, dampers and constant forces
/// on the revolute, prismatic, cylindrical and universal joints.
std::unique_ptr<JointedCase> every_joint_type(unsigned seed);

/// Planar joints on the bodies of kanedyn::random_tree_model(5, seed): planar (the root),
/// revolute, planar, planar, prismatic, with random joint frames (the planes) and axes, and joint
/// springs, dampers and constant forces on every joint; no bushing.
std::unique_ptr<JointedCase> planar_joints(unsigned seed);
std::unique_ptr<JointedCase> screw_joints(unsigned seed);

/// A random state: angles in [-1.2, 1.2] rad, slides (and planar x, y) in [-0.1, 0.1] m, spherical
/// joints and the free root turned by up to 1.2 rad about a random axis, the root's s' up to 2 cm;
/// speeds in
/// [-1, 1] (rad/s, m/s). Portable draws from the engine's raw 32-bit output.
void random_joint_state(JointedCase& c, std::mt19937& rng);

/// The case in the engines' terms, at the case's (q, z), its ball, hinge and distance
/// constraints and point-to-point springs too. Throws std::runtime_error for what the peers do
/// not express (a bushing on a jointed body, a free joint off the root, constant body loads, a
/// rolling disc).
JointedSystem describe_jointed(const JointedCase& c);

}  // namespace peers
