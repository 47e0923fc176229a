// Analysis on the command line: `linearize` (JSON and summary), `equilibrium` (the rest pose and
// the model file it writes), `view --mode`, and the model-file writer they rely on.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/model_writer.hpp"

namespace fs = std::filesystem;

namespace {

using namespace kanedyn;
using test::kExamples;
using test::run_in;
using test::slurp;
using test::temp_dir;

// A cart on a prismatic joint with a pole on a revolute joint above it, pushed by an input.
const char* kCartPole = R"(format: kanedyn-model/1
name: cart-pole
gravity: [0, 0, -9.81]
bodies:
  - name: cart
    parent: ground
    mass: 1.5
    inertia: [0.1, 0.1, 0.1]
    joint: {type: prismatic, axis: [1, 0, 0]}
  - name: pole
    parent: cart
    mass: 0.4
    inertia: [0.02, 0.02, 0.02]
    com: [0, 0, 0.6]
    joint: {type: revolute, axis: [0, 1, 0]}
inputs:
  - {name: push, type: joint, body: cart}
)";

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

TEST(LinearizeCommand, JsonIsTheSpecObjectWithTheLibrarysNumbers) {
  const fs::path dir = temp_dir("cli_linearize");
  write(dir / "cart.yaml", kCartPole);
  const auto r = run_in(dir, "linearize cart.yaml --json --input push=0.5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::ordered_json::parse(r.out);
  std::vector<std::string> keys;
  for (const auto& item : j.items()) keys.push_back(item.key());
  EXPECT_EQ(keys, (std::vector<std::string>{"n", "m", "state", "inputs", "q", "z", "u", "A", "B",
                                            "eigenvalues"}));
  EXPECT_EQ(j["n"], 2);
  EXPECT_EQ(j["m"], 1);
  EXPECT_EQ(j["state"], (std::vector<std::string>{"cart.j1", "pole.j1", "cart.jd1", "pole.jd1"}));
  EXPECT_EQ(j["u"][0], 0.5);
  const io::ModelFile file = io::load_model_file((dir / "cart.yaml").string());
  VectorX u(1);
  u << 0.5;
  const Linearization lin = linearize(file.model, file.q, file.z, u);
  ASSERT_EQ(j["A"].size(), 4u);
  for (int r2 = 0; r2 < 4; ++r2) {
    for (int c = 0; c < 4; ++c) EXPECT_EQ(j["A"][r2][c].get<double>(), lin.A(r2, c));
    EXPECT_EQ(j["B"][r2][0].get<double>(), lin.B(r2, 0));
    EXPECT_EQ(j["eigenvalues"][r2][0].get<double>(), lin.eigenvalues[r2].real());
    EXPECT_EQ(j["eigenvalues"][r2][1].get<double>(), lin.eigenvalues[r2].imag());
  }
  // Without inputs there is no B.
  const auto pendulum = run_in(dir, "linearize '" + kExamples + "/double_pendulum.yaml' --json");
  ASSERT_EQ(pendulum.exit_code, 0) << pendulum.err;
  EXPECT_FALSE(nlohmann::json::parse(pendulum.out).contains("B"));
}

TEST(LinearizeCommand, SummaryReadsEachEigenvalue) {
  const fs::path dir = temp_dir("cli_linearize_summary");
  write(dir / "cart.yaml", kCartPole);
  const auto up = run_in(dir, "linearize cart.yaml --modes");
  ASSERT_EQ(up.exit_code, 0) << up.err;
  EXPECT_NE(up.out.find("the operating point is unstable"), std::string::npos) << up.out;
  EXPECT_NE(up.out.find("moves:"), std::string::npos);
  EXPECT_NE(up.out.find("pole.j1"), std::string::npos);
  // The tennis racket spins: a periodic system, said so.
  const auto racket = run_in(dir, "linearize '" + kExamples + "/tennis_racket.yaml'");
  ASSERT_EQ(racket.exit_code, 0) << racket.err;
  EXPECT_NE(racket.out.find("periodic"), std::string::npos) << racket.out;
  // Errors: an unknown input, a state file of another system.
  const auto bad = run_in(dir, "linearize cart.yaml --input pushh=1");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("did you mean 'push'"), std::string::npos) << bad.err;
  const auto other =
      run_in(dir, "linearize cart.yaml --state '" + kExamples + "/double_pendulum.yaml'");
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_NE(other.err.find("are not those of"), std::string::npos) << other.err;
}

