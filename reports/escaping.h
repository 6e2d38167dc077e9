#pragma once
// Text from a model file (its name, its description) shown in an output: one escaping function
// per format, so that the text is shown as written and never read as part of the format. The
// loader already refuses control characters in names (modeling/loader_support.h); these functions
// do not rely on that, since an API caller or a future key may bring any text.
#include <string>
#include <string_view>

namespace servokit {

/// `text` for a terminal or a plain-text comment line: each control character (a newline, an
/// escape sequence's ESC, DEL) written as a visible C escape ("\n", "\x1b"), so that the text
/// stays on its line and cannot drive a terminal.
std::string PlainText(std::string_view text);

/// `text` as a gnuplot string expression: single-quoted (no backslash escapes, no command
/// substitution there), each quote a double-quoted string of its own joined with gnuplot's `.`
/// ('it'."'".'s'), control characters as in PlainText. Terminals are set `noenhanced`
/// (reports/plots.cpp), so no other character has a meaning there.
std::string GnuplotString(std::string_view text);

/// `text` as inline Markdown: every ASCII punctuation character backslash-escaped (CommonMark
/// allows it for all of them, and so HTML, links, emphasis, code spans and table cells are all
/// shown as text), line breaks as spaces, other control characters as in PlainText.
std::string MarkdownText(std::string_view text);

/// `text` as HTML character data or a double-quoted attribute value: & < > " as entities.
std::string HtmlText(std::string_view text);

}  // namespace servokit
