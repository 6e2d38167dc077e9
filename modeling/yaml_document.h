#pragma once
// The one YAML document of a file servokit reads (a model file, a waypoint file). yaml-cpp's own
// readers fall short of that: YAML::Load ignores whatever follows the first document (a second
// one after "---" would be dropped unseen), and YAML::LoadAll, on text it cannot move past (a
// stray flow indicator such as ","), returns empty documents forever (yaml-cpp 0.7).
#include <yaml-cpp/yaml.h>

#include <string>
#include <string_view>

namespace servokit {

/// The first YAML document of `text` (a null node for none). Throws ModelError
/// "source:line:column: bad YAML: ..." on a syntax error or on text the reader cannot move past,
/// and "source: holds N YAML documents (separated by ---); `file_kind` is one" on more than one
/// document, e.g. file_kind = "a model file".
YAML::Node LoadSingleYamlDocument(const std::string& text,
                                  const std::string& source,
                                  std::string_view file_kind);

}  // namespace servokit
