#include "reports/document.h"

#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>

#include "base/errors.h"
#include "files/output_file.h"
#include "reports/escaping.h"

namespace servokit {
namespace {

// Inline Markdown as HTML: `code` spans become <code>; outside them a backslash before ASCII
// punctuation stands for that character (CommonMark's escapes, as MarkdownText writes them);
// everything else is escaped.
std::string InlineHtml(const std::string& text) {
  std::string html;
  bool in_code = false;
  std::string span;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (!in_code && c == '\\' && i + 1 < text.size() &&
        std::ispunct(static_cast<unsigned char>(text[i + 1]))) {
      span += text[++i];
    } else if (c == '`') {
      html += in_code ? "<code>" + HtmlText(span) + "</code>" : HtmlText(span);
      span.clear();
      in_code = !in_code;
    } else {
      span += c;
    }
  }
  html += HtmlText(span);
  return html;
}

// Inline Markdown as plain text, for an HTML title or attribute: the escapes resolved, the code
// spans' backticks dropped.
std::string InlineText(const std::string& text) {
  std::string plain;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\\' && i + 1 < text.size() &&
        std::ispunct(static_cast<unsigned char>(text[i + 1]))) {
      plain += text[++i];
    } else if (text[i] != '`') {
      plain += text[i];
    }
  }
  return plain;
}

std::string EscapeTableCell(const std::string& text) {
  std::string escaped;
  for (const char c : text) escaped += c == '|' ? std::string("\\|") : std::string(1, c);
  return escaped;
}

// RFC 4648 base64, for data: URIs.
std::string Base64(const std::string& bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string encoded;
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned value = unsigned(static_cast<unsigned char>(bytes[i])) << 16 |
                           unsigned(static_cast<unsigned char>(bytes[i + 1])) << 8 |
                           unsigned(static_cast<unsigned char>(bytes[i + 2]));
    for (const int shift : {18, 12, 6, 0}) encoded += kAlphabet[(value >> shift) & 63];
  }
  if (i < bytes.size()) {
    unsigned value = unsigned(static_cast<unsigned char>(bytes[i])) << 16;
    if (i + 1 < bytes.size()) value |= unsigned(static_cast<unsigned char>(bytes[i + 1])) << 8;
    encoded += kAlphabet[(value >> 18) & 63];
    encoded += kAlphabet[(value >> 12) & 63];
    encoded += i + 1 < bytes.size() ? kAlphabet[(value >> 6) & 63] : '=';
    encoded += '=';
  }
  return encoded;
}

std::string ReadBytes(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw Error("cannot read " + path + " (a figure of the report)");
  std::ostringstream bytes;
  bytes << file.rdbuf();
  return bytes.str();
}

struct MarkdownRenderer {
  std::ostringstream& out;
  void operator()(const Heading& heading) const {
    out << std::string(std::size_t(heading.level), '#') << " " << heading.text << "\n\n";
  }
  void operator()(const Paragraph& paragraph) const { out << paragraph.text << "\n\n"; }
  void operator()(const Table& table) const {
    out << "|";
    for (const auto& cell : table.header) out << " " << EscapeTableCell(cell) << " |";
    out << "\n|";
    for (std::size_t i = 0; i < table.header.size(); ++i) out << " --- |";
    out << "\n";
    for (const auto& row : table.rows) {
      out << "|";
      for (const auto& cell : row) out << " " << EscapeTableCell(cell) << " |";
      out << "\n";
    }
    out << "\n";
  }
  void operator()(const Figure& figure) const {
    out << "![" << figure.caption << "](" << figure.png << ")\n\n*" << figure.caption << "* ([SVG]("
        << figure.svg << "))\n\n";
  }
  void operator()(const CodeBlock& code) const { out << "```\n" << code.text << "\n```\n\n"; }
};

struct HtmlRenderer {
  std::ostringstream& out;
  const std::string& directory;
  void operator()(const Heading& heading) const {
    out << "<h" << heading.level << ">" << InlineHtml(heading.text) << "</h" << heading.level
        << ">\n";
  }
  void operator()(const Paragraph& paragraph) const {
    out << "<p>" << InlineHtml(paragraph.text) << "</p>\n";
  }
  void operator()(const Table& table) const {
    out << "<table>\n<tr>";
    for (const auto& cell : table.header) out << "<th>" << InlineHtml(cell) << "</th>";
    out << "</tr>\n";
    for (const auto& row : table.rows) {
      out << "<tr>";
      for (const auto& cell : row) out << "<td>" << InlineHtml(cell) << "</td>";
      out << "</tr>\n";
    }
    out << "</table>\n";
  }
  void operator()(const Figure& figure) const {
    out << "<figure><img src=\"data:image/svg+xml;base64,"
        << Base64(ReadBytes(directory + "/" + figure.svg)) << "\" alt=\""
        << HtmlText(InlineText(figure.caption)) << "\"><figcaption>" << InlineHtml(figure.caption)
        << " (files beside this page: ";
    std::string links;
    const std::size_t dot = figure.png.rfind('.');
    const std::string pdf = dot == std::string::npos ? "" : figure.png.substr(0, dot) + ".pdf";
    const bool has_pdf = !pdf.empty() && std::filesystem::exists(directory + "/" + pdf);
    for (const std::string* file : {&pdf, &figure.png, &figure.svg}) {
      if (file->empty() || (file == &pdf && !has_pdf)) continue;
      links += (links.empty() ? "" : ", ") + std::string("<a href=\"") + HtmlText(*file) + "\">" +
               HtmlText(*file) + "</a>";
    }
    out << links << ")</figcaption></figure>\n";
  }
  void operator()(const CodeBlock& code) const {
    out << "<pre>" << HtmlText(code.text) << "</pre>\n";
  }
};

}  // namespace

std::string RenderMarkdown(const Document& document) {
  std::ostringstream out;
  out << "# " << document.title << "\n\n";
  for (const Block& block : document.blocks) std::visit(MarkdownRenderer{out}, block);
  return out.str();
}

std::string RenderHtml(const Document& document, const std::string& directory) {
  std::ostringstream out;
  out << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>"
      << HtmlText(InlineText(document.title)) << "</title>\n<style>\n"
      << "body { font-family: sans-serif; max-width: 60em; margin: 2em auto; line-height: 1.4; }\n"
      << "table { border-collapse: collapse; margin: 1em 0; }\n"
      << "th, td { border: 1px solid #999; padding: 0.25em 0.6em; text-align: left; }\n"
      << "figure img { max-width: 100%; }\n"
      << "code, pre { background: #f4f4f4; }\n</style>\n</head>\n<body>\n<h1>"
      << InlineHtml(document.title) << "</h1>\n";
  for (const Block& block : document.blocks) std::visit(HtmlRenderer{out, directory}, block);
  out << "</body>\n</html>\n";
  return out.str();
}

void WriteDocument(const std::filesystem::path& directory, const Document& document) {
  for (const auto& [name, text] :
       {std::pair{"report.md", RenderMarkdown(document)},
        std::pair{"report.html", RenderHtml(document, directory.string())}}) {
    OutputFile file((directory / name).string());
    file.Write(text);
    file.Commit();
  }
}

Figure FigureOf(const std::string& name, const std::string& caption) {
  return {name + ".png", name + ".svg", caption};
}

}  // namespace servokit
