#pragma once
// Every expression text of the shipped and test models and of the expression fuzz corpus: the
// corpus on which tests hold two routes of the symbolic core equal (the reader against GiNaC's
// parser, derivatives on canonical forms against GiNaC's diff).
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/test_files.h"

namespace servokit::testing {

/// Every scalar of a YAML tree, appended to `out`.
inline void CollectScalars(const YAML::Node& node, std::vector<std::string>& out) {
  if (node.IsScalar()) {
    out.push_back(node.Scalar());
  } else if (node.IsSequence() || node.IsMap()) {
    for (const auto& child : node) {
      if (node.IsMap()) {
        CollectScalars(child.second, out);
      } else {
        CollectScalars(child, out);
      }
    }
  }
}

/// The scalars of every model file (in file order) and of the expression corpus.
inline std::vector<std::string> ModelTexts() {
  namespace fs = std::filesystem;
  std::vector<std::string> texts;
  std::vector<fs::path> files;
  for (const char* folder : {SERVOKIT_MODELS_DIR, SERVOKIT_TEST_DATA_DIR}) {
    for (const auto& entry : fs::recursive_directory_iterator(folder)) {
      if (entry.is_regular_file() && entry.path().extension() == ".yaml") {
        files.push_back(entry.path());
      }
    }
  }
  const fs::path corpus =
      fs::path(SERVOKIT_TEST_DATA_DIR).parent_path() / "fuzz" / "corpus" / "expression";
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    try {
      CollectScalars(YAML::Load(ReadFile(file)), texts);
    } catch (const YAML::Exception&) {
      // a file that tests the loader's YAML errors
    }
  }
  if (fs::is_directory(corpus)) {
    std::vector<fs::path> entries;
    for (const auto& entry : fs::directory_iterator(corpus)) entries.push_back(entry.path());
    std::sort(entries.begin(), entries.end());
    for (const fs::path& entry : entries) {
      try {
        CollectScalars(YAML::Load(ReadFile(entry)), texts);
      } catch (const YAML::Exception&) {
      }
    }
  }
  return texts;
}

}  // namespace servokit::testing
