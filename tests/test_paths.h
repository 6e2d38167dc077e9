#pragma once
// Where tests find the shipped models and the test-only models (set by tests/CMakeLists.txt).
#include <string>

namespace servokit::testing {

inline std::string ModelPath(const std::string& file) {
  return std::string(SERVOKIT_MODELS_DIR) + "/" + file;
}
inline std::string TestDataPath(const std::string& file) {
  return std::string(SERVOKIT_TEST_DATA_DIR) + "/" + file;
}

}  // namespace servokit::testing
