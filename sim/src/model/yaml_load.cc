// YAML documents with the yaml-cpp 0.7 no-progress guard (vinci/sim/model/yaml_documents.h).
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "vinci/sim/model/yaml_documents.h"

namespace vinci::sim {
namespace {

// Records where each document starts; ignores the content.
class DocumentStarts final : public YAML::EventHandler {
 public:
  void OnDocumentStart(const YAML::Mark& mark) override { start = mark; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
  YAML::Mark start = YAML::Mark::null_mark();
};

[[noreturn]] void SyntaxError(const std::string& source, const YAML::Mark& mark,
                              const std::string& msg) {
  const std::string line = mark.is_null() ? "" : std::to_string(mark.line + 1) + ":";
  throw std::invalid_argument(source + ":" + line + " YAML syntax error: " + msg);
}

// A printable description of the character at `pos`.
std::string CharAt(const std::string& text, int pos) {
  if (pos < 0 || static_cast<std::size_t>(pos) >= text.size()) return "end of input";
  const unsigned char c = static_cast<unsigned char>(text[static_cast<std::size_t>(pos)]);
  if (c >= 0x20 && c < 0x7f) return std::string("'") + static_cast<char>(c) + "'";
  char buf[16];
  std::snprintf(buf, sizeof buf, "byte 0x%02x", c);
  return buf;
}

}  // namespace

std::vector<YAML::Node> LoadYamlDocuments(const std::string& text, const std::string& source) {
  try {
    std::istringstream in(text);
    YAML::Parser parser(in);
    DocumentStarts starts;
    int previous = -1;
    while (parser.HandleNextDocument(starts)) {
      if (starts.start.pos == previous)
        SyntaxError(source, starts.start,
                    "unexpected " + CharAt(text, starts.start.pos) +
                        " (a ',' is only allowed inside [ ] or { })");
      previous = starts.start.pos;
    }
    return YAML::LoadAll(text);
  } catch (const YAML::Exception& e) {
    SyntaxError(source, e.mark, e.msg);
  }
}

YAML::Node LoadYamlDocument(const std::string& text, const std::string& source) {
  std::vector<YAML::Node> docs = LoadYamlDocuments(text, source);
  return docs.empty() ? YAML::Node() : docs.front();
}

}  // namespace vinci::sim
