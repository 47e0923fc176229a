// Eqs. (2)-(5) and (41): transformation matrices and Euler parameters.
// Conventions: eps = (e1, e2, e3, e4), e4 the scalar part; [R_K] maps inertial components to
// body-K components ({v'} = [R_K]{v}); its rows are body K's unit vectors (Eq. 2).
#pragma once

#include "kanedyn/types.hpp"

namespace kanedyn {

/// [R_K] of Eqs. (3)-(4): (e4^2 - e.e)[I] + 2{e}{e}^T - 2 e4 [e~].
Matrix3 rotation_matrix(const Vector4& eps);

/// [E'_K] of Eq. (5): {w'; 0} = 2 [E'_K] {eps dot}. Orthogonal when |eps| = 1.
Matrix4 euler_matrix(const Vector4& eps);

/// [Ebar'_K]^T of Eq. (41): [E'_K]^T without its fourth column (4 x 3).
Eigen::Matrix<double, 4, 3> euler_matrix_bar_transpose(const Vector4& eps);

/// {eps dot} = 1/2 [Ebar'_K]^T {w'} (Eqs. 5, 39, 41); w' in body components.
Vector4 euler_parameter_rates(const Vector4& eps, const Vector3& w_b);

/// {w'} from {eps dot}: the first three rows of 2 [E'_K] {eps dot} (Eq. 5).
Vector3 angular_velocity_from_rates(const Vector4& eps, const Vector4& eps_dot);

/// Euler parameters of a rotation by `angle` (radians) about `axis` (need not be unit).
Vector4 euler_parameters_from_axis_angle(const Vector3& axis, double angle);

/// Euler parameters (e4 >= 0) whose [R] equals the given proper orthogonal matrix.
Vector4 euler_parameters_from_matrix(const Matrix3& r);

/// Euler parameters of frame K relative to frame J, from the absolute ones: the rotation
/// that turns J's axes into K's, so that [R_K] = [R(rel)] [R_J].
Vector4 relative_euler_parameters(const Vector4& eps_j, const Vector4& eps_k);

/// Rotation vector theta (angle in [0, pi] times unit axis) of the rotation eps; its
/// components are the same in both frames the rotation relates. Without atan2 (a series after
/// reducing the half angle), to a few ulp; the bushings and their energy use the same.
Vector3 rotation_vector(const Vector4& eps);

}  // namespace kanedyn
