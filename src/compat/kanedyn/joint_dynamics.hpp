// The Python module's (python/src/run.cpp) former include of the jointed kernel, now internal
// to the library (src/joint_dynamics.hpp; the public entry point is kanedyn::Dynamics). Only
// the module's target sees this folder (CMakeLists.txt); it goes when the module takes Dynamics.
#pragma once

#include "../../joint_dynamics.hpp"

namespace kanedyn {
using detail::JointDynamics;
}  // namespace kanedyn
