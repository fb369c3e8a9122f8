// YAML text to documents with the guards every YAML reader of the project needs (scene files,
// the field, design and plan specs). Callers include <yaml-cpp/yaml.h> themselves.
#pragma once

#include <string>
#include <vector>

namespace YAML {
class Node;
}  // namespace YAML

namespace vinci::sim {

/// The YAML documents in `text`. Throws std::invalid_argument "SOURCE:LINE: YAML syntax error:
/// ..." for malformed YAML, including the inputs on which yaml-cpp 0.7's own YAML::Load and
/// YAML::LoadAll never return (a stray ',' at the top level, e.g. the text "," or
/// "# c\n, a: 1": its parser yields an empty document without consuming the token, forever,
/// growing memory; yaml-cpp issue 1040). The event stream is scanned first and a document that
/// starts where the previous one started is reported at that line; only then are the nodes
/// built.
std::vector<YAML::Node> LoadYamlDocuments(const std::string& text, const std::string& source);

/// The first document of `text` (a null node if there is none), as YAML::Load but with the
/// guards and errors of LoadYamlDocuments (later documents are checked, then ignored).
YAML::Node LoadYamlDocument(const std::string& text, const std::string& source);

}  // namespace vinci::sim
