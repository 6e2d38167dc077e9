// Text from a model file shown in an output is shown as written and never read as part of the
// format (reports/escaping.h). gnuplot itself reads back each string the escaping writes: it
// must print the text verbatim and run nothing. Markdown and HTML go through the document
// renderer the reports use.
#include "reports/escaping.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "reports/document.h"
#include "tests/test_files.h"
#include "tests/test_process.h"

namespace servokit {
namespace {

using testing::RunProcess;
using testing::TemporaryDirectory;

// The names an attacker would give a model: quotes, backslashes, backticks, a shell command in
// each of gnuplot's and the shell's forms, HTML, a Modelica table header, a comment sign.
const std::vector<std::string> kHostileTexts = {
    "car'q",
    "it''s \\ \\\\ \\n",
    "`touch BACKQUOTE`",
    "system(\"touch SYSTEM\")",
    "$(touch DOLLAR) @macro",
    "<script>alert(1)</script> &amp;",
    "#1 double u_d(2,2)",
    "a | b *c* _d_ [e](f) ![g](h) \\`i\\`",
};

TEST_CASE("gnuplot prints every escaped string verbatim and runs nothing", "[reports]") {
  const TemporaryDirectory directory;
  std::string script, expected;
  for (const std::string& text : kHostileTexts) {
    script += "print " + GnuplotString(text) + "\n";
    expected += text + "\n";
  }
  std::ofstream(directory / "strings.gp") << script;
  const testing::ProcessResult gnuplot = RunProcess(directory.path(), {"gnuplot", "strings.gp"});
  REQUIRE(gnuplot.status == 0);
  CHECK(gnuplot.err == expected);  // gnuplot's print writes to stderr
  for (const char* planted : {"BACKQUOTE", "SYSTEM", "DOLLAR"}) {
    CHECK(!std::filesystem::exists(directory / planted));
  }
}

TEST_CASE("a line break cannot end a gnuplot string or a comment line", "[reports]") {
  const std::string text = "car\nsystem \"touch INJECTED\"\n#\x1b[31m";
  CHECK(GnuplotString(text) == "'car\\nsystem \"touch INJECTED\"\\n#\\x1b[31m'");
  CHECK(GnuplotString("it's") == "'it'.\"'\".'s'");
  CHECK(PlainText(text) == "car\\nsystem \"touch INJECTED\"\\n#\\x1b[31m");
  CHECK(PlainText("tab\there\r\x7f") == "tab\\there\\r\\x7f");
}

TEST_CASE("Markdown shows hostile text as text, and HTML shows it escaped", "[reports]") {
  CHECK(MarkdownText("<script>alert(1)</script>") == "\\<script\\>alert\\(1\\)\\<\\/script\\>");
  CHECK(MarkdownText("a\nb") == "a b");  // one paragraph: no heading or list can start
  for (const std::string& text : kHostileTexts) {
    Document document;
    document.title = MarkdownText(text);
    document.Add(Paragraph{MarkdownText(text)});
    const std::string markdown = RenderMarkdown(document);
    // No raw HTML and no code span: every '<' and '`' of the text is escaped in the Markdown.
    for (std::size_t at = markdown.find_first_of("<`"); at != std::string::npos;
         at = markdown.find_first_of("<`", at + 1)) {
      CHECK(markdown[at - 1] == '\\');
    }
    const std::string html = RenderHtml(document, ".");
    CHECK(html.find("<p>" + HtmlText(text) + "</p>") != std::string::npos);
    CHECK(html.find("<title>" + HtmlText(text) + "</title>") != std::string::npos);
    CHECK(html.find("<script>") == std::string::npos);
  }
}

TEST_CASE("HTML escapes the characters that start markup or end an attribute", "[reports]") {
  CHECK(HtmlText("<a href=\"x\">&</a>") == "&lt;a href=&quot;x&quot;&gt;&amp;&lt;/a&gt;");
}

}  // namespace
}  // namespace servokit
