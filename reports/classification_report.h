#pragma once
// `servokit analyze` output: the JSON object of docs/analyze.md, and text and Markdown for people.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analysis/classification.h"
#include "analysis/linear_analysis.h"
#include "base/vocabulary.h"
#include "modeling/linear_model.h"
#include "modeling/model.h"

namespace servokit {

/// The analyze object (docs/analyze.md, "Synopsis and options": `--format json`), plus explanatory
/// extras: coordinates, infinite_zero_orders, decoupling_matrix_regular, P_rank_threshold,
/// zero_dynamics.cross_check and the tolerances used.
nlohmann::ordered_json ClassificationToJson(const Model& model,
                                            const Classification& classification,
                                            const ClassificationOptions& options);

/// (label, value) rows of a classification, shared by the text, Markdown and report forms.
std::vector<std::pair<std::string, std::string>> ClassificationSummary(
    const Model& model, const Classification& classification);

/// The same content for a terminal.
std::string ClassificationToText(const Model& model, const Classification& classification);

/// The same content as a Markdown section.
std::string ClassificationToMarkdown(const Model& model, const Classification& classification);

/// One of the three, by format.
std::string FormatClassification(const Model& model,
                                 const Classification& classification,
                                 const ClassificationOptions& options,
                                 ReportFormat format);

/// The analyze object of a large linear model (modeling/linear_model.h): the keys of
/// ClassificationToJson where they apply, at the operating point q = 0, u = 0, y = 0
/// (operating_point.q is left empty, with a note, since it has dof entries, all zero); inputs
/// and outputs are named u1.., y1..; zero_dynamics adds complete, zero_count, scope, solver,
/// target, shift and the ARPACK counters.
nlohmann::ordered_json LinearAnalysisToJson(const LinearModel& model,
                                            const LinearAnalysis& analysis,
                                            const LinearAnalysisOptions& options);

/// (label, value) rows of a linear model's analysis, as ClassificationSummary.
std::vector<std::pair<std::string, std::string>> LinearAnalysisSummary(
    const LinearModel& model, const LinearAnalysis& analysis);

/// Text, JSON or Markdown, as FormatClassification.
std::string FormatLinearAnalysis(const LinearModel& model,
                                 const LinearAnalysis& analysis,
                                 const LinearAnalysisOptions& options,
                                 ReportFormat format);

}  // namespace servokit
