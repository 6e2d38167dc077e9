#pragma once
// `servokit report paper`: the paper's classification table, its parameter studies (Figs. 6
// and 8) with the located thresholds and closed forms, and the frequencies it quotes, all
// computed from the shipped models.
#include <string>

namespace servokit {

/// Writes DIR/report.md, DIR/report.html and the figures (PNG and SVG, with their gnuplot data
/// and scripts). `models_directory` holds mass_on_car.yaml and rotational_arm.yaml.
void WritePaperReport(const std::string& directory, const std::string& models_directory);

}  // namespace servokit
