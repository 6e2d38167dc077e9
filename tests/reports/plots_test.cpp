// Figures (reports/plots.h): the robust axis rule on data with an outlier against a hand
// computation, the palette column and colour bar, escaped names, merged and staggered marker
// labels, PDFs, and the self-contained HTML page (reports/document.h).
#include "reports/plots.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include "reports/document.h"
#include "tests/test_files.h"

namespace servokit {
namespace {

using testing::ReadFile;

TEST_CASE("RobustLimits clips an outlier by the quantile rule", "[reports]") {
  // 0, 1, ..., 9 and 1000 (11 values): q10 = v[1] = 1 and q90 = v[9] = 9 (positions 1 and 9 of
  // 0..10), width 8; limits [max(0, 1 - 8), min(1000, 9 + 8)] = [0, 17]; padded by 5 % of 17 =
  // 0.85 on each side: [-0.85, 17.85]; 1000 is outside.
  std::vector<double> values = {1000};
  for (int i = 9; i >= 0; --i) values.push_back(double(i));
  const RobustRange range = RobustLimits(values);
  CHECK(range.low == 0.0);
  CHECK(range.high == 17.0);
  CHECK(range.outside == 1);
  CHECK(range.min == 0.0);
  CHECK(range.max == 1000.0);
  double low = 0.0, high = 0.0;
  REQUIRE(std::sscanf(range.range.c_str(), "[%lf:%lf]", &low, &high) == 2);
  CHECK(low == Approx(-0.85).epsilon(1e-14));
  CHECK(high == Approx(17.85).epsilon(1e-14));
}

TEST_CASE("RobustLimits keeps every value of data without outliers", "[reports]") {
  // 0..10: q10 = 1, q90 = 9, width 8: [max(0, -7), min(10, 17)] = [0, 10], nothing outside.
  std::vector<double> values;
  for (int i = 0; i <= 10; ++i) values.push_back(double(i));
  const RobustRange range = RobustLimits(values);
  CHECK(range.low == 0.0);
  CHECK(range.high == 10.0);
  CHECK(range.outside == 0);
  CHECK(RobustLimits({2.0, 2.0, 2.0}).range.empty());  // no width: gnuplot autoscales
}

TEST_CASE("PlotSymbol writes Greek letters and dots", "[reports]") {
  CHECK(PlotSymbol("alpha") == "α");
  CHECK(PlotSymbol("theta_1") == "θ_1");
  CHECK(PlotSymbol("x_dot") == "x\u0307");  // x and a combining dot above: ẋ
  CHECK(PlotSymbol("beta_ddot") == "β\u0308");
  CHECK(PlotSymbol("u_d") == "u_d");
  CHECK(PlotSymbol("alphabet") == "alphabet");
}

TEST_CASE("DrawPlot writes a palette column, a PDF and names as written", "[reports]") {
  const testing::TemporaryDirectory scratch;
  const std::string directory = scratch.path().string();
  PlotSpec spec{
      "locus",
      "x_dot over alpha",
      "Re λ [1/s]",
      "Im λ [1/s]",
      "[-2:2]",
      "",
      {{"x_dot", {{-1.0, 0.5}, {-0.5, 1.0}}}},
      {{0.5, "stability"}, {0.5, "oscillation"}, {0.5000001, "structure"}, {-1.5, "realization"}}};
  DrawPlot(directory, spec, PlotColouring{{{10.0, 20.0}}, "α [deg]"});
  const std::string data = ReadFile(scratch / "locus.dat");
  CHECK_THAT(data, Catch::Contains("-1 0.5 10\n") && Catch::Contains("-0.5 1 20\n"));
  const std::string script = ReadFile(scratch / "locus.gp");
  CHECK_THAT(script, Catch::Contains("using 1:2:3 with points pointtype 7 pointsize 0.5 "
                                     "linecolor palette title 'x_dot'") &&
                         Catch::Contains("set cblabel 'α [deg]'") &&
                         Catch::Contains("set palette"));
  // Enhanced text is off in every terminal, so 'x_dot' is drawn as written.
  CHECK(std::regex_search(script, std::regex("pngcairo noenhanced")));
  CHECK(std::regex_search(script, std::regex("svg noenhanced")));
  CHECK(std::regex_search(script, std::regex("pdfcairo noenhanced size 5in,3.5in font ',12'")));
  // The three events at 0.5 (within 1e-6 of the span) share one label. "realization" at -1.5
  // is more than 15 % of the span away, but the shared label (34 characters, right-aligned at
  // 0.5: 34 x 0.024 x 4 = 3.3 wide, from -2.8) would run into it: one line lower.
  // Labels stand above the graph (line 1 at 0.6 character heights, each further line one
  // higher), never over a curve, in a top margin of the title's 3 lines and one per line.
  CHECK_THAT(script, Catch::Contains("set label 'realization' at first -1.5, graph 1 left offset "
                                     "0.5,0.6\n"));
  CHECK_THAT(script, Catch::Contains("set label 'stability, oscillation, structure' at first 0.5, "
                                     "graph 1 right offset -0.5,1.6\n"));
  CHECK_THAT(script, Catch::Contains("set tmargin 5\n"));
  CHECK_THAT(script, !Catch::Contains("opaque"));
  const std::string pdf = ReadFile(scratch / "locus.pdf");
  CHECK(pdf.rfind("%PDF", 0) == 0);
  CHECK_THAT(pdf, Catch::Contains("/CreationDate (D:20000101000000"));
}

TEST_CASE("DrawPlot puts close marker labels on different lines", "[reports]") {
  const testing::TemporaryDirectory scratch;
  PlotSpec spec{"close",
                "t",
                "x",
                "y",
                "[0:1]",
                "",
                {{"y", {{0.0, 0.0}, {1.0, 1.0}}}},
                {{0.30, "a"}, {0.35, "b"}, {0.40, "c"}, {0.9, "d"}}};
  DrawPlot(scratch.path().string(), spec);
  const std::string script = ReadFile(scratch / "close.gp");
  // Spacing 0.15 of the span 1: b is 0.05 from a (line 2), c 0.1 from a and 0.05 from b (line
  // 3); d is far from all (line 1). Lines step up by one character height above the graph.
  CHECK_THAT(script, Catch::Contains("'a' at first 0.3, graph 1 left offset 0.5,0.6\n"));
  CHECK_THAT(script, Catch::Contains("'b' at first 0.35, graph 1 left offset 0.5,1.6\n"));
  CHECK_THAT(script, Catch::Contains("'c' at first 0.4, graph 1 left offset 0.5,2.6\n"));
  CHECK_THAT(script, Catch::Contains("'d' at first 0.9, graph 1 right offset -0.5,0.6\n"));
}

TEST_CASE("DrawPlot puts labels whose texts would meet on different lines", "[reports]") {
  // A stable inversion's markers on t in [-2.5, 2] (span 4.5): 'pre-actuation start' at -1.24
  // runs right to -1.24 + 20 x 0.024 x 4.5 = 0.92; 'motion start', right-aligned at 0 (right of
  // the middle, -0.25), starts at 0 - 13 x 0.024 x 4.5 = -1.40: they meet although 1.24 apart
  // (more than 15 % of the span). 'motion end', right-aligned at 1, starts at
  // 1 - 11 x 0.024 x 4.5 = -0.19: it meets the first, and 'motion start' (which ends at 0) on
  // the second line, so it takes the third.
  const testing::TemporaryDirectory scratch;
  PlotSpec spec{"window",
                "t",
                "t [s]",
                "u",
                "[-2.5:2]",
                "",
                {{"u", {{-2.5, 0.0}, {2.0, 0.0}}}},
                {{-1.24, "pre-actuation start"}, {0.0, "motion start"}, {1.0, "motion end"}}};
  DrawPlot(scratch.path().string(), spec);
  const std::string script = ReadFile(scratch / "window.gp");
  CHECK_THAT(script, Catch::Contains("'pre-actuation start' at first -1.24, graph 1 left offset "
                                     "0.5,0.6"));
  CHECK_THAT(script, Catch::Contains("'motion start' at first 0, graph 1 right offset -0.5,1.6"));
  CHECK_THAT(script, Catch::Contains("'motion end' at first 1, graph 1 right offset -0.5,2.6"));
}

// The values of every `attribute="..."` in `html`, in order.
std::vector<std::string> AttributeValues(const std::string& html, const std::string& attribute) {
  std::vector<std::string> values;
  const std::string opening = attribute + "=\"";
  for (std::size_t at = html.find(opening); at != std::string::npos;
       at = html.find(opening, at + 1)) {
    const std::size_t begin = at + opening.size();
    values.push_back(html.substr(begin, html.find('"', begin) - begin));
  }
  return values;
}

TEST_CASE("the HTML report embeds its figures and links nothing outside", "[reports]") {
  const testing::TemporaryDirectory scratch;
  PlotSpec spec{"line", "t", "x", "y", "", "", {{"y", {{0.0, 0.0}, {1.0, 1.0}}}}, {}};
  DrawPlot(scratch.path().string(), spec);
  Document document;
  document.title = "t";
  document.Add(FigureOf("line", "a line"));
  WriteDocument(scratch.path(), document);
  const std::string html = ReadFile(scratch / "report.html");
  CHECK_THAT(html, Catch::Contains("<img src=\"data:image/svg+xml;base64,"));
  CHECK_THAT(html, !Catch::Contains("DESIGN.md"));
  // Every image is a data: URI; links point only at the files beside the page. (Found by
  // search, not std::regex, whose recursive matcher overflows the stack on a page of inline
  // images under the sanitizers.)
  for (const std::string& source : AttributeValues(html, "src")) {
    CHECK(source.rfind("data:", 0) == 0);
  }
  for (const std::string& link : AttributeValues(html, "href")) {
    CHECK(std::filesystem::exists(scratch / link));
  }
  CHECK_THAT(html, Catch::Contains("href=\"line.pdf\""));
}

}  // namespace
}  // namespace servokit
