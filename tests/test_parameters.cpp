// The model file's `parameters` section and its `= expression` numbers (docs/model-format.md,
// "Parameters"): the grammar, every located refusal, cycles, the writer keeping expressions, a
// study varying a parameter, and `kanedyn info`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "../src/io/parameters.hpp"
#include "file_support.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/model_writer.hpp"

namespace kanedyn::test {
namespace {

// The value of `text` with the parameters a = 2, b = 3.
double eval(const std::string& text) {
  return io::detail::evaluate_expression(text, [](std::string_view name, size_t at) -> double {
    if (name == "a") return 2.0;
    if (name == "b") return 3.0;
    throw io::detail::ExpressionError{at, "unknown " + std::string(name)};
  });
}

// The refusal of `text`: where (0-based byte of the expression) and what.
io::detail::ExpressionError refusal(const std::string& text) {
  try {
    eval(text);
  } catch (const io::detail::ExpressionError& e) {
    return e;
  }
  ADD_FAILURE() << "accepted: " << text;
  return {};
}

// Each expected value is written out by hand in the order the grammar says, so that a wrong
// precedence or associativity changes it (the operands are chosen so that it would).
TEST(Expressions, PrecedenceAssociativityAndUnaryMinus) {
  EXPECT_EQ(eval("1 + 2 * 3"), 7.0);
  EXPECT_EQ(eval("(1 + 2) * 3"), 9.0);
  EXPECT_EQ(eval("8 - 3 - 2"), 3.0);    // left: (8 - 3) - 2, not 8 - (3 - 2) = 7
  EXPECT_EQ(eval("16 / 4 / 2"), 2.0);   // left: (16 / 4) / 2, not 16 / 2 = 8
  EXPECT_EQ(eval("2 ^ 3 ^ 2"), 512.0);  // right: 2 ^ 9, not 8 ^ 2 = 64
  EXPECT_EQ(eval("-2 ^ 2"), -4.0);      // - (2 ^ 2): the power binds tighter
  EXPECT_EQ(eval("2 ^ -1"), 0.5);       // a signed exponent
  EXPECT_EQ(eval("--3"), 3.0);
  EXPECT_EQ(eval("2 * -a"), -4.0);
  EXPECT_EQ(eval("a * b ^ 2"), 18.0);  // 2 * 9, not 6 ^ 2 = 36
  EXPECT_EQ(eval("a + b * a - b / a"), 2.0 + 6.0 - 1.5);
  EXPECT_EQ(eval("1.5e2 + .5 + 2."), 152.5);
  EXPECT_EQ(eval("  a\t+ b "), 5.0);
}

TEST(Expressions, LeftToRightInDoublePrecision) {
  // 0.1 + 0.2 - 0.3 in that order is 5.55e-17, not 0: each operation rounds as written.
  const double x = 0.1, y = 0.2, z = 0.3;
  EXPECT_EQ(eval("0.1 + 0.2 - 0.3"), (x + y) - z);
  EXPECT_NE(eval("0.1 + 0.2 - 0.3"), 0.0);
  EXPECT_EQ(eval("0.1 + (0.2 - 0.3)"), x + (y - z));
}

TEST(Expressions, PiAndFunctions) {
  EXPECT_EQ(eval("pi"), std::numbers::pi);
  EXPECT_EQ(eval("pi / 10"), std::numbers::pi / 10);
  EXPECT_EQ(eval("sqrt(16)"), 4.0);
  EXPECT_EQ(eval("sin(pi / 10)"), std::sin(std::numbers::pi / 10));
  EXPECT_EQ(eval("cos(pi / 10)"), std::cos(std::numbers::pi / 10));
  EXPECT_EQ(eval("tan(0.3)"), std::tan(0.3));
  EXPECT_EQ(eval("asin(0.5)"), std::asin(0.5));
  EXPECT_EQ(eval("acos(0.5)"), std::acos(0.5));
  EXPECT_EQ(eval("atan(2)"), std::atan(2.0));
  EXPECT_EQ(eval("atan2(1, -1)"), 3 * std::numbers::pi / 4);
  EXPECT_EQ(eval("exp(1)"), std::exp(1.0));
  EXPECT_EQ(eval("log(10)"), std::log(10.0));
  EXPECT_EQ(eval("abs(-a)"), 2.0);
  EXPECT_EQ(eval("min(b, a, 5)"), 2.0);
  EXPECT_EQ(eval("max(b, a, 5)"), 5.0);
  EXPECT_EQ(eval("2 * max(a, b) ^ 2"), 18.0);
  EXPECT_TRUE(io::detail::is_reserved_name("pi"));
  EXPECT_TRUE(io::detail::is_reserved_name("atan2"));
  EXPECT_FALSE(io::detail::is_reserved_name("trail"));
}

TEST(Expressions, RefusalsNameTheCharacter) {
  struct Case {
    std::string text;
    size_t at;
    std::string words;
  };
  const std::vector<Case> cases{
      {"1 +", 3, "ends where a number"},
      {"1 + * 2", 4, "unexpected '*'"},
      {"(1 + 2", 6, "is not closed"},
      {"1 + 2)", 5, "')' without its '('"},
      {"2 a", 2, "after a complete expression"},
      {"2pi", 1, "'*' missing"},
      {"1.2.3", 0, "not a number"},
      {"1e999", 0, "out of the range"},
      {"", 0, "empty expression"},
      {"1 $ 2", 2, "unexpected '$'"},
      {"sin", 0, "is a function"},
      {"pi(2)", 2, "not a function"},
      {"foo(1)", 0, "unknown function 'foo'"},
      {"sin(1, 2)", 0, "sin takes 1 argument, got 2"},
      {"atan2(1)", 0, "atan2 takes 2 arguments, got 1"},
      {"min(1)", 0, "min takes at least 2 arguments, got 1"},
      {"sqrt()", 0, "sqrt takes 1 argument, got 0"},
      {"1 / (a - 2)", 2, "division by zero"},
      {"sqrt(-1)", 0, "not finite (nan)"},
      {"log(0)", 0, "not finite (inf)"},
      {"10 ^ 400", 3, "not finite (inf)"},
      {"1e308 * 10", 6, "not finite"},
      {"a + c", 4, "unknown c"},
  };
  // Nesting is bounded (the parser recurses): 300 parentheses or signs are refused, 150 read.
  EXPECT_EQ(eval(std::string(150, '(') + "1" + std::string(150, ')')), 1.0);
  EXPECT_NE(refusal(std::string(300, '(') + "1" + std::string(300, ')')).problem.find("nested"),
            std::string::npos);
  EXPECT_NE(refusal(std::string(300, '-') + "1").problem.find("nested"), std::string::npos);
  for (const Case& c : cases) {
    const io::detail::ExpressionError e = refusal(c.text);
    EXPECT_EQ(e.at, c.at) << c.text << ": " << e.problem;
    EXPECT_NE(e.problem.find(c.words), std::string::npos) << c.text << ": " << e.problem;
  }
}

// A pendulum whose numbers come from parameters, the later ones used before they are given.
const std::string kModel = R"yaml(format: kanedyn-model/1
parameters:
  length: 1.5
  mass: = 2 * half_mass
  half_mass: 0.5
  tilt: pi / 10
  radius: "= length / 10"
gravity: [0, 0, "= -9.81"]
bodies:
  - name: rod
    parent: ground
    mass: "= mass"
    inertia: ["= mass * length^2 / 12", "= mass * length^2 / 12", "= mass * radius^2 / 2"]
    com: [0, 0, "= -length / 2"]
    joint:
      type: revolute
      axis: ["= cos(tilt)", 0, "= sin(tilt)"]
    initial:
      joint: ["= tilt / 2"]
      joint_rate: [0.25]
simulation:
  t_end: "= 2 * length"
)yaml";

TEST(Parameters, NumbersFollowTheParameters) {
  const io::ModelFile f = io::parse_model_file(kModel, "pendulum.yaml");
  const double length = 1.5, mass = 2 * 0.5, tilt = std::numbers::pi / 10;
  const BodySpec& rod = f.model.body(0);
  EXPECT_EQ(rod.mass, mass);
  EXPECT_EQ(rod.inertia(0, 0), mass * (length * length) / 12);
  EXPECT_EQ(rod.inertia(2, 2), mass * ((length / 10) * (length / 10)) / 2);
  EXPECT_EQ(rod.com.z(), -length / 2);
  EXPECT_EQ(f.model.gravity().z(), -9.81);
  // The axis is normalized by the Model: along (cos, 0, sin) of the tilt, to the round-off of
  // scaling and normalizing a unit vector (a few ulps).
  EXPECT_NEAR(f.model.joint(0).axis.x(), std::cos(tilt), 4e-16);
  EXPECT_NEAR(f.model.joint(0).axis.z(), std::sin(tilt), 4e-16);
  EXPECT_EQ(f.q[0], tilt / 2);
  EXPECT_EQ(*f.simulation.t_end, 2 * length);
  // The section as the file gives it, in its order, each value evaluated.
  ASSERT_EQ(f.parameters.parameters.size(), 5u);
  EXPECT_EQ(f.parameters.parameters[1].name, "mass");
  EXPECT_EQ(f.parameters.parameters[1].text, "2 * half_mass");
  EXPECT_EQ(f.parameters.parameters[1].value, 1.0);
  EXPECT_EQ(f.parameters.parameters[0].text, "");  // a plain number
  EXPECT_EQ(f.parameters.parameters[3].value, tilt);
  EXPECT_EQ(f.parameters.parameters[4].text, "length / 10");
  // Every number given as an expression, by key path; a list's plain numbers too.
  const io::Parameters::Number* axis1 = f.parameters.find("bodies[0].joint.axis[1]");
  ASSERT_NE(axis1, nullptr);
  EXPECT_EQ(axis1->text, "");
  ASSERT_NE(f.parameters.find("bodies[0].mass"), nullptr);
  EXPECT_EQ(f.parameters.find("bodies[0].com[2]")->text, "-length / 2");
  EXPECT_EQ(f.parameters.find("bodies[0].initial.joint_rate[0]"), nullptr);
}

TEST(Parameters, RefusalsAreLocated) {
  const std::string base =
      "format: kanedyn-model/1\nparameters:\n  wheelbase: 1.02\n"
      "  trail: 0.08\nbodies:\n  - name: b\n    parent: ground\n"
      "    mass: 1\n    inertia: [1, 1, 1]\n";
  const std::vector<BadCase> cases{
      {"unknown name, the closest suggested",
       edit(base, "mass: 1", "mass: \"= wheelbse + 1\""),
       "mass: \"= ^wheelbse",
       "bodies[0].mass",
       {"unknown name 'wheelbse'", "closest parameter: 'wheelbase'", "character 3"}},
      {"unknown name in a parameter",
       edit(base, "trail: 0.08", "trail: = wheelbase * k"),
       "wheelbase * ^k",
       "parameters.trail",
       {"unknown name 'k'"}},
      {"no parameters at all",
       "format: kanedyn-model/1\nbodies:\n  - name: b\n    parent: ground\n    mass: '= m'\n"
       "    inertia: [1, 1, 1]\n",
       "'= ^m'",
       "bodies[0].mass",
       {"unknown name 'm'", "no 'parameters' section"}},
      {"a cycle, its members named",
       edit(base, "  trail: 0.08\n", "  trail: = c\n  c: = 2 * d\n  d: = trail + 1\n"),
       "= ^trail + 1",
       "parameters.d",
       {"cycle", "trail -> c -> d -> trail"}},
      {"a parameter of itself",
       edit(base, "trail: 0.08", "trail: = trail"),
       "= ^trail",
       "parameters.trail",
       {"cycle", "trail -> trail"}},
      {"bad syntax: the column in the string",
       edit(base, "inertia: [1, 1, 1]", "inertia: [1, \"= 2 * (trail + 1\", 1]"),
       "(trail + 1^\"",
       "bodies[0].inertia[1]",
       {"character 17", "is not closed"}},
      {"a non-finite result",
       edit(base, "mass: 1", "mass: = sqrt(trail - wheelbase)"),
       "mass: = ^sqrt",
       "bodies[0].mass",
       {"not finite (nan)"}},
      {"division by zero",
       edit(base, "mass: 1", "mass: = 1 / (trail - 0.08)"),
       "mass: = 1 ^/",
       "bodies[0].mass",
       {"division by zero"}},
      {"a wrong number of arguments",
       edit(base, "mass: 1", "mass: = max(trail)"),
       "mass: = ^max",
       "bodies[0].mass",
       {"max takes at least 2 arguments, got 1"}},
      {"a value's check sees the value",
       edit(base, "mass: 1", "mass: = trail - wheelbase"),
       "mass: ^= trail",
       "bodies[0].mass",
       {"must be > 0", "= trail - wheelbase' = -0.94"}},
      {"a reserved name",
       edit(base, "trail: 0.08", "sin: 0.08"),
       "^sin: 0.08",
       "parameters.sin",
       {"reserved"}},
      {"a name that is no identifier",
       edit(base, "trail: 0.08", "2x: 0.08"),
       "^2x: 0.08",
       "parameters.2x",
       {"must start with a letter"}},
      {"a list as a value",
       edit(base, "trail: 0.08", "trail: [1, 2]"),
       "trail: ^[1, 2]",
       "parameters.trail",
       {"expected a number or an expression"}},
      {"a non-finite parameter",
       edit(base, "trail: 0.08", "trail: .inf"),
       "trail: ^.inf",
       "parameters.trail",
       {"non-finite"}},
      {"a text where a number belongs is still refused",
       edit(base, "mass: 1", "mass: trail"),
       "mass: ^trail",
       "bodies[0].mass",
       {"expected a number"}},
  };
  for (const BadCase& c : cases) expect_refused(c);
  // A chain of parameters each using the next is bounded too: 300 deep is refused.
  std::string chain;
  for (int i = 0; i < 300; ++i)
    chain += "  p" + std::to_string(i) + ": = p" + std::to_string(i + 1) + "\n";
  chain += "  p300: 1\n";
  expect_refused({"a chain too deep",
                  edit(base, "  trail: 0.08\n", chain),
                  "p256: ^= p257",
                  "parameters.p256",
                  {"more than 256 deep"}});
}

// The writer keeps the parameters and every expression whose number it writes unchanged; a
// number it changed (the initial pose) becomes the number. Read back, the model is the same
// bit for bit.
TEST(Parameters, WriterKeepsTheExpressions) {
  const io::ModelFile f = io::parse_model_file(kModel, "pendulum.yaml");
  VectorX q = f.q;
  q[0] = 0.125;  // a new pose: the expression `= tilt / 2` no longer gives it
  const std::string text = io::model_file_text(f.model, q, f.z, f.simulation, "", f.parameters);
  for (const char* kept :
       {"parameters:\n", "  mass: '= 2 * half_mass'\n", "  length: 1.5\n", "  tilt: '= pi / 10'\n",
        "mass: '= mass'", "com: [0.0, 0.0, '= -length / 2']",
        "axis: ['= cos(tilt)', 0.0, '= sin(tilt)']", "gravity: [0.0, 0.0, '= -9.81']",
        "inertia: ['= mass * length^2 / 12', '= mass * length^2 / 12', '= mass * radius^2 / 2'",
        "joint: [0.125]", "t_end: '= 2 * length'"})
    EXPECT_NE(text.find(kept), std::string::npos) << kept << "\n" << text;
  const io::ModelFile back = io::parse_model_file(text, "written.yaml");
  EXPECT_EQ(back.model.body(0).mass, f.model.body(0).mass);
  EXPECT_EQ(back.model.body(0).inertia, f.model.body(0).inertia);
  EXPECT_EQ(back.model.body(0).com, f.model.body(0).com);
  EXPECT_EQ(back.model.joint(0).axis, f.model.joint(0).axis);
  EXPECT_EQ(back.q[0], 0.125);
  EXPECT_EQ(back.parameters.parameters.size(), 5u);
  // Without the parameters, numbers only, as before.
  const std::string plain = io::model_file_text(f.model, q, f.z, f.simulation);
  EXPECT_EQ(plain.find("parameters"), std::string::npos);
  EXPECT_EQ(plain.find("'="), std::string::npos);
}

// `kanedyn equilibrium -o` writes the rest pose: the parameters and expressions stay, the
// pose that changed is a number.
TEST(Parameters, EquilibriumKeepsTheExpressions) {
  const fs::path dir = temp_dir("parameters_equilibrium");
  std::ofstream(dir / "pendulum.yaml") << kModel;
  const ToolRun r = run_in(dir, "equilibrium pendulum.yaml -o rest.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string rest = slurp(dir / "rest.yaml");
  EXPECT_NE(rest.find("  tilt: '= pi / 10'"), std::string::npos) << rest;
  EXPECT_NE(rest.find("com: [0.0, 0.0, '= -length / 2']"), std::string::npos) << rest;
  EXPECT_EQ(rest.find("= tilt / 2"), std::string::npos) << rest;  // the pose moved
  const io::ModelFile f = io::load_model_file((dir / "rest.yaml").string());
  EXPECT_EQ(f.model.body(0).mass, 1.0);
}

TEST(Parameters, InfoPrintsThem) {
  const fs::path dir = temp_dir("parameters_info");
  std::ofstream(dir / "pendulum.yaml") << kModel;
  const ToolRun r = run_in(dir, "info pendulum.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* line :
       {"parameters: 5\n", "  length = 1.5\n", "  mass = 1  (= 2 * half_mass)\n",
        "  tilt = 0.3141592653589793  (= pi / 10)\n", "  radius = 0.15  (= length / 10)\n"})
    EXPECT_NE(r.out.find(line), std::string::npos) << line << "\n" << r.out;
}

// A study varies `parameters.NAME` as any number, and the expressions that use it follow: a
// body drifting at `= speed` for 1 s, with no force, ends at x = speed (1e-12: the integrator's
// error on a straight line is round-off).
TEST(Parameters, StudyVariesAParameter) {
  const fs::path dir = temp_dir("parameters_study");
  std::ofstream(dir / "drift.yaml") << R"(format: kanedyn-model/1
parameters:
  speed: 1.0
bodies:
  - name: puck
    parent: ground
    mass: 1
    inertia: [1, 1, 1]
    initial:
      translation_rate: ["= speed", 0, 0]
)";
  std::ofstream(dir / "study.yaml") << R"(format: kanedyn-study/1
model: drift.yaml
vary:
  - key: parameters.speed
    values: [0.5, 2.0, 3.0]
simulate:
  t_end: 1.0
  dt_out: 0.5
outputs:
  - final: puck.x
)";
  const ToolRun r = run_in(dir, "sweep study.yaml -o out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = read_csv(dir / "out" / "results.csv");
  ASSERT_EQ(rows.size(), 4u);
  const std::vector<std::string>& head = rows[0];
  const auto column = [&](const std::string& name) {
    return static_cast<size_t>(std::find(head.begin(), head.end(), name) - head.begin());
  };
  ASSERT_LT(column("parameters.speed"), head.size());
  ASSERT_LT(column("final:puck.x"), head.size());
  const double speeds[] = {0.5, 2.0, 3.0};
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(parse(rows[i + 1][column("parameters.speed")]), speeds[i]);
    EXPECT_NEAR(parse(rows[i + 1][column("final:puck.x")]), speeds[i], 1e-12);
  }
}

