// The tutorials (docs/tutorial-notes.md, docs/tutorial-first-model.md) run as written: every
// command they show is run and its output compared with the text of the page, so a change of
// the tool's output makes this test fail until the page is brought up to date.
//
// The form a page follows:
//
//   ```console                      a block of commands and their output
//   $ kanedyn ARGS                  a command: run as `kanedyn ARGS` (by a shell)
//   OUTPUT LINES                    what it prints: stdout, then stderr, exactly
//   ...                             a line of three dots matches any number of lines (also none)
//   [exit N]                        optional last line: the exit code must be N (default 0)
//   ```
//
//   ```yaml file=NAME               a file the commands below use
//   ```
//
// A `file=` block whose NAME starts with `examples/` must be that file of the source tree,
// byte for byte (a page that shows a whole example file cannot drift from it); any other NAME
// is written into the page's folder before the commands that follow it.
//
// Each page runs in a fresh folder under the build folder (temp_dir), into which the source
// tree's examples/ are copied first: paths such as examples/eight_body.yaml resolve as they do
// from the source root, and whatever a command writes (a trajectory CSV) stays in that folder.
// The commands of a page run in order in that one folder, so a later command can read what an
// earlier one wrote.
//
// The README and the tutorials also show command lines without their output, in `sh` blocks:
// every line of a code block (other than a `console` block, whose commands are checked with
// their output above) that starts with `build/kanedyn ` or `kanedyn ` is run the same way, in
// the page's order and folder, its trailing `# comment` dropped, and must exit 0. What counts:
// only the kanedyn tool's lines. The lines that install (`bash scripts/...`, `pip`, `venv`),
// run the Python examples (`PYTHONPATH=... python3 examples/python/...`: python/tests/
// test_examples.py runs each) or the C++ example program (`build/examples/simulate_example`)
// are not the tool's, and are left to those tests.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "file_support.hpp"

namespace kanedyn::test {
namespace {

const std::string kElision = "...";

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines = split(text, '\n');
  if (!lines.empty() && lines.back().empty()) lines.pop_back();
  return lines;
}

/// True if `actual` matches `expected` line by line, where a line "..." of `expected` stands
/// for any number of lines (none included).
bool matches(const std::vector<std::string>& expected, size_t e,
             const std::vector<std::string>& actual, size_t a) {
  while (e < expected.size()) {
    if (expected[e] == kElision) {
      for (size_t skip = a; skip <= actual.size(); ++skip)
        if (matches(expected, e + 1, actual, skip)) return true;
      return false;
    }
    if (a >= actual.size() || expected[e] != actual[a]) return false;
    ++e;
    ++a;
  }
  return a == actual.size();
}

bool matches(const std::vector<std::string>& expected, const std::vector<std::string>& actual) {
  return matches(expected, 0, actual, 0);
}

struct Command {
  int line = 0;  // of the `$ kanedyn` line in the page, 1-based
  std::string args;
  std::vector<std::string> expected;
  int exit_code = 0;
};

struct FileBlock {
  int line = 0;
  std::string name, text;
};

/// A page's steps in order: a file to write or compare, or a command to run.
struct Step {
  bool is_file = false;
  FileBlock file;
  Command command;
};

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

std::vector<Step> parse_page(const std::string& page, const std::string& where) {
  const std::vector<std::string> lines = lines_of(page);
  std::vector<Step> steps;
  const std::string fence = "```";
  const std::string prompt = "$ kanedyn ";
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string& open = lines[i];
    const size_t file_at = open.find(" file=");
    if (starts_with(open, fence) && file_at != std::string::npos) {
      Step step;
      step.is_file = true;
      step.file.line = static_cast<int>(i) + 1;
      step.file.name = open.substr(file_at + 6);
      for (++i; i < lines.size() && lines[i] != fence; ++i) step.file.text += lines[i] + "\n";
      EXPECT_LT(i, lines.size()) << where << ":" << step.file.line << ": unclosed block";
      steps.push_back(step);
      continue;
    }
    if (open != fence + "console") continue;
    const int block_line = static_cast<int>(i) + 1;
    bool any = false;
    for (++i; i < lines.size() && lines[i] != fence; ++i) {
      const std::string& line = lines[i];
      if (starts_with(line, "$ ")) {
        EXPECT_TRUE(starts_with(line, prompt))
            << where << ":" << i + 1 << ": only kanedyn commands can be checked: " << line;
        Step step;
        step.command.line = static_cast<int>(i) + 1;
        step.command.args = line.substr(std::min(line.size(), prompt.size()));
        steps.push_back(step);
        any = true;
        continue;
      }
      EXPECT_TRUE(any) << where << ":" << i + 1 << ": output before the first command";
      if (!any) continue;
      steps.back().command.expected.push_back(line);
    }
    EXPECT_LT(i, lines.size()) << where << ":" << block_line << ": unclosed block";
    EXPECT_TRUE(any) << where << ":" << block_line << ": a console block without a command";
  }
  for (Step& step : steps) {
    if (step.is_file) continue;
    std::vector<std::string>& out = step.command.expected;
    if (!out.empty() && starts_with(out.back(), "[exit ") && out.back().back() == ']') {
      step.command.exit_code = std::stoi(out.back().substr(6));
      out.pop_back();
    }
  }
  return steps;
}

