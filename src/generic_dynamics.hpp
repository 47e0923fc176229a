// The inverse dynamics of any model over a generic number type S (double, or the dual numbers of
// src/dual.hpp): Q = the generalized inertia forces minus the active forces of z, at (q, z,
// z dot, u). The same equations as Terms::inverse_dynamics (src/terms.cpp: Newton-Euler over the
// joints in body axes, Eqs. 28 and 30 outward, the generalized forces of Eqs. 31-35 inward), with
// each equation from src/equations.inc; gravity, the force elements' own laws for every scalar
// (ForceElement::apply_generic) and the inputs. Private to the library (src/analysis.cpp, and the
// tests that compare it with Terms).
#pragma once

#include <vector>

#include "kanedyn/model.hpp"

namespace kanedyn::detail {

/// Whether every force element of the model gives its law for every scalar
/// (ForceElement::any_scalar), as the built-in ones do: generic_inverse_dynamics needs it.
bool generic_dynamics_supported(const Model& model);

/// Q at (q, z, zdot, u) in double, for the tests: the generic equations at S = double.
VectorX generic_inverse_dynamics(const Model& model, const VectorX& q, const VectorX& z,
                                 const VectorX& zdot, const VectorX& u);

}  // namespace kanedyn::detail
