// Private: YAML documents from text, with the guards every YAML reader of the project needs.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

namespace vinci::sim::internal {

/// The YAML documents in `text`. Throws std::invalid_argument "SOURCE:LINE: YAML syntax error:
/// ..." for malformed YAML, including the inputs on which yaml-cpp 0.7's own YAML::LoadAll
/// never returns (a stray ',' at the top level, e.g. the text "," or "# c\n, a: 1": its parser
/// yields an empty document without consuming the token, forever; yaml-cpp issue 1040). The
/// event stream is scanned first and a document that starts where the previous one started is
/// reported at that line; only then are the nodes built.
std::vector<YAML::Node> LoadYamlDocuments(const std::string& text, const std::string& source);

}  // namespace vinci::sim::internal
