// api::WritePaperReport, WriteModelReport and the report of a finished sweep: the API's face of
// studies/paper_report.h, model_report.h and sweep_report.h.
#include <utility>

#include "servokit/toolkit_bridge.h"
#include "studies/model_report.h"
#include "studies/paper_report.h"
#include "studies/sweep_report.h"

namespace servokit::api {

struct FinishedSweep::Data {
  FinishedSweepReport report;
};

const FinishedSweep::Data& Unwrap(const FinishedSweep& sweep) { return *sweep.data_; }

void WritePaperReport(const std::string& directory, const std::string& models_directory) {
  servokit::WritePaperReport(directory, models_directory);
}

void WriteModelReport(const std::string& directory,
                      const Model& model,
                      const std::vector<SweepAxis>& axes,
                      const AnalyzeOptions& options) {
  const servokit::Model& multibody = MultibodyModel(model, "WriteModelReport");
  std::vector<GridAxis> grid_axes;
  for (const SweepAxis& axis : axes) grid_axes.push_back(ToGridAxis(model, axis));
  servokit::WriteModelReport(directory, multibody, grid_axes, ToClassificationOptions(options));
}

FinishedSweep FinishedSweep::Read(const std::string& directory, const std::string& label) {
  return FinishedSweep(std::make_shared<const Data>(Data{ReadFinishedSweep(directory, label)}));
}

void WriteSweepReport(const std::string& directory, const FinishedSweep& sweep) {
  const FinishedSweepReport& report = Unwrap(sweep).report;
  servokit::WriteModelReport(directory, report.model, report.axes, report.options, &report.stored);
}

}  // namespace servokit::api