/// The page's folder, with a copy of the source tree's examples/.
fs::path page_dir(const std::string& name) {
  const fs::path dir = temp_dir(name);
  fs::copy(kExamples, dir / "examples", fs::copy_options::recursive);
  return dir;
}

ToolRun run_command(const fs::path& dir, const std::string& args) {
  const fs::path capture = dir.parent_path() / (dir.filename().string() + ".capture");
  fs::create_directories(capture);
  const std::string cmd = "cd '" + dir.string() + "' && '" + kTool + "' " + args + " > '" +
                          (capture / "stdout.txt").string() + "' 2> '" +
                          (capture / "stderr.txt").string() + "' < /dev/null";
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(capture / "stdout.txt"),
          slurp(capture / "stderr.txt")};
}

std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const std::string& l : lines) s += l + "\n";
  return s;
}

/// Runs every step of docs/NAME.md; returns the number of commands run.
int check_page(const std::string& name) {
  const fs::path path = fs::path(KANEDYN_SOURCE_DIR) / "docs" / (name + ".md");
  const std::string page = slurp(path);
  EXPECT_FALSE(page.empty()) << path;
  const std::string where = "docs/" + name + ".md";
  const fs::path dir = page_dir(name);
  int commands = 0;
  for (const Step& step : parse_page(page, where)) {
    if (step.is_file) {
      const FileBlock& f = step.file;
      if (starts_with(f.name, "examples/")) {
        EXPECT_EQ(f.text, slurp(fs::path(KANEDYN_SOURCE_DIR) / f.name))
            << where << ":" << f.line << ": the block differs from " << f.name;
      } else {
        std::ofstream(dir / f.name, std::ios::binary) << f.text;
      }
      continue;
    }
    const Command& c = step.command;
    const ToolRun run = run_command(dir, c.args);
    ++commands;
    const std::vector<std::string> actual = lines_of(run.out + run.err);
    EXPECT_EQ(run.exit_code, c.exit_code) << where << ":" << c.line << ": kanedyn " << c.args;
    EXPECT_TRUE(matches(c.expected, actual))
        << where << ":" << c.line << ": the output of `kanedyn " << c.args
        << "` differs from the page.\n--- the page shows:\n"
        << joined(c.expected) << "--- the command printed:\n"
        << joined(actual);
  }
  return commands;
}

struct CommandLine {
  int line = 0;
  std::string args;  // after `kanedyn `, without the trailing comment
};

/// Every kanedyn command line in a code block of `page` outside `console` blocks.
std::vector<CommandLine> command_lines(const std::string& page) {
  const std::vector<std::string> lines = lines_of(page);
  std::vector<CommandLine> found;
  bool in_block = false, console = false;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    if (starts_with(line, "```")) {
      console = !in_block && line == "```console";
      in_block = !in_block;
      continue;
    }
    if (!in_block || console) continue;
    std::string text = line;
    if (starts_with(text, "$ ")) text = text.substr(2);
    std::string args;
    for (const std::string& prefix : {std::string("build/kanedyn "), std::string("kanedyn ")})
      if (starts_with(text, prefix)) args = text.substr(prefix.size());
    if (args.empty()) continue;
    // The comment: the first " #" (no argument of these lines holds a '#').
    if (const size_t hash = args.find(" #"); hash != std::string::npos) args.resize(hash);
    while (!args.empty() && args.back() == ' ') args.pop_back();
    found.push_back({static_cast<int>(i) + 1, args});
  }
  return found;
}

/// Runs every command line of `relative` (from the source root) in a fresh folder with a copy
/// of examples/; each must exit 0. Returns how many ran.
int run_command_lines(const std::string& relative) {
  const std::string page = slurp(fs::path(KANEDYN_SOURCE_DIR) / relative);
  EXPECT_FALSE(page.empty()) << relative;
  const fs::path dir = page_dir("lines_" + fs::path(relative).stem().string());
  int ran = 0;
  for (const CommandLine& c : command_lines(page)) {
    const auto start = std::chrono::steady_clock::now();
    const ToolRun run = run_command(dir, c.args);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ++ran;
    EXPECT_EQ(run.exit_code, 0) << relative << ":" << c.line << ": kanedyn " << c.args << "\n"
                                << run.err;
    // Shown so that a slow line is seen, not hidden: the test runs every line as written.
    if (seconds > 2.0)
      std::printf("%s:%d: kanedyn %s took %.1f s\n", relative.c_str(), c.line, c.args.c_str(),
                  seconds);
  }
  return ran;
}

