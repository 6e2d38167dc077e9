#pragma once
// A report as a list of blocks, rendered to Markdown and to HTML from the same content, so
// that report.md and report.html cannot say different things.
#include <string>
#include <variant>
#include <vector>

namespace servokit {

struct Heading {
  int level = 2;  // 1 = title
  std::string text;
};
struct Paragraph {
  std::string text;  // plain text; `code` in backquotes is kept as code
};
struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};
struct Figure {
  std::string png;  // file names relative to the report
  std::string svg;
  std::string caption;
};
struct CodeBlock {
  std::string text;
};

using Block = std::variant<Heading, Paragraph, Table, Figure, CodeBlock>;

struct Document {
  std::string title;
  std::vector<Block> blocks;

  void Add(Block block) { blocks.push_back(std::move(block)); }
};

/// GitHub-flavoured Markdown; figures link the PNG.
std::string RenderMarkdown(const Document& document);

/// A self-contained HTML page; figures embed the SVG by reference.
std::string RenderHtml(const Document& document);

}  // namespace servokit
