// Everything of kanedyn's public API in one include.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/integrate.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/state.hpp"
#include "kanedyn/types.hpp"