TEST(Tutorials, CommandLinesAreFoundOutsideConsoleBlocks) {
  const std::string page =
      "text build/kanedyn info x.yaml\n"
      "```sh\n"
      "build/kanedyn info a.yaml   # a comment\n"
      "$ kanedyn eom b.yaml --json\n"
      "PYTHONPATH=build/python /usr/bin/python3 examples/python/x.py\n"
      "bash scripts/test.sh\n"
      "```\n"
      "```console\n"
      "$ kanedyn info c.yaml\n"
      "```\n";
  const std::vector<CommandLine> found = command_lines(page);
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0].line, 3);
  EXPECT_EQ(found[0].args, "info a.yaml");
  EXPECT_EQ(found[1].line, 4);
  EXPECT_EQ(found[1].args, "eom b.yaml --json");
}

TEST(Tutorials, ReadmeCommandLinesRun) { EXPECT_GE(run_command_lines("README.md"), 25); }

TEST(Tutorials, TutorialCommandLinesRun) {
  // Every docs/tutorial-*.md: its console blocks are checked by the tests below (each page is
  // named there, and this test fails for a page that is not), its other lines here.
  std::vector<std::string> pages;
  for (const auto& entry : fs::directory_iterator(fs::path(KANEDYN_SOURCE_DIR) / "docs")) {
    const std::string name = entry.path().filename().string();
    if (starts_with(name, "tutorial-") && entry.path().extension() == ".md") pages.push_back(name);
  }
  std::sort(pages.begin(), pages.end());
  EXPECT_EQ(pages, (std::vector<std::string>{"tutorial-first-model.md", "tutorial-notes.md"}))
      << "a new tutorial: add a test that runs its console blocks (check_page) below";
  for (const std::string& name : pages) run_command_lines("docs/" + name);
}

TEST(Tutorials, ElisionMatchesAnyNumberOfLines) {
  const std::vector<std::string> out{"a", "b", "c", "d"};
  EXPECT_TRUE(matches({"a", "b", "c", "d"}, out));
  EXPECT_TRUE(matches({"a", "...", "d"}, out));
  EXPECT_TRUE(matches({"...", "b", "c", "d"}, out));
  EXPECT_TRUE(matches({"a", "b", "c", "d", "..."}, out));
  EXPECT_TRUE(matches({"a", "...", "b", "...", "d"}, out));
  EXPECT_TRUE(matches({"..."}, out));
  EXPECT_FALSE(matches({"a", "...", "c"}, out));
  EXPECT_FALSE(matches({"a", "b", "c"}, out));
  EXPECT_FALSE(matches({"a", "b", "c", "d", "e"}, out));
  EXPECT_FALSE(matches({"a", "...", "x", "..."}, out));
  EXPECT_FALSE(matches({"a", "b", "c", "d "}, out));
}

TEST(Tutorials, NotesTutorialOutputsAreCurrent) { EXPECT_GE(check_page("tutorial-notes"), 8); }

TEST(Tutorials, FirstModelTutorialOutputsAreCurrent) {
  EXPECT_GE(check_page("tutorial-first-model"), 14);
}

// docs/cli.md's samples of usage errors, checked as a tutorial's: the list of commands in the
// unknown-command message is the tool's.
TEST(Tutorials, CliPageSamplesAreCurrent) { EXPECT_EQ(check_page("cli"), 2); }

TEST(Tutorials, SatelliteLoadsAndSimulates) {
  const fs::path dir = temp_dir("tutorial_satellite");
  const std::string model = "'" + kExamples + "/satellite.yaml'";
  const ToolRun info = run_in(dir, "info " + model);
  EXPECT_EQ(info.exit_code, 0) << info.err;
  const ToolRun sim =
      run_in(dir, "simulate " + model + " --t-end 0.2 --dt-out 0.05 --out satellite.csv");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const auto rows = read_csv(dir / "satellite.csv");
  ASSERT_EQ(rows.size(), 6u);  // the header, t = 0, 0.05, ..., 0.2
  EXPECT_EQ(rows.front().front(), "t");
  EXPECT_DOUBLE_EQ(parse(rows.back().front()), 0.2);
}

}  // namespace
}  // namespace kanedyn::test