// A study may also set a number that the file gives as an expression: the number replaces it.
TEST(Parameters, DocumentFindsExpressionsAndParameters) {
  const io::ModelDocument doc = io::ModelDocument::parse(kModel, "pendulum.yaml");
  const auto length = doc.find_number("parameters.length");
  EXPECT_EQ(length.value, 1.5);
  const auto tilt = doc.find_number("parameters.tilt");  // a parameter given by an expression
  EXPECT_EQ(tilt.value, std::numbers::pi / 10);
  const auto com = doc.find_number("bodies[rod].com[2]");
  EXPECT_EQ(com.value, -0.75);
  const std::pair<uint32_t, double> changes[] = {{length.node, 3.0}, {com.node, -0.5}};
  const io::ModelFile f = doc.build(changes);
  EXPECT_EQ(f.model.body(0).inertia(0, 0), 1.0 * 9.0 / 12);  // follows the new length
  EXPECT_EQ(f.model.body(0).com.z(), -0.5);                  // the number given
}

// ---- The bicycle example (examples/bicycle.yaml, docs/bicycle.md) ----------------------------

// examples/bicycle_upright.yaml is examples/bicycle.yaml with no roll rate (and its own name): the
// two cannot drift apart.
TEST(BicycleExample, UprightIsThePushedOneWithoutItsRollRate) {
  const std::string pushed = slurp(kExamples + "/bicycle.yaml");
  std::string upright = edit(pushed, "  roll_rate: 0.5                # rad/s: the initial push\n",
                             "  roll_rate: 0                  # rad/s: none, the upright steady "
                             "motion\n");
  upright = edit(upright, "name: Whipple bicycle (Meijaard et al. 2007)\n",
                 "name: Whipple bicycle (Meijaard et al. 2007) upright at 5 m/s\n");
  EXPECT_EQ(slurp(kExamples + "/bicycle_upright.yaml"), upright);
  // Its numbers are the benchmark's (Table 1), derived by the file's expressions: the steer
  // axis meets the ground at the wheelbase plus the trail, w + c = 1.1 m.
  const io::ModelFile f = io::load_model_file(kExamples + "/bicycle_upright.yaml");
  const Model& m = f.model;
  const double lambda = std::numbers::pi / 10;
  const Vector3 at = m.body(2).joint,
                axis = m.joint(2).axis;  // the steer axis, at rear-axle height
  EXPECT_NEAR(at.x() - 0.3 * axis.x() / axis.z(), 1.1, 1e-15);
  EXPECT_NEAR(axis.x(), -std::sin(lambda), 1e-15);
  EXPECT_NEAR(m.body(2).joint.x() + m.body(3).joint.x(), 1.02, 1e-15);  // the front axle at w
  EXPECT_EQ(m.total_mass(), 94.0);
  // The rear wheel's spin v / rR and no roll rate, after the projection onto the constraints
  // (round-off).
  EXPECT_NEAR(f.z.cwiseAbs().maxCoeff(), 5.0 / 0.3, 1e-12);
  EXPECT_NEAR(f.z[0], 0.0, 1e-12);
}

