#pragma once
// The blanks between and around the words and numbers servokit reads (model values, grid texts,
// Matrix Market lines, CSV fields), and the one trim of them.
#include <string_view>

namespace servokit {

inline constexpr std::string_view kBlanks = " \t";

/// `text` without the blanks around it ("  5 deg " is "5 deg"; all blanks: empty).
inline std::string_view TrimBlanks(std::string_view text) {
  const std::size_t first = text.find_first_not_of(kBlanks);
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(kBlanks) - first + 1);
}

}  // namespace servokit