// Every number equilibrium writes reads as a float under YAML 1.1 (its float pattern needs a '.'
// and a signed exponent), and the file loads back to the rest pose.
TEST(EquilibriumCommand, WritesTheRestPoseAsAModelFile) {
  const fs::path dir = temp_dir("cli_equilibrium");
  const std::string model = kExamples + "/eight_body.yaml";
  const auto r = run_in(dir, "equilibrium '" + model + "' -o rest.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("the rest pose is stable"), std::string::npos) << r.out;
  const io::ModelFile rest = io::load_model_file((dir / "rest.yaml").string());
  VectorX zdot(rest.model.num_speeds());
  Dynamics(rest.model).evaluate(rest.q, rest.z, zdot);
  // Newton stopped at 1e-10 of the largest starting force (~700 N) over the mass matrix.
  EXPECT_LE(zdot.cwiseAbs().maxCoeff(), 1e-6);
  const std::string text = slurp(dir / "rest.yaml");
  const std::regex number(R"((?:^|[\[ ,:])(-?[0-9][0-9.eE+-]*)(?=[,\]\n]))");
  const std::regex yaml11_float(R"(^[-+]?([0-9][0-9_]*)?\.[0-9.]*([eE][-+][0-9]+)?$)");
  int floats = 0;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), number);
       it != std::sregex_iterator(); ++it) {
    EXPECT_TRUE(std::regex_match((*it)[1].str(), yaml11_float)) << (*it)[1].str();
    ++floats;
  }
  EXPECT_GT(floats, 100);
  // -o - is standard output, as for view and import: the same model, the report on stderr.
  const auto piped = run_in(dir, "equilibrium '" + model + "' -o -");
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  EXPECT_EQ(piped.out, text);
  EXPECT_NE(piped.err.find("the rest pose is stable"), std::string::npos) << piped.err;
  EXPECT_FALSE(fs::exists(dir / "-"));
}

// A tolerance so loose that the start counts as a rest would report a pose with most of its
// forces unbalanced as stable: refused, here and by the library.
TEST(EquilibriumCommand, ALooseToleranceIsRefused) {
  const fs::path dir = temp_dir("cli_equilibrium_tolerance");
  const std::string model = kExamples + "/eight_body.yaml";
  for (const char* tolerance : {"1e300", "0.5", "0.0011"}) {
    const auto r = run_in(dir, "equilibrium '" + model + "' --tolerance " + tolerance);
    EXPECT_EQ(r.exit_code, 2) << tolerance;  // a usage error, as every option out of range
    EXPECT_NE(r.err.find("--tolerance"), std::string::npos) << r.err;
  }
  EXPECT_EQ(run_in(dir, "equilibrium '" + model + "' --tolerance 1e-3").exit_code, 0);
  const io::ModelFile file = io::load_model_file(model);
  EquilibriumOptions options;
  options.tolerance = 1e300;
  EXPECT_THROW(equilibrium(file.model, file.q, VectorX::Zero(0), options), std::invalid_argument);
  options.tolerance = 1e-10;
  options.max_iterations = 0;
  EXPECT_THROW(equilibrium(file.model, file.q, VectorX::Zero(0), options), std::invalid_argument);
}

TEST(EquilibriumCommand, FailsHonestlyWhereNothingRestrains) {
  const fs::path dir = temp_dir("cli_equilibrium_fail");
  write(dir / "rock.yaml",
        "format: kanedyn-model/1\ngravity: [0, 0, -9.81]\nbodies:\n  - name: rock\n    parent: "
        "ground\n    mass: 1\n    inertia: [1, 1, 1]\n");
  const auto r = run_in(dir, "equilibrium rock.yaml -o rest.yaml");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no rest pose found"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("rock.s3"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "rest.yaml"));
  const auto typo = run_in(dir, "equilibrium rock.yaml --free rok");
  EXPECT_EQ(typo.exit_code, 1);
  EXPECT_NE(typo.err.find("did you mean 'rock'"), std::string::npos) << typo.err;
  // Holding the rock's height and tilt is not enough: gravity pulls on s3 alone, so freeing
  // only the horizontal coordinates and the turns converges at once.
  const auto held =
      run_in(dir, "equilibrium rock.yaml --free rock.s1,rock.s2,rock.r1,rock.r2,rock.r3");
  EXPECT_EQ(held.exit_code, 0) << held.err;
}

