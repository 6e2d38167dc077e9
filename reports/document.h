#pragma once
// A report as a list of blocks, rendered to Markdown and to HTML from the same content, so
// that report.md and report.html cannot say different things.
#include <filesystem>
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

/// A self-contained HTML page: each figure's SVG, read from `directory` (where the figures
/// were drawn), is embedded as a data: URI, so the page shows its figures on its own; the files
/// beside it (the PNG, the SVG and a PDF of the same name, when
/// there is one) are linked for download. Throws Error when an SVG cannot be read.
std::string RenderHtml(const Document& document, const std::string& directory);

/// Writes report.md and report.html into `directory`.
void WriteDocument(const std::filesystem::path& directory, const Document& document);

/// Figure block for a drawn plot named `name`.
Figure FigureOf(const std::string& name, const std::string& caption);

}  // namespace servokit
