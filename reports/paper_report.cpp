#include "reports/paper_report.h"

#include <cmath>
#include <filesystem>
#include <numbers>

#include "analysis/classification.h"
#include "models/errors.h"
#include "models/units.h"
#include "reports/classification_report.h"
#include "reports/number_format.h"
#include "reports/report_support.h"

namespace servokit {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

double ToDegrees(double radians) { return RadiansToDegrees(radians); }

std::string Eigenvalues(const std::vector<std::complex<double>>& eigenvalues) {
  if (eigenvalues.empty()) return "none";
  std::string text;
  for (const auto& eigenvalue : eigenvalues) {
    text += (text.empty() ? "" : ", ") + FormatComplex(eigenvalue);
  }
  return text;
}

std::string Join(const std::vector<int>& values) {
  std::string text;
  for (const int value : values) text += (text.empty() ? "" : ", ") + std::to_string(value);
  return text;
}

// The paper's four cases of Sect. 3 and what the paper says of each.
struct PaperCase {
  const char* name;
  const char* alpha;
  const char* damping;
  const char* paper;
};
constexpr PaperCase kMassOnCarCases[] = {
    {"1", "90 deg", "1", "ideal orthogonal, index 3, internal dynamics Eq. (34), order 2"},
    {"2", "5 deg", "1", "non-ideal orthogonal, index 3, Eq. (36), order 2"},
    {"3", "0", "1", "tangential, index 4, Eq. (40), order 1"},
    {"4", "0", "0", "tangential, index 5, flat (Eq. 47)"},
};

void AddMassOnCarTable(Document& document, const std::string& path) {
  document.Add(Heading{2, "Mass on car: the four cases (Sect. 3)"});
  document.Add(Paragraph{"`models/" + std::filesystem::path(path).filename().string() +
                         "` with m1 = 1 kg, m2 = 2 kg, k = 5 N/m (DESIGN.md: the "
                         "paper's Table 1 is missing from its text; these values reproduce its "
                         "0.25 Hz, 2.88 Hz and 9.1 deg)."});
  Table table;
  table.header = {"case",
                  "alpha",
                  "d",
                  "realization",
                  "P",
                  "relative degree",
                  "index (projected)",
                  "internal order",
                  "flat",
                  "zero-dynamics eigenvalues",
                  "stability",
                  "paper"};
  for (const PaperCase& paper_case : kMassOnCarCases) {
    const Model model = LoadModel(path, {{"alpha", paper_case.alpha}, {"d", paper_case.damping}});
    Workspace workspace(model);
    const Classification c = Classify(model, workspace);
    table.rows.push_back({paper_case.name, paper_case.alpha, paper_case.damping,
                          std::string(ToString(c.decoupling.realization)),
                          FormatShort(c.decoupling.decoupling_matrix(0, 0)),
                          Join(c.structure.relative_degree),
                          std::to_string(c.structure.differentiation_index) + " (" +
                              std::to_string(c.structure.projected_index) + ")",
                          std::to_string(c.structure.internal_dynamics_order),
                          c.flat ? "yes" : "no", Eigenvalues(c.zero_dynamics.eigenvalues),
                          std::string(ToString(c.zero_dynamics.stability)), paper_case.paper});
  }
  document.Add(table);
}

double UndampedFrequency(const std::string& path, const char* alpha) {
  const Model model = LoadModel(path, {{"alpha", alpha}, {"d", "0"}});
  Workspace workspace(model);
  const Classification c = Classify(model, workspace);
  if (c.zero_dynamics.modes.empty()) throw NoSolution(std::string("no mode at alpha = ") + alpha);
  return c.zero_dynamics.modes.front().frequency_hz;
}

void AddFigure6(Document& document,
                const std::filesystem::path& directory,
                const std::string& path) {
  document.Add(Heading{2, "Fig. 6: zero dynamics of the mass on car over alpha"});
  const std::vector<double> angles = Linspace(0.25 * kDegree, 90.0 * kDegree, 360);
  std::vector<double> angles_in_degrees;
  for (const double angle : angles) angles_in_degrees.push_back(ToDegrees(angle));
  PlotSpec locus{"fig6_root_locus",
                 "Zero-dynamics eigenvalues, alpha from 0.25 to 90 deg",
                 "Re(lambda) [1/s]",
                 "Im(lambda) [1/s]",
                 "[-12:1]",
                 "[-25:25]",
                 {},
                 {}};
  PlotSpec frequency{"fig6_frequency",
                     "Undamped zero dynamics (d = 0): frequency over alpha",
                     "alpha [deg]",
                     "frequency [Hz]",
                     "[0:90]",
                     "[0:6]",
                     {},
                     {}};
  for (const char* damping : {"0", "1"}) {
    const Model model = LoadModel(path, {{"d", damping}});
    const auto alpha = *model.FindParameter("alpha");
    const std::vector<SweepPoint> points = SweepParameter(model, alpha, angles);
    locus.series.push_back({std::string("d = ") + damping + " N s/m", RootLocus(points)});
    if (std::string(damping) == "0") {
      std::vector<std::pair<double, double>> curve;
      for (const auto& [angle, imaginary] : EigenvalueCurve(points, angles_in_degrees, true)) {
        if (imaginary > 0) curve.emplace_back(angle, imaginary / (2 * std::numbers::pi));
      }
      frequency.series.push_back({"d = 0", curve, "lines linewidth 2"});
    }
  }
  const Model damped = LoadModel(path, {{"d", "1"}});
  const ThresholdSearch overdamping =
      FindThresholds(damped, *damped.FindParameter("alpha"), 0.25 * kDegree, 90 * kDegree,
                     ThresholdEvent::kOscillation);
  frequency.markers.push_back({5.0, "5 deg"});
  DrawPlot(directory.string(), locus);
  DrawPlot(directory.string(), frequency);
  document.Add(FigureOf(locus.name,
                        "Fig. 6: zero-dynamics eigenvalues for alpha in (0, 90] deg, "
                        "d = 0 (on the imaginary axis) and d = 1"));
  document.Add(FigureOf(frequency.name, "Frequency of the undamped zero dynamics over alpha"));

  Table quoted;
  quoted.header = {"quantity", "paper", "servokit", "closed form"};
  const double m2 = 2.0, k = 5.0, d = 1.0;
  quoted.rows.push_back({"frequency at alpha = 90 deg, d = 0", "0.25 Hz",
                         FormatShort(UndampedFrequency(path, "90 deg")) + " Hz",
                         FormatShort(std::sqrt(k / m2) / (2 * std::numbers::pi)) + " Hz"});
  const double sine5 = std::sin(5 * kDegree);
  quoted.rows.push_back(
      {"frequency at alpha = 5 deg, d = 0", "2.88 Hz",
       FormatShort(UndampedFrequency(path, "5 deg")) + " Hz",
       FormatShort(std::sqrt(k / (m2 * sine5 * sine5)) / (2 * std::numbers::pi)) + " Hz"});
  quoted.rows.push_back({"over-damped below (d = 1)", "9.1 deg",
                         overdamping.events.empty()
                             ? "not found"
                             : FormatPrecise(ToDegrees(overdamping.events[0].value)) + " deg",
                         FormatPrecise(ToDegrees(std::asin(d / std::sqrt(4 * m2 * k)))) +
                             " deg = asin(d / sqrt(4 m2 k))"});
  document.Add(Heading{3, "The numbers the paper quotes"});
  document.Add(quoted);
  document.Add(Heading{3, "Located thresholds (d = 1)"});
  document.Add(ThresholdTable({overdamping}, "deg", ToDegrees));
  if (const auto closed_form = DeriveCharacteristicPolynomial(
          damped, *damped.FindParameter("alpha"), 0.25 * kDegree, 90 * kDegree)) {
    AddClosedForm(document, *closed_form, "alpha");
  }
}

void AddFigure8(Document& document,
                const std::filesystem::path& directory,
                const std::string& path) {
  document.Add(Heading{2, "Fig. 8: zero dynamics of the rotational arm over the output point s"});
  const Model model = LoadModel(path);
  const auto s = *model.FindParameter("s");
  const double length = model.parameters()(Eigen::Index(*model.FindParameter("l")));
  const std::vector<double> positions = Linspace(0.0, length, 201);
  const std::vector<SweepPoint> points = SweepParameter(model, s, positions);
  std::vector<ThresholdSearch> searches;
  for (const ThresholdEvent event :
       {ThresholdEvent::kStability, ThresholdEvent::kOscillation, ThresholdEvent::kRealization}) {
    searches.push_back(FindThresholds(model, s, 0.0, length, event));
  }
  PlotSpec locus{"fig8_root_locus",
                 "Zero-dynamics eigenvalues, s from 0 to l",
                 "Re(lambda) [1/s]",
                 "Im(lambda) [1/s]",
                 "[-60:60]",
                 "[-40:40]",
                 {{"zero dynamics", RootLocus(points)}},
                 {}};
  PlotSpec real_part{"fig8_real_part",
                     "Real parts of the zero-dynamics eigenvalues over s",
                     "s [m]",
                     "Re(lambda) [1/s]",
                     "[0:1]",
                     "[-60:60]",
                     {{"Re(lambda)", EigenvalueCurve(points, positions, false)}},
                     {}};
  for (const ThresholdSearch& search : searches) {
    for (const ThresholdCrossing& event : search.events) {
      if (event.value > 0.0) {
        real_part.markers.push_back({event.value, std::string(ToString(search.event))});
      }
    }
  }
  DrawPlot(directory.string(), locus);
  DrawPlot(directory.string(), real_part);
  document.Add(FigureOf(locus.name, "Fig. 8: zero-dynamics eigenvalues for s in [0, l]"));
  document.Add(FigureOf(real_part.name,
                        "Real parts over s: one eigenvalue leaves through infinity at s = 2l/3"));
  document.Add(Heading{3, "Located thresholds"});
  document.Add(ThresholdTable(searches, "m", AsIs));
  if (const auto closed_form = DeriveCharacteristicPolynomial(model, s, 0.0, length)) {
    AddClosedForm(document, *closed_form, "s");
  }
  document.Add(Heading{3, "A correction to Eq. (54)"});
  Workspace workspace(model);
  const Classification end_effector = Classify(model, workspace);
  const double mass = model.parameters()(Eigen::Index(*model.FindParameter("m")));
  const double s_value = model.parameters()(Eigen::Index(s));
  const double printed = 2 * length * (3 * s_value - 2 * length) /
                         (mass * length * length * (length + s_value) * (9.0 - 23.0));
  document.Add(Paragraph{
      "At beta = 0, s = l servokit finds P = H M^-1 B = " +
      FormatShort(end_effector.decoupling.decoupling_matrix(0, 0)) +
      "; the paper's printed Eq. (54) gives " + FormatShort(printed) +
      ", l/6 of it, and has the unit 1/(kg m) instead of 1/(kg m^2). Derived again from Eq. (49): "
      "`P = (2l - 3 s cos(beta)) / (6 m l^2 (s + l) (4/9 - cos(beta)^2/4))`; where P vanishes, "
      "s* = 2l/(3 cos(beta)), and Eq. (56) are as printed."});
}

}  // namespace

void WritePaperReport(const std::string& directory, const std::string& models_directory) {
  const std::filesystem::path out(directory);
  std::filesystem::create_directories(out);
  Document document;
  document.title = "servokit: the examples of Seifried & Blajer (2013)";
  document.Add(Paragraph{
      "Reproduction of the classification and parameter studies of R. Seifried and W. Blajer, "
      "\"Analysis of servo-constraint problems for underactuated multibody systems\", Mech. Sci. "
      "4, 113-129, 2013. Every number below is computed by servokit from the shipped models; "
      "the columns \"paper\" and \"closed form\" are the independent references."});
  AddMassOnCarTable(document, models_directory + "/mass_on_car.yaml");
  AddFigure6(document, out, models_directory + "/mass_on_car.yaml");
  AddFigure8(document, out, models_directory + "/rotational_arm.yaml");
  WriteDocument(out, document);
}

}  // namespace servokit
