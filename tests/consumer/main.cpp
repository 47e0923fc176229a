// Builds a two-body pendulum through the installed public headers and checks free fall.
#include <cmath>
#include <cstdio>
#include <kanedyn/data.hpp>
#include <kanedyn/dynamics.hpp>
#include <kanedyn/model.hpp>

int main() {
  using namespace kanedyn;
  BodySpec a{"a", kGround, 2.0, Matrix3::Identity(), Vector3(0, 0, -0.5), Vector3::Zero()};
  BodySpec b{"b", 0, 1.0, Matrix3::Identity(), Vector3(0, 0, -0.5), Vector3(0, 0, -1)};
  const Model model({a, b}, Vector3(0, 0, -9.81));
  const State state(model);
  Data data(model);
  forward_dynamics(model, state, data, Route::assembled);
  // No force element holds anything: every body falls freely, the root's s'' is g.
  const double err = std::abs(data.ydot[3 * model.num_bodies() + 2] + 9.81);
  std::printf("consumer: root s''_z = %.6f\n", data.ydot[3 * model.num_bodies() + 2]);
  return err < 1e-12 ? 0 : 1;
}