// Table 2 of Meijaard et al. (2007) at v = 5 m/s: tests/data/meijaard2007.json holds the
// published values.
std::vector<std::complex<double>> published_at_five() {
  std::ifstream in(KANEDYN_SOURCE_DIR "/tests/data/meijaard2007.json");
  const nlohmann::json paper = nlohmann::json::parse(in);
  std::vector<std::complex<double>> values;
  for (const auto& entry : paper["eigenvalues_published"])
    if (entry["v"].get<double>() == 5.0)
      for (const auto& pair : entry["eigenvalues"])
        values.emplace_back(pair[0].get<double>(), pair[1].get<double>());
  return values;
}

// The README's `linearize` line of the bicycle, run exactly as written there (from a folder with
// a copy of examples/, as tests/test_tutorials.cpp runs the README's lines), prints the
// paper's four eigenvalues of roll and steer at 5 m/s and six zeros. The summary prints 5
// significant digits: each printed value is the published one rounded so (half a unit in the
// fifth digit).
TEST(BicycleExample, ReadmeLinePrintsTableTwo) {
  std::istringstream readme(slurp(fs::path(KANEDYN_SOURCE_DIR) / "README.md"));
  std::string args;
  for (std::string line; std::getline(readme, line);)
    if (line.starts_with("build/kanedyn linearize examples/bicycle")) {
      EXPECT_TRUE(args.empty()) << "two such lines";
      args = line.substr(std::string("build/kanedyn ").size());
      args.resize(args.find(" #"));
      while (args.back() == ' ') args.pop_back();
    }
  ASSERT_FALSE(args.empty()) << "the README has no bicycle linearize line";
  const fs::path dir = temp_dir("parameters_readme_bicycle");
  fs::copy(kExamples, dir / "examples", fs::copy_options::recursive);
  const ToolRun r = run_in(dir, args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.find("periodic"), std::string::npos) << r.out;
  std::vector<std::complex<double>> printed;
  std::istringstream out(r.out);
  for (std::string line; std::getline(out, line);) {
    std::istringstream words(line);
    int index = 0;
    std::string re, im;
    if (!(words >> index >> re >> im) || index != static_cast<int>(printed.size()) + 1) continue;
    printed.emplace_back(std::stod(re), std::stod(im));
  }
  ASSERT_EQ(printed.size(), 10u) << r.out;
  const auto rounding = [](double x) {  // half a unit in the fifth significant digit of x
    return x == 0.0 ? 0.0 : 0.5 * std::pow(10.0, std::floor(std::log10(std::abs(x))) - 4);
  };
  for (const std::complex<double>& want : published_at_five()) {
    const auto near = std::find_if(printed.begin(), printed.end(), [&](std::complex<double> p) {
      return std::abs(p.real() - want.real()) <= rounding(want.real()) &&
             std::abs(p.imag() - want.imag()) <= rounding(want.imag());
    });
    ASSERT_NE(near, printed.end()) << want << " is not printed:\n" << r.out;
    printed.erase(near);
  }
  ASSERT_EQ(printed.size(), 6u);
  for (const auto& zero : printed) EXPECT_EQ(zero, std::complex<double>(0.0, 0.0)) << r.out;
}

