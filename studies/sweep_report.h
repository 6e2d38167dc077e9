#pragma once
// A finished sweep read back for its report (`servokit report --from DIR`): its record
// (sweep.json, studies/sweep_store.h), the model it names, unchanged since, and its CSV tables,
// each point's class as the map names it.
#include <filesystem>
#include <string>
#include <vector>

#include "analysis/options.h"
#include "analysis/parameter_grid.h"
#include "modeling/model.h"
#include "studies/model_report.h"

namespace servokit {

struct FinishedSweepReport {
  Model model;
  std::vector<GridAxis> axes;
  ClassificationOptions options;
  StoredSweep stored;
};

/// Reads the finished CSV sweep in `directory`. Throws UsageError naming the file and the
/// problem: no sweep.json ("<label> DIR: no sweep.json there", `label` the caller's name for
/// DIR), not a sweep's record, a sweep not completed, of a linear model or in HDF5/MAT, its
/// model missing or changed (content hash), its tables not those of its grid.
FinishedSweepReport ReadFinishedSweep(const std::filesystem::path& directory,
                                      const std::string& label);

}  // namespace servokit