TEST(ViewCommand, ModeAnimatesTheShape) {
  const fs::path dir = temp_dir("cli_view_mode");
  write(dir / "cart.yaml", kCartPole);
  const auto r = run_in(dir, "view cart.yaml --mode 3 -o mode.html");
  if (r.err.find("without the viewer") != std::string::npos) GTEST_SKIP() << r.err;
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("mode 3 of 4"), std::string::npos) << r.out;
  EXPECT_GT(fs::file_size(dir / "mode.html"), 1000u);
  const auto bad = run_in(dir, "view cart.yaml --mode 5 -o mode5.html");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("has 4 modes"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir / "mode5.html"));
  // What is printed is finite: an amplitude whose shape overflows writes no page of NaN.
  const auto huge = run_in(dir, "view cart.yaml --mode 3 --amplitude 1e100 -o huge.html");
  EXPECT_EQ(huge.exit_code, 1);
  EXPECT_NE(huge.err.find("choose a smaller amplitude"), std::string::npos) << huge.err;
  EXPECT_FALSE(fs::exists(dir / "huge.html"));
}

// The writer: every example loads back with the same model and state, bit for bit, apart from
// joint frames and frames' rotations (axis and angle: within a few units in the last place).
TEST(ModelWriter, ExamplesRoundTrip) {
  for (const std::string name :
       {"eight_body.yaml", "human_jointed.yaml", "satellite.yaml", "tennis_racket.yaml",
        "cart_pendulum.yaml", "double_pendulum.yaml", "chain64.yaml", "urdf/arm.urdf"}) {
    const io::ModelFile a = io::load_model_file(kExamples + "/" + name);
    const std::string text = io::model_file_text(a.model, a.q, a.z, a.simulation, "a test");
    const io::ModelFile b = io::parse_model_file(text, name + " written");
    const Model &ma = a.model, &mb = b.model;
    ASSERT_EQ(ma.num_bodies(), mb.num_bodies()) << name;
    EXPECT_EQ(ma.gravity(), mb.gravity());
    for (int k = 0; k < ma.num_bodies(); ++k) {
      EXPECT_EQ(ma.body(k).name, mb.body(k).name);
      EXPECT_EQ(ma.body(k).lower_body, mb.body(k).lower_body);
      EXPECT_EQ(ma.body(k).mass, mb.body(k).mass);
      EXPECT_EQ(ma.body(k).inertia, mb.body(k).inertia);
      EXPECT_EQ(ma.body(k).com, mb.body(k).com);
      EXPECT_EQ(ma.body(k).joint, mb.body(k).joint);
      EXPECT_EQ(ma.joint(k).type, mb.joint(k).type);
      EXPECT_LE((ma.joint(k).frame - mb.joint(k).frame).cwiseAbs().maxCoeff(), 1e-15) << name;
      EXPECT_LE((ma.joint(k).axis - mb.joint(k).axis).cwiseAbs().maxCoeff(), 1e-15);
      EXPECT_EQ(ma.joint(k).translation, mb.joint(k).translation);
    }
    EXPECT_LE((a.q - b.q).cwiseAbs().maxCoeff(), 1e-15) << name;
    EXPECT_EQ(a.z, b.z) << name;
    ASSERT_EQ(ma.forces().size(), mb.forces().size()) << name;
    for (size_t i = 0; i < ma.forces().size(); ++i)
      EXPECT_EQ(ma.forces()[i]->type(), mb.forces()[i]->type());
    ASSERT_EQ(ma.inputs().size(), mb.inputs().size()) << name;
    for (size_t i = 0; i < ma.inputs().size(); ++i) {
      EXPECT_EQ(ma.inputs()[i].name, mb.inputs()[i].name);
      EXPECT_EQ(ma.inputs()[i].speed, mb.inputs()[i].speed);
    }
    ASSERT_EQ(ma.frames().size(), mb.frames().size()) << name;
    // The same forward dynamics at the state.
    VectorX za(ma.num_speeds()), zb(mb.num_speeds());
    Dynamics(ma).evaluate(a.q, a.z, za);
    Dynamics(mb).evaluate(b.q, b.z, zb);
    EXPECT_LE((za - zb).cwiseAbs().maxCoeff(), 1e-12 * std::max(1.0, za.cwiseAbs().maxCoeff()))
        << name;
  }
}

TEST(ModelWriter, FloatsReadAsFloatsUnderYaml11) {
  EXPECT_EQ(io::yaml_float(8e-4), "8.0e-04");
  EXPECT_EQ(io::yaml_float(8e-24), "8.0e-24");
  EXPECT_EQ(io::yaml_float(3.0), "3.0");
  EXPECT_EQ(io::yaml_float(-1.5e300), "-1.5e+300");
  EXPECT_EQ(io::yaml_float(0.1), "0.1");
  EXPECT_EQ(std::stod(io::yaml_float(1.0 / 3.0)), 1.0 / 3.0);
}

}  // namespace
