// Options shared by the subcommands: strict decimal numbers, and the state a command
// evaluates at (the model's initial state, or a row of a trajectory).
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "kanedyn/io/model_file.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::cli {

/// A CLI11 check: a finite decimal number (no hex, inf or nan) that neither overflows nor
/// underflows to 0; with `positive`, also > 0.
CLI::Validator decimal_number(bool positive);
inline CLI::Validator positive_number() { return decimal_number(true); }

/// Adds an option (or a positional argument) that names a file the command reads. Every file
/// named so is an input of the command, and no output may be one of them (input_files()):
/// a command that reads a file through any other kind of option would let its output replace
/// that file.
CLI::Option* add_input_file(CLI::App* cmd, const std::string& name, std::string& path,
                            const std::string& help);
/// The files named on this command line by the options of add_input_file: what
/// io::check_output_path compares each output with.
std::vector<std::string> input_files();

/// The help of every MODEL argument: load_model_file reads all three.
inline constexpr const char* kModelHelp = "model file: YAML, JSON or URDF (.urdf)";

/// A CLI11 check for --route: recursive or assembled, and `kane`, the older spelling of
/// assembled, which still works but is left out of the help (as is --method, the option's
/// older name, which each command adds with group("") beside --route).
CLI::Validator route_names();

/// Label of speed i (0-based) of {y} in an N-body model, in the order of Eq. (1): wK.c
/// (w'_K component c) or sdK.c (s'_K dot component c), as eom prints them and inspect --row
/// reads them.
std::string speed_label(int n, int i);

/// Body k's chain down to the inertial frame, 1-based, "8 -> 7 -> 1 -> 0"; a chain of more
/// than 7 bodies shows its first 6 and its root ("...N more..." between), so that the text for
/// a whole model stays O(N).
std::string chain_text(const Model& model, int k);

/// A model with constraints in one line: how many, their equations and rank, the redundant
/// rows, the independent speeds and what projecting the initial state changed.
std::string constraint_summary(const io::ModelFile& file);

/// `--trajectory FILE.csv --t T`, each needing the other.
struct StateChoice {
  std::string trajectory;
  double t = 0.0;
  std::vector<std::string> inputs;  ///< --input NAME=VALUE
};
void add_state_options(CLI::App* cmd, StateChoice& choice);

/// The state chosen: the model file's initial state, or the trajectory's row at t (throws
/// std::runtime_error naming the file and the problem). Sets t to the row's time (0 for the
/// initial state) and where to "its initial state" or "t = T of FILE (line L)".
State chosen_state(const io::ModelFile& file, const StateChoice& choice, double& t,
                   std::string& where);
/// The same, and for a jointed model the joint coordinates and speeds of that state (the
/// file's initial ones, or the row's j, jd columns); empty for the free tree.
State chosen_state(const io::ModelFile& file, const StateChoice& choice, double& t,
                   std::string& where, VectorX& q, VectorX& z);
/// The same, and the inputs' values there: the row's input columns (zero at the initial
/// state), then every --input NAME=VALUE.
State chosen_state(const io::ModelFile& file, const StateChoice& choice, double& t,
                   std::string& where, VectorX& q, VectorX& z, VectorX& u);

/// The operating point of an analysis command (linearize, view --mode): (q, z) in the Model's
/// layout for every model, and u. From --state FILE (a model file of the same bodies and
/// joints, such as the one equilibrium writes: its initial state) when given, else from
/// chosen_state(); then the --input values. `where` says which.
struct OperatingPoint {
  VectorX q, z, u;
  std::string where;
};
OperatingPoint operating_point(const io::ModelFile& file, const StateChoice& choice,
                               const std::string& state_file);

}  // namespace kanedyn::cli
