#include "reports/escaping.h"

#include <array>
#include <cstdio>

namespace servokit {
namespace {

bool IsControl(char c) {
  const auto byte = static_cast<unsigned char>(c);
  return byte < 0x20 || byte == 0x7f;
}

void AppendControl(std::string& out, char c) {
  switch (c) {
    case '\n':
      out += "\\n";
      return;
    case '\r':
      out += "\\r";
      return;
    case '\t':
      out += "\\t";
      return;
    default: {
      std::array<char, 5> hex{};
      std::snprintf(hex.data(), hex.size(), "\\x%02x", unsigned(static_cast<unsigned char>(c)));
      out += hex.data();
    }
  }
}

bool IsAsciiPunctuation(char c) {
  return (c >= '!' && c <= '/') || (c >= ':' && c <= '@') || (c >= '[' && c <= '`') ||
         (c >= '{' && c <= '~');
}

}  // namespace

std::string PlainText(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    if (IsControl(c)) {
      AppendControl(out, c);
    } else {
      out += c;
    }
  }
  return out;
}

std::string GnuplotString(std::string_view text) {
  std::string out = "'";
  for (const char c : text) {
    if (c == '\'') {
      // gnuplot reads '' inside single quotes as one quote, but not two such pairs in a row;
      // a quote is therefore a string of its own, joined by gnuplot's concatenation.
      out += "'.\"'\".'";
    } else if (IsControl(c)) {
      AppendControl(out, c);
    } else {
      out += c;
    }
  }
  return out + "'";
}

std::string MarkdownText(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    if (c == '\n' || c == '\r') {
      out += ' ';
    } else if (IsControl(c)) {
      AppendControl(out, c);
    } else {
      if (IsAsciiPunctuation(c)) out += '\\';
      out += c;
    }
  }
  return out;
}

std::string HtmlText(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace servokit
