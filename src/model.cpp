#include "kanedyn/model.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_set>

#include "kanedyn/forces.hpp"

namespace kanedyn {

namespace {

bool valid_name(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

bool all_finite(const auto& m) { return m.allFinite(); }

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw ModelError(where + ": " + what);
}

std::string body_label(int k, const std::string& name) {
  return "body " + std::to_string(k + 1) + " '" + name + "'";
}

}  // namespace

std::string check_inertia(const Matrix3& inertia) {
  if (!inertia.allFinite()) return "inertia has a non-finite entry";
  const double scale = inertia.cwiseAbs().maxCoeff();
  if ((inertia - inertia.transpose()).cwiseAbs().maxCoeff() > 1e-12 * scale)
    return "inertia is not symmetric";
  const Eigen::SelfAdjointEigenSolver<Matrix3> eig(inertia, Eigen::EigenvaluesOnly);
  const Vector3 p = eig.eigenvalues();  // ascending
  if (!(p[0] > 0.0)) {
    std::ostringstream s;
    s << "inertia is not positive definite (principal moments " << p[0] << ", " << p[1] << ", "
      << p[2] << ")";
    return s.str();
  }
  // Triangle inequalities: each principal moment at most the sum of the other two. A thin
  // rod or a lamina sits on the boundary, so allow round-off there.
  if (p[2] > (p[0] + p[1]) * (1.0 + 1e-12)) {
    std::ostringstream s;
    s << "principal moments " << p[0] << ", " << p[1] << ", " << p[2]
      << " violate the triangle inequality (" << p[2] << " > " << p[0] << " + " << p[1] << ")";
    return s.str();
  }
  return "";
}

Model::Model(std::vector<BodySpec> bodies, Vector3 gravity,
             std::vector<std::shared_ptr<const ForceElement>> forces, std::string name)
    : bodies_(std::move(bodies)),
      gravity_(std::move(gravity)),
      forces_(std::move(forces)),
      name_(std::move(name)) {
  const int n = num_bodies();
  if (n == 0) throw ModelError("model: a model needs at least one body");
  if (!gravity_.allFinite()) fail("gravity", "has a non-finite component");
  std::unordered_set<std::string> names;
  for (int k = 0; k < n; ++k) {
    const BodySpec& b = bodies_[static_cast<size_t>(k)];
    const std::string where = body_label(k, b.name);
    if (!valid_name(b.name)) fail(where, "name must be non-empty and use only [A-Za-z0-9_-]");
    if (!names.insert(b.name).second) fail(where, "duplicate body name '" + b.name + "'");
    if (b.lower_body != kGround && (b.lower_body < 0 || b.lower_body >= k))
      fail(where, "parent must be 'ground' or an earlier body (L(K) < K), got index " +
                      std::to_string(b.lower_body + 1));
    if (!std::isfinite(b.mass) || !(b.mass > 0.0)) fail(where, "mass must be a finite number > 0");
    if (const std::string e = check_inertia(b.inertia); !e.empty()) fail(where, e);
    if (!all_finite(b.com)) fail(where, "com has a non-finite component");
    if (!all_finite(b.joint)) fail(where, "joint has a non-finite component");
  }

  depth_.resize(static_cast<size_t>(n));
  root_.resize(static_cast<size_t>(n));
  lower_.resize(static_cast<size_t>(n));
  children_.assign(static_cast<size_t>(n), {});
  for (int k = 0; k < n; ++k) {
    const auto i = static_cast<size_t>(k);
    const int j = lower_body(k);
    lower_[i] = j;
    depth_[i] = j == kGround ? 0 : depth_[static_cast<size_t>(j)] + 1;
    root_[i] = j == kGround ? k : root_[static_cast<size_t>(j)];
    if (j != kGround) children_[static_cast<size_t>(j)].push_back(k);
    chain_entries_ += depth_[i] + 1;
  }
  // Flat chains cost sum (u_K + 1) ints: fine for the Kane route's models, not for a
  // 100,000-body chain (5e9 entries); there chain(k) walks L instead.
  if (chain_entries_ <= kMaxFlatChainEntries) {
    chain_offset_.reserve(static_cast<size_t>(n) + 1);
    chain_flat_.reserve(static_cast<size_t>(chain_entries_));
    chain_offset_.push_back(0);
    for (int k = 0; k < n; ++k) {
      for (int a = k; a != kGround; a = lower_body(a)) chain_flat_.push_back(a);
      chain_offset_.push_back(static_cast<int>(chain_flat_.size()));
    }
  }
  inverse_inertia_.resize(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    inverse_inertia_[static_cast<size_t>(k)] = body(k).inertia.inverse();
    total_mass_ += body(k).mass;
  }
  for (size_t i = 0; i < forces_.size(); ++i) {
    const auto& f = forces_[i];
    const std::string where = "forces[" + std::to_string(i) + "]";
    if (!f) fail(where, "is empty");
    if (f->body() < 0 || f->body() >= n)
      fail(where, "body index " + std::to_string(f->body()) + " out of range");
    if (const std::string e = f->validate(*this); !e.empty()) fail(where, e);
  }
}

int Model::body_index(const std::string& name) const {
  for (int k = 0; k < num_bodies(); ++k)
    if (body(k).name == name) return k;
  return -2;
}

bool Model::on_chain(int a, int k) const {
  if (a < 0 || depth(a) > depth(k)) return false;
  return chain(k)[depth(k) - depth(a)] == a;
}

}  // namespace kanedyn
