// What must hold for any study file (docs/studies.md, read by kanedyn::io::parse_study), whatever
// the bytes: shared by the libFuzzer target kanedyn_fuzz_study and its replay driver. The study's
// model is given as text (parse_study's model_text), so no file is read: an example model,
// eight_body.yaml or cart_pole.yaml when the study's text names it (the key paths of
// examples/studies/eight_body_stiffness.yaml, an input's `inputs[...]`), else tennis_racket.yaml.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <typeinfo>
#include <vector>

#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/study.hpp"
#include "loader_invariants.hpp"

#ifndef KANEDYN_FUZZ_EXAMPLES
#error "KANEDYN_FUZZ_EXAMPLES: the examples folder (fuzz/CMakeLists.txt defines it)"
#endif

namespace kanedyn::fuzz {

/// The name every study input is parsed under; error messages must start with it.
inline constexpr const char* kStudySourceName = "fuzz_study.yaml";
/// Larger than any draw's |z| (Box-Muller's with 1 - u >= 2^-53: 8.58).
inline constexpr double kMaxNormalDraw = 10.0;

/// A number for a message: %.17g.
inline std::string number_text(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", x);
  return buffer;
}

inline std::string read_example(const char* name) {
  const std::string path = std::string(KANEDYN_FUZZ_EXAMPLES) + "/" + name;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "kanedyn fuzz: cannot read the example %s\n", path.c_str());
    std::abort();
  }
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The model text a study input runs with.
inline const std::string& study_model_text(std::string_view study) {
  static const std::string tennis = read_example("tennis_racket.yaml");
  static const std::string eight_body = read_example("eight_body.yaml");
  static const std::string cart_pole = read_example("cart_pole.yaml");
  if (study.find("eight_body") != std::string_view::npos) return eight_body;
  if (study.find("cart_pole") != std::string_view::npos) return cart_pole;
  return tennis;
}

/// Run `run`'s values against their entries: never NaN; a grid's or a choice's one of its
/// values; a uniform draw within [low, high]; a normal or log-normal draw finite wherever its
/// formula cannot overflow (a mean or mu near the largest double may: the run's model then
/// refuses the value, as a file's).
inline std::string check_parameters(const io::Study& study, long run) {
  const std::vector<double> p = study.parameters(run);
  if (p.size() != study.vary.size())
    return "parameters(" + std::to_string(run) + ") has " + std::to_string(p.size()) +
           " values for " + std::to_string(study.vary.size()) + " vary entries";
  for (size_t j = 0; j < p.size(); ++j) {
    const io::StudyVary& v = study.vary[j];
    const double x = p[j];
    const std::string what = "run " + std::to_string(run) + ", vary[" + std::to_string(j) + "] (" +
                             v.key + "): " + number_text(x) + " ";
    if (std::isnan(x)) return what + "is NaN";
    switch (v.draw) {
      case io::Draw::grid:
      case io::Draw::choice: {
        bool listed = false;
        for (const double value : v.values) listed = listed || value == x;
        if (!listed) return what + "is none of the entry's values";
        break;
      }
      case io::Draw::uniform:
        if (!(x >= v.a && x <= v.b))
          return what + "lies outside the uniform range [" + number_text(v.a) + ", " +
                 number_text(v.b) + "]";
        break;
      case io::Draw::normal:
        if (std::isfinite(std::abs(v.a) + kMaxNormalDraw * std::abs(v.b)) && !std::isfinite(x))
          return what + "is not finite (mean " + number_text(v.a) + ", std " + number_text(v.b) +
                 ")";
        break;
      case io::Draw::lognormal:
        if (v.a + kMaxNormalDraw * v.b < 700.0 && !(std::isfinite(x) && x >= 0.0))
          return what + "is not a finite number >= 0 (mu " + number_text(v.a) + ", sigma " +
                 number_text(v.b) + ")";
        break;
    }
  }
  return "";
}

/// What an accepted study must be: runs >= 1 as its grids and `runs` make them, its entries'
/// numbers finite, a column per key and output, and finite values for a few runs.
inline std::string check_study_file(const io::Study& study) {
  if (study.runs < 1 || study.runs_per_point < 1 || study.grid_points < 1)
    return "accepted a study of " + std::to_string(study.runs) + " runs (" +
           std::to_string(study.grid_points) + " grid points, runs " +
           std::to_string(study.runs_per_point) + ")";
  if (study.runs / study.runs_per_point != study.grid_points ||
      study.runs % study.runs_per_point != 0)
    return "runs " + std::to_string(study.runs) + " is not the grid points times `runs`";
  for (const io::StudyVary& v : study.vary) {
    if (!std::isfinite(v.a) || !std::isfinite(v.b))
      return v.key + ": a draw's number is not finite";
    for (const double value : v.values)
      if (!std::isfinite(value)) return v.key + ": a listed value is not finite";
    if ((v.draw == io::Draw::grid || v.draw == io::Draw::choice) && v.values.empty())
      return v.key + ": an empty list of values";
  }
  if (study.columns().size() != 3 + study.vary.size() + study.outputs.size())
    return "the results table has " + std::to_string(study.columns().size()) + " columns";
  for (const long run : {0L, 1L, study.runs / 2, study.runs - 1}) {
    if (run >= study.runs) continue;
    if (const std::string v = check_parameters(study, run); !v.empty()) return v;
  }
  try {
    (void)study.parameters(study.runs);
    return "parameters(runs) did not throw std::out_of_range";
  } catch (const std::out_of_range&) {
  }
  // The settings every run starts from were checked when the study was read.
  (void)study.settings(study.model.base());
  return "";
}

/// Reads `text` as a study file of the fixed model and checks every invariant; nothing escapes.
inline LoaderVerdict check_study(std::string_view text) {
  LoaderVerdict verdict;
  const std::string& model_text = study_model_text(text);
  std::optional<io::Study> study;
  try {
    study.emplace(io::parse_study(std::string(text), kStudySourceName, "", &model_text));
  } catch (const io::ModelFileError& e) {  // StudyFileError too
    verdict.error = e.what();
    verdict.violation = check_error_message(verdict.error, kStudySourceName);
    return verdict;
  } catch (const std::exception& e) {
    verdict.violation = std::string(
                            "the study reader let an exception other than StudyFileError or "
                            "ModelFileError escape: ") +
                        typeid(e).name() + ": " + e.what();
    return verdict;
  } catch (...) {
    verdict.violation = "the study reader let a non-std exception escape";
    return verdict;
  }
  verdict.accepted = true;
  try {
    verdict.violation = check_study_file(*study);
  } catch (const std::exception& e) {
    verdict.violation =
        std::string("checking an accepted study threw ") + typeid(e).name() + ": " + e.what();
  }
  return verdict;
}

}  // namespace kanedyn::fuzz