// docs/bicycle.md's trail sweep: five runs, each with the model its trail gives. They differ
// (the steer axis moves), and the benchmark's trail rights the bicycle: its final roll rate is
// below a fiftieth of the push (0.5 rad/s; the decay of docs/bicycle.md, e^-0.32 t at 5 s).
TEST(BicycleExample, TrailStudyRuns) {
  const fs::path dir = temp_dir("parameters_bicycle_trail");
  const ToolRun r = run_in(dir, "sweep '" + kExamples + "/studies/bicycle_trail.yaml' -o trail");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = read_csv(dir / "trail" / "results.csv");
  ASSERT_EQ(rows.size(), 6u);
  const std::vector<std::string>& head = rows[0];
  const auto column = [&](const std::string& name) {
    const auto it = std::find(head.begin(), head.end(), name);
    EXPECT_NE(it, head.end()) << name;
    return static_cast<size_t>(it - head.begin());
  };
  std::vector<double> finals;
  for (size_t i = 1; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i][column("status")], "ok");
    finals.push_back(parse(rows[i][column("final:rear_frame.w1")]));
    if (parse(rows[i][column("parameters.trail")]) == 0.08) {
      EXPECT_LT(std::abs(finals.back()), 0.01);
    }
  }
  std::sort(finals.begin(), finals.end());
  EXPECT_EQ(std::unique(finals.begin(), finals.end()), finals.end());
}

}  // namespace
}  // namespace kanedyn::test
