#include "reports/mat_file.h"

#include <algorithm>
#include <array>

namespace servokit {
namespace {

// MATLAB's namelengthmax.
constexpr std::size_t kMatlabNameLength = 63;

// MATLAB's iskeyword list: names `load` cannot give a variable.
constexpr std::array<const char*, 20> kMatlabKeywords = {
    "break",      "case",   "catch",    "classdef", "continue", "else",      "elseif",
    "end",        "for",    "function", "global",   "if",       "otherwise", "parfor",
    "persistent", "return", "spmd",     "switch",   "try",      "while"};

}  // namespace

std::optional<std::string> MatlabNameProblem(const std::string& name) {
  const auto is_letter = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); };
  const auto is_name_char = [&](char c) {
    return is_letter(c) || (c >= '0' && c <= '9') || c == '_';
  };
  if (name.empty() || !is_letter(name.front()) ||
      !std::all_of(name.begin(), name.end(), is_name_char)) {
    return std::string("not a MATLAB name (a letter, then letters, digits and _)");
  }
  if (name.size() > kMatlabNameLength) {
    return "longer than MATLAB's " + std::to_string(kMatlabNameLength) + " characters";
  }
  if (std::find_if(kMatlabKeywords.begin(), kMatlabKeywords.end(),
                   [&](const char* keyword) { return name == keyword; }) != kMatlabKeywords.end()) {
    return std::string("a MATLAB keyword");
  }
  return std::nullopt;
}

}  // namespace servokit
