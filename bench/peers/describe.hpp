// kanedyn's Model and State in the engine-neutral description of peer.hpp, shared by
// kanedyn_peers and kanedyn_peers_trajectory.
#pragma once

#include <string>

#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"
#include "peer.hpp"

namespace peers {

/// The model's bodies, gravity, bushings (summed per body) and constant loads, and the state
/// as joint coordinates relative to each body's lower body. Throws std::runtime_error for a
/// force type the peers cannot express.
System describe(const std::string& name, const kanedyn::Model& model, const kanedyn::State& state);

}  // namespace peers
