// kanedyn_peers' urdf section (urdf_section.hpp).
#include "urdf_section.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/Joint.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <dart/utils/urdf/DartLoader.hpp>
#include <exception>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/joints.hpp"

namespace peers {
namespace {

// Accelerations are compared at the scale of the largest one, but not below 1 (rad/s^2 or
// m/s^2): at these states (|q|, |z| <= 1, g = 9.81 m/s^2) the joints' accelerations are of
// that order or larger unless the file makes them vanish (flange.urdf: a vertical first axis,
// a tool symmetric about its own), where both engines give rounding noise of 1e-15.
constexpr double kAccelerationFloor = 1.0;

using kanedyn::MatrixX;
using kanedyn::VectorX;

// max |a - b| / max(max |b|, floor): the difference at the scale of the largest entry of the
// reference, or of `floor` where the reference is smaller.
template <class A, class B>
double relative_difference(const A& a, const B& b, double floor = 0) {
  const double scale = std::max(b.cwiseAbs().maxCoeff(), floor);
  const double diff = (a - b).cwiseAbs().maxCoeff();
  return scale > 0 ? diff / scale : diff;
}

// std::cerr swallowed while it lives.
class QuietCerr {
 public:
  QuietCerr() : saved_(std::cerr.rdbuf(sink_.rdbuf())) {}
  QuietCerr(const QuietCerr&) = delete;
  QuietCerr& operator=(const QuietCerr&) = delete;
  ~QuietCerr() { std::cerr.rdbuf(saved_); }

