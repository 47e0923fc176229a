// What must hold for any input to the model loader, whatever the bytes: shared by the libFuzzer
// target and the corpus replay driver, so that both judge an input the same way.
#pragma once

#include <cmath>
#include <cstddef>
#include <exception>
#include <optional>
#include <string>
#include <string_view>
#include <typeinfo>

#include "../src/io/model_tree.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/model.hpp"

namespace kanedyn::fuzz {

/// The name every input is parsed under; error messages must start with it.
inline constexpr const char* kSourceName = "fuzz.yaml";
/// Longer messages are no longer one readable line (a list of every body, say).
inline constexpr std::size_t kMaxMessageLength = 1000;
inline constexpr double kEulerNormTolerance = 1e-12;
/// Evaluating the dynamics of larger models costs more than it finds.
inline constexpr int kMaxBodiesForDynamics = 64;

struct LoaderVerdict {
  bool accepted = false;
  std::string error;      ///< the loader's message, when it refused the input
  std::string violation;  ///< empty when every invariant holds
};

/// Each fuzz target's own check of one input, whatever the bytes (check_loader for the model
/// loader's): LLVMFuzzerTestOneInput aborts on a violation, and the replay driver also uses it
/// to see that a "valid_" input is accepted.
LoaderVerdict check_input(std::string_view text);

/// What an error message may not be: multi-line, raw control bytes, unnamed (not starting with
/// `source`, the name the input was parsed under), overlong.
inline std::string check_error_message(const std::string& what,
                                       const std::string& source = kSourceName) {
  if (what.rfind(source, 0) != 0) return "error message does not start with '" + source + "'";
  if (what.size() >= kMaxMessageLength)
    return "error message is " + std::to_string(what.size()) + " characters long";
  for (std::size_t i = 0; i < what.size(); ++i) {
    const auto c = static_cast<unsigned char>(what[i]);
    if (c == '\n' || c == '\r')
      return "error message is not one line (break at byte " + std::to_string(i) + ")";
    if (c < 0x20 || c == 0x7f)
      return "error message holds the raw control byte " + std::to_string(c) + " at byte " +
             std::to_string(i);
  }
  return "";
}

/// The state rate of an accepted model with joints or constraints, through the one entry
/// point `kanedyn simulate` integrates (Dynamics::derivative at the file's (q, z), both routes:
/// for a constrained model the constrained dynamics with its multipliers or its projected
/// equations). It may refuse the state only with the library's own exception types
/// (ConstraintError: the equations undefined there; ModelError), each a clean line; anything
/// else escapes to check_loader, a finding. Non-finite rates are allowed, as above.
inline std::string check_dynamics_entry_point(const io::ModelFile& file) {
  for (const Route route : {Route::recursive, Route::assembled}) {
    const std::string where = "Dynamics (" + to_string(route) + ") ";
    try {
      Dynamics dynamics(file.model, route);
      VectorX v(dynamics.size()), dv(dynamics.size());
      dynamics.pack(file.q, file.z, v);
      dynamics.derivative(v, dv);
      if (dv.size() != dynamics.size()) return where + "gave a rate of the wrong size";
    } catch (const ConstraintError& e) {
      if (const std::string m = check_error_message(e.what(), ""); !m.empty())
        return where + "threw ConstraintError: " + m;
    } catch (const ModelError& e) {
      if (const std::string m = check_error_message(e.what(), ""); !m.empty())
        return where + "threw ModelError: " + m;
    }
  }
  return "";
}

/// What an accepted file must give: a tree of bodies with positive masses and a finite
/// initial state with unit Euler parameters, whose dynamics evaluate without crashing.
inline std::string check_model_file(const io::ModelFile& file) {
  const Model& model = file.model;
  const State& state = file.initial;
  const int n = model.num_bodies();
  if (n < 1) return "accepted a model with N = " + std::to_string(n);
  if (state.num_bodies() != n || state.x.size() != 7 * n || state.y.size() != 6 * n)
    return "the initial state does not have the model's size";
  for (int k = 0; k < n; ++k) {
    const std::string body = "body " + std::to_string(k + 1) + ": ";
    const int lower = model.lower_body(k);
    if (lower != kGround && (lower < 0 || lower >= k))
      return body + "L(K) = " + std::to_string(lower + 1) + " is not < K";
    if (!(model.body(k).mass > 0.0) || !std::isfinite(model.body(k).mass))
      return body + "mass is not a positive number";
    const double norm = state.euler_parameters(k).norm();
    if (!(std::abs(norm - 1.0) <= kEulerNormTolerance))
      return body + "initial Euler parameters have norm " + std::to_string(norm) + ", not 1";
  }
  if (!state.x.allFinite() || !state.y.allFinite()) return "the initial state is not finite";
  if (n <= kMaxBodiesForDynamics) {
    // Non-finite results are allowed (a huge gravity overflows); crashes and throws are not.
    DataOptions options;
    options.dense_mass_matrix = false;
    Data data(model, options);
    forward_dynamics(model, state, data, Route::recursive);
    forward_dynamics(model, state, data, Route::assembled);
    // Joints and constraints: the kernels simulate runs for them.
    if (!model.all_free() || model.num_constraints() > 0) return check_dynamics_entry_point(file);
  }
  return "";
}

/// Where the loader's fast scanner reads `text`, its tree must be libyaml's, node by node
/// and position by position, and libyaml must read the text too.
inline std::string check_front_ends(std::string_view text) {
  try {
    const io::detail::FrontEnds r = io::detail::compare_front_ends(text);
    if (!r.difference.empty()) return "the fast scanner's tree is not libyaml's: " + r.difference;
    if (r.fast_accepted) {
      // The whole load too: the same model or the same message with libyaml alone.
      const std::string t(text);
      const auto outcome = [&](bool libyaml_only) -> std::string {
        try {
          const io::ModelFile f = libyaml_only
                                      ? io::detail::parse_model_file_with_libyaml(t, kSourceName)
                                      : io::parse_model_file(t, kSourceName);
          return "accepted " + std::to_string(f.model.num_bodies()) + " bodies";
        } catch (const io::ModelFileError& e) {
          return e.what();
        }
      };
      const std::string fast = outcome(false), slow = outcome(true);
      if (fast != slow) return "the loader gives '" + fast + "' but libyaml alone '" + slow + "'";
    }
  } catch (const std::exception& e) {
    return std::string("comparing the front ends threw ") + typeid(e).name() + ": " + e.what();
  }
  return "";
}

/// Runs the loader on `text` and checks every invariant; nothing escapes.
inline LoaderVerdict check_loader(std::string_view text) {
  LoaderVerdict verdict;
  verdict.violation = check_front_ends(text);
  if (!verdict.violation.empty()) return verdict;
  std::optional<io::ModelFile> file;
  try {
    file = io::parse_model_file(std::string(text), kSourceName);
  } catch (const io::ModelFileError& e) {
    verdict.error = e.what();
    verdict.violation = check_error_message(verdict.error);
    return verdict;
  } catch (const std::exception& e) {
    verdict.violation = std::string(
                            "the loader let an exception other than ModelFileError "
                            "escape: ") +
                        typeid(e).name() + ": " + e.what();
    return verdict;
  } catch (...) {
    verdict.violation = "the loader let a non-std exception escape";
    return verdict;
  }
  verdict.accepted = true;
  try {
    verdict.violation = check_model_file(*file);
  } catch (const std::exception& e) {
    verdict.violation =
        std::string("evaluating an accepted model threw ") + typeid(e).name() + ": " + e.what();
  } catch (...) {
    verdict.violation = "evaluating an accepted model threw a non-std exception";
  }
  return verdict;
}

}  // namespace kanedyn::fuzz
