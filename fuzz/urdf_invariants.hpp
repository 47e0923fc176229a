// What must hold for any input to the URDF import, whatever the bytes: shared by the libFuzzer
// target kanedyn_fuzz_urdf and its replay driver. The model loader's invariants
// (loader_invariants.hpp) judge the model the import writes.
#pragma once

#include <cstddef>
#include <exception>
#include <optional>
#include <string>
#include <string_view>
#include <typeinfo>
#include <utility>
#include <vector>

#include "../src/io/xml_scan.hpp"
#include "kanedyn/io/urdf.hpp"
#include "loader_invariants.hpp"

#ifdef KANEDYN_FUZZ_TINYXML
#include <tinyxml.h>
#endif

namespace kanedyn::fuzz {

/// The name every URDF input is converted under; error messages must start with it.
inline constexpr const char* kUrdfSourceName = "fuzz.urdf";

#ifdef KANEDYN_FUZZ_TINYXML
/// The deepest element of what TinyXML (urdfdom's parser) builds from `text`, found without
/// recursion; `parsed` says whether TinyXML read it without an error. After an error TinyXML
/// keeps the elements it made, so the depth is what its recursion reached.
inline int tinyxml_depth(std::string_view text, bool& parsed) {
  std::string padded(text);
  padded.append(8, '\0');  // as urdf.cpp passes it (TinyXML reads past a NUL)
  TiXmlDocument doc;
  doc.Parse(padded.c_str());
  parsed = !doc.Error();
  int deepest = 0;
  std::vector<std::pair<const TiXmlNode*, int>> stack{{&doc, 0}};
  while (!stack.empty()) {
    const auto [node, depth] = stack.back();
    stack.pop_back();
    if (depth > deepest) deepest = depth;
    for (const TiXmlNode* c = node->FirstChild(); c; c = c->NextSibling())
      if (c->ToElement()) stack.emplace_back(c, depth + 1);
  }
  return deepest;
}
#endif

/// The depth scan against TinyXML itself: never shallower than what TinyXML's recursion
/// reaches (that would let a deep file through to it), and exactly its depth for a text
/// TinyXML reads without an error.
inline std::string check_depth_scan(std::string_view text) {
  const io::detail::XmlScan scan = io::detail::scan_xml(text, io::kMaxUrdfDepth);
  if (scan.max_depth > io::kMaxUrdfDepth + 1)
    return "the depth scan went on past the limit, to " + std::to_string(scan.max_depth);
  if (!scan.problem.empty()) {
    if (scan.line < 1 || scan.column < 1 || scan.offset > text.size())
      return "the depth scan's refusal has no position: " + scan.problem;
    return "";
  }
#ifdef KANEDYN_FUZZ_TINYXML
  bool parsed = false;
  const int tinyxml = tinyxml_depth(text, parsed);
  if (tinyxml > scan.max_depth || (parsed && tinyxml != scan.max_depth))
    return "TinyXML nests elements " + std::to_string(tinyxml) + " deep" +
           (parsed ? "" : " (before its error)") + ", the depth scan counted " +
           std::to_string(scan.max_depth);
#endif
  return "";
}

/// Runs the import on `text` and checks every invariant; nothing escapes.
inline LoaderVerdict check_urdf(std::string_view text) {
  LoaderVerdict verdict;
  verdict.violation = check_depth_scan(text);
  if (!verdict.violation.empty()) return verdict;
  std::string yaml;
  try {
    std::vector<std::string> notes;
    yaml = io::urdf_to_model_yaml(std::string(text), kUrdfSourceName, {}, &notes);
  } catch (const io::ModelFileError& e) {
    verdict.error = e.what();
    verdict.violation = check_error_message(verdict.error, kUrdfSourceName);
    return verdict;
  } catch (const std::exception& e) {
    verdict.violation = std::string(
                            "the import let an exception other than ModelFileError "
                            "escape: ") +
                        typeid(e).name() + ": " + e.what();
    return verdict;
  } catch (...) {
    verdict.violation = "the import let a non-std exception escape";
    return verdict;
  }
  verdict.accepted = true;
  // The import's output loads: every command reads what `kanedyn import` writes.
  std::optional<io::ModelFile> file;
  try {
    file = io::parse_model_file(yaml, kUrdfSourceName);
  } catch (const std::exception& e) {
    verdict.violation = std::string("the import wrote a model the loader refuses: ") + e.what();
    return verdict;
  }
  if (const std::string v = check_front_ends(yaml); !v.empty()) {
    verdict.violation = "the import's output: " + v;
    return verdict;
  }
  try {
    verdict.violation = check_model_file(*file);
  } catch (const std::exception& e) {
    verdict.violation =
        std::string("evaluating an imported model threw ") + typeid(e).name() + ": " + e.what();
  } catch (...) {
    verdict.violation = "evaluating an imported model threw a non-std exception";
  }
  return verdict;
}

}  // namespace kanedyn::fuzz
