#include "modeling/yaml_document.h"

#include <yaml-cpp/eventhandler.h>

#include <sstream>
#include <vector>

#include "base/errors.h"

namespace servokit {
namespace {

// Notes where each document starts and nothing else: enough to count the documents and to see
// the reader stall (a document starting where the one before it started).
class DocumentStarts final : public YAML::EventHandler {
 public:
  std::vector<YAML::Mark> starts;

  void OnDocumentStart(const YAML::Mark& mark) override { starts.push_back(mark); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&,
                const std::string&,
                YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&,
                       const std::string&,
                       YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&,
                  const std::string&,
                  YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

[[noreturn]] void FailAt(const std::string& source,
                         const YAML::Mark& mark,
                         const std::string& problem) {
  // yaml-cpp counts lines and columns from 0; editors count from 1.
  throw ModelError(source + ":" + std::to_string(mark.line + 1) + ":" +
                   std::to_string(mark.column + 1) + ": bad YAML: " + problem);
}

}  // namespace

YAML::Node LoadSingleYamlDocument(const std::string& text,
                                  const std::string& source,
                                  std::string_view file_kind) {
  try {
    std::istringstream stream(text);
    YAML::Parser parser(stream);
    DocumentStarts documents;
    while (parser.HandleNextDocument(documents)) {
      const std::size_t count = documents.starts.size();
      if (count >= 2 && documents.starts[count - 1].pos == documents.starts[count - 2].pos) {
        FailAt(source, documents.starts.back(), "cannot read on from here");
      }
    }
    if (documents.starts.size() > 1) {
      throw ModelError(source + ": holds " + std::to_string(documents.starts.size()) +
                       " YAML documents (separated by ---); " + std::string(file_kind) + " is one");
    }
    return YAML::Load(text);
  } catch (const YAML::ParserException& error) {
    FailAt(source, error.mark, error.msg);
  }
}

}  // namespace servokit
