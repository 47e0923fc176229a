// What must hold for any inputs table (the CSV of `kanedyn simulate --inputs`, read by
// kanedyn::io::read_input_table), whatever the bytes: shared by the libFuzzer target
// kanedyn_fuzz_inputs_table and its replay driver. The table drives a fixed model with three
// inputs named as the URDF arm's table names its joints (examples/urdf/arm_torques.csv reads as
// it is), of three kinds: a joint's generalized force, a torque with its reaction, a force.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <typeinfo>

#include "kanedyn/inputs.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "loader_invariants.hpp"

namespace kanedyn::fuzz {

/// The cart-pole of examples/cart_pole.yaml with three inputs instead of one.
inline constexpr const char* kInputsModel = R"(format: kanedyn-model/1
name: inputs fuzz model
gravity: [0, 0, -9.81]
bodies:
  - name: cart
    parent: ground
    mass: 1.0
    inertia: [0.01, 0.02, 0.02]
    joint: {type: prismatic, axis: [1, 0, 0]}
  - name: pole
    parent: cart
    mass: 0.1
    inertia: [0.008333, 0.008333, 0.00001]
    com: [0, 0, 0.5]
    joint: {type: revolute, axis: [0, 1, 0]}
    initial:
      joint: [0.2]
inputs:
  - {name: shoulder_lift, type: joint, body: cart}
  - {name: elbow, type: torque, body: pole, axis: [0, 1, 0], reaction: true}
  - {name: push, type: force, body: pole, direction: [1, 0, 0], point: [0, 0, 1]}
)";
inline constexpr int kInputsModelInputs = 3;

/// The model, and the file every input is written to (the reader takes a path): one per
/// process, in a folder of its own under $TMPDIR (or /tmp), removed at exit.
class InputsFixture {
 public:
  InputsFixture() : file(io::parse_model_file(kInputsModel, "inputs fuzz model")) {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/kanedyn_fuzz_inputs.XXXXXX";
    if (!mkdtemp(pattern.data())) {
      std::fprintf(stderr, "kanedyn fuzz: cannot make a folder %s: %s\n", pattern.c_str(),
                   std::strerror(errno));
      std::abort();
    }
    dir = pattern;
    path = dir + "/fuzz_inputs.csv";
  }
  ~InputsFixture() {
    unlink(path.c_str());
    rmdir(dir.c_str());
  }
  InputsFixture(const InputsFixture&) = delete;
  InputsFixture& operator=(const InputsFixture&) = delete;

  /// Replaces the file with one of the bytes `text`; false (errno set) when that fails. A new
  /// file each time, not the old one truncated: ext4 writes a file truncated to 0 and written
  /// again to disk when it is closed, which made each input wait on the disk.
  bool write(std::string_view text) const {
    if (unlink(path.c_str()) != 0 && errno != ENOENT) return false;
    const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0) return false;
    for (size_t done = 0; done < text.size();) {
      const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        close(fd);
        return false;
      }
      done += static_cast<size_t>(n);
    }
    return close(fd) == 0;
  }

  io::ModelFile file;
  std::string dir, path;
};

inline const InputsFixture& inputs_fixture() {
  static const InputsFixture fixture;
  return fixture;
}

/// What an accepted table must be: rows, each a finite time after the last, the model's width of
/// finite values, and (zero-order hold) at each row's time that row's values.
inline std::string check_input_table(const InputTable& table) {
  const int rows = table.rows();
  if (rows < 1) return "accepted a table without rows";
  if (table.num_inputs() != kInputsModelInputs)
    return "the table has " + std::to_string(table.num_inputs()) + " inputs, the model " +
           std::to_string(kInputsModelInputs);
  if (table.values().rows() != rows || static_cast<int>(table.times().size()) != rows)
    return "the table's times and values disagree on the number of rows";
  for (int r = 0; r < rows; ++r) {
    const double t = table.times()[static_cast<size_t>(r)];
    const std::string row = "row " + std::to_string(r + 1) + ": ";
    if (!std::isfinite(t)) return row + "the time is not finite";
    if (r > 0 && !(t > table.times()[static_cast<size_t>(r - 1)]))
      return row + "the time does not come after the previous row's";
    if (!table.values().row(r).allFinite()) return row + "a value is not finite";
  }
  if (table.hold() == InputHold::zero_order) {
    VectorX u(table.num_inputs());
    for (int r = 0; r < std::min(rows, 64); ++r) {
      const double t = table.times()[static_cast<size_t>(r)];
      if (table.segment(t) != r)
        return "row " + std::to_string(r + 1) + ": its time falls in segment " +
               std::to_string(table.segment(t));
      table.value(t, u);
      if (u != table.values().row(r).transpose())
        return "row " + std::to_string(r + 1) + ": the value at its time is not the row's";
    }
  }
  return "";
}

/// Reads `text` as the fixed model's inputs table and checks every invariant; nothing escapes.
inline LoaderVerdict check_inputs_table(std::string_view text) {
  const InputsFixture& fixture = inputs_fixture();
  LoaderVerdict verdict;
  if (!fixture.write(text)) {
    std::fprintf(stderr, "kanedyn fuzz: cannot write %s: %s\n", fixture.path.c_str(),
                 std::strerror(errno));
    std::abort();
  }
  std::optional<InputTable> table;
  try {
    table.emplace(io::read_input_table(fixture.file.model, fixture.path, InputHold::zero_order));
  } catch (const std::runtime_error& e) {
    // The reader's documented refusal: one line naming the file.
    verdict.error = e.what();
    verdict.violation = check_error_message(verdict.error, fixture.path);
    return verdict;
  } catch (const std::exception& e) {
    verdict.violation =
        std::string("the inputs reader let an exception other than std::runtime_error escape: ") +
        typeid(e).name() + ": " + e.what();
    return verdict;
  } catch (...) {
    verdict.violation = "the inputs reader let a non-std exception escape";
    return verdict;
  }
  verdict.accepted = true;
  try {
    verdict.violation = check_input_table(*table);
  } catch (const std::exception& e) {
    verdict.violation =
        std::string("checking an accepted table threw ") + typeid(e).name() + ": " + e.what();
  }
  return verdict;
}

}  // namespace kanedyn::fuzz