 private:
  std::ostringstream sink_;
  std::streambuf* saved_;
};

struct Row {
  std::string file;
  int n = 0;
  double mass_matrix = 0, accelerations = 0, of_tolerance = 0, condition = 0;
  std::string skipped;  // why the file was not compared
  /// The skip is a failure: a file one side cannot read, or that the two read as different
  /// joints (not a floating joint or a file without joints, which are skipped on purpose).
  bool failed = false;
};

// One file: kanedyn's speed i is DART's generalized coordinate dart_index[i].
Row compare_file(const std::string& path, const UrdfOptions& opt, std::mt19937& rng) {
  Row row;
  row.file = std::filesystem::path(path).filename().string();
  const kanedyn::io::ModelFile file = kanedyn::io::load_model_file(path);
  if (!file.jointed()) {
    row.skipped = "no joints in kanedyn's model (a single welded or free body)";
    return row;
  }
  const kanedyn::Model& model = file.model;
  const kanedyn::Model& tree = file.model;
  const int n = tree.num_speeds();
  row.n = n;

  // DART gives a link without <inertial> a unit mass by default; URDF (and kanedyn) make it
  // massless. The root is welded as kanedyn's importer welds it (the files here have no
  // floating root; a floating one is refused below with the floating joints).
  // DART warns (on std::cerr) of every massless inertia it is given: the default one and the
  // ground's and the frames' on fixed joints, massless on purpose; kept out of the output.
  const QuietCerr quiet;
  dart::utils::DartLoader::Options options(
      nullptr, dart::utils::DartLoader::RootJointType::FIXED,
      dart::dynamics::Inertia(0, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Zero()));
  dart::utils::DartLoader loader(options);
  const dart::dynamics::SkeletonPtr skel = loader.parseSkeleton(
      dart::common::Uri::createFromPath(std::filesystem::absolute(path).string()));
  if (!skel) {
    row.skipped = "DART's loader could not read it";
    row.failed = true;
    return row;
  }
  if (static_cast<int>(skel->getNumDofs()) != n) {
    row.skipped = "DART has " + std::to_string(skel->getNumDofs()) + " coordinates, kanedyn " +
                  std::to_string(n);
    row.failed = true;
    return row;
  }

  // Each kanedyn body with one speed is a revolute, continuous or prismatic URDF joint whose
  // child link has the body's name; any other joint with speeds is a floating one, whose
  // coordinates (kanedyn's Euler parameters and body-frame speeds, DART's exponential
  // coordinates) do not map one to one.
  std::vector<Eigen::Index> q_index(static_cast<size_t>(n)), dart_index(static_cast<size_t>(n));
  for (int k = 0; k < tree.num_bodies(); ++k) {
    const int speeds = tree.speed_offset(k + 1) - tree.speed_offset(k);
    if (speeds == 0) continue;
    const std::string& name = model.body(k).name;
    if (speeds != 1 || tree.coordinate_offset(k + 1) - tree.coordinate_offset(k) != 1) {
      row.skipped =
          "floating joint to '" + name + "': kanedyn's and DART's free-joint coordinates differ";
      return row;
    }
    const dart::dynamics::BodyNode* node = skel->getBodyNode(name);
    if (!node || node->getParentJoint()->getNumDofs() != 1) {
      row.skipped = "no one-coordinate DART joint to link '" + name + "'";
      row.failed = true;
      return row;
    }
    const auto i = static_cast<size_t>(tree.speed_offset(k));
    q_index[i] = tree.coordinate_offset(k);
    dart_index[i] = static_cast<Eigen::Index>(node->getParentJoint()->getIndexInSkeleton(0));
  }
  skel->setGravity(model.gravity());
  // DART's forward dynamics treats joint damping (and springs) implicitly over one time step
  // h, adding h d to the joint's articulated inertia; kanedyn's joint_spring damping is the
  // explicit -d z. A vanishing h makes DART's explicit too (h d and h^2 k are 1e-30 and less
  // of the inertias here, far below rounding).
  skel->setTimeStep(1e-30);

  kanedyn::Dynamics ws(model, kanedyn::Route::recursive);
  kanedyn::Data data(model, kanedyn::DataOptions{});
  std::uniform_real_distribution<double> uniform(-1, 1);
  constexpr double eps = std::numeric_limits<double>::epsilon();
  for (int s = 0; s < opt.states; ++s) {
    VectorX q = file.q, z = VectorX::Zero(n), zdot(n), qdot(model.num_coordinates());
    Eigen::VectorXd dq(n), dz(n);
    for (int i = 0; i < n; ++i) {
      q[q_index[static_cast<size_t>(i)]] = uniform(rng);
      z[i] = uniform(rng);
      dq[dart_index[static_cast<size_t>(i)]] = q[q_index[static_cast<size_t>(i)]];
      dz[dart_index[static_cast<size_t>(i)]] = z[i];
    }
    ws.evaluate(q, z, zdot, qdot);
    const MatrixX A = kanedyn::projected_equations(model, q, z, data).A_z;

    skel->setPositions(dq);
    skel->setVelocities(dz);
    skel->clearInternalForces();
    skel->clearExternalForces();
    skel->computeForwardDynamics();
    const Eigen::MatrixXd& dart_mass = skel->getMassMatrix();
    const Eigen::VectorXd dart_acc = skel->getAccelerations();
    MatrixX M(n, n);
    VectorX a(n);
    for (int i = 0; i < n; ++i) {
      a[i] = dart_acc[dart_index[static_cast<size_t>(i)]];
      for (int j = 0; j < n; ++j)
        M(i, j) = dart_mass(dart_index[static_cast<size_t>(i)], dart_index[static_cast<size_t>(j)]);
    }
    const Eigen::SelfAdjointEigenSolver<MatrixX> eigen(A, Eigen::EigenvaluesOnly);
    const double cond = eigen.eigenvalues().maxCoeff() / eigen.eigenvalues().minCoeff();
    const double acc_tol = std::max(opt.tolerance, 10 * cond * eps);
    const double dm = relative_difference(M, A),
                 da = relative_difference(a, zdot, kAccelerationFloor);
    row.condition = std::max(row.condition, cond);
    row.mass_matrix = std::max(row.mass_matrix, dm);
    row.accelerations = std::max(row.accelerations, da);
    row.of_tolerance = std::max({row.of_tolerance, dm / opt.tolerance, da / acc_tol});
  }
  return row;
}

}  // namespace

bool run_urdf_section(const UrdfOptions& opt) {
  std::cout << "\n## URDF files: kanedyn's importer against DART's loader\n\n"
            << "Largest relative differences over " << opt.states
            << " random states (joint positions and velocities in [-1, 1]): the joint-space "
               "mass matrix (kanedyn's projected A_z against Skeleton::getMassMatrix) and the "
               "joint accelerations (Dynamics::evaluate (Route::recursive) against "
               "computeForwardDynamics, relative to the largest, or to 1 where that is "
               "smaller); tolerance "
            << opt.tolerance
            << " (accelerations: 10 cond(M) eps where larger). Fixed roots "
               "only: a file with a floating joint is skipped.\n\n"
            << "| file | n | cond(M) | mass matrix | accelerations | of tolerance |\n"
            << "|---|---:|---:|---:|---:|---:|\n";
  std::mt19937 rng(opt.seed);
  bool agree = true;
  for (const std::string& path : opt.files) {
    Row row;
    try {
      row = compare_file(path, opt, rng);
    } catch (const std::exception& e) {
      row.file = std::filesystem::path(path).filename().string();
      row.skipped = std::string("kanedyn could not load it: ") + e.what();
      row.failed = true;
    }
    if (!row.skipped.empty()) {
      std::cout << "| " << row.file << " | | | " << (row.failed ? "FAILED: " : "skipped: ")
                << row.skipped << " | | |\n";
      agree = agree && !row.failed;
      continue;
    }
    const bool ok = row.of_tolerance <= 1;
    agree = agree && ok;
    std::cout << "| " << row.file << " | " << row.n << " | " << std::setprecision(2)
              << row.condition << " | " << row.mass_matrix << " | " << row.accelerations << " | "
              << row.of_tolerance << (ok ? "" : " DISAGREE") << " |\n";
  }
  std::cout << std::flush;
  return agree;
}

}  // namespace peers
