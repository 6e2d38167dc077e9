#pragma once
// The data-files plugin (reports/plugins.h), libservokit_data_files.so: the code that calls HDF5
// (sweep_hdf5_writer.cpp) and matio (mat_file_matio.cpp). The rest of servokit reaches it only
// through DataFilesPlugin, so that only the commands that write such files load those libraries.
#include <filesystem>
#include <memory>
#include <string>

#include "reports/mat_file.h"
#include "reports/sweep_hdf5.h"

namespace servokit {

// Defined in the plugin only (its code uses nothing of servokit but these headers' types).
std::unique_ptr<SweepHdf5Writer> CreateSweepHdf5File(const std::filesystem::path& path,
                                                     const SweepFileMetadata& metadata,
                                                     const SweepHdf5Layout& layout);
std::unique_ptr<MatFileWriter> CreateMatioFile(const std::string& path);

/// What the plugin offers: CreateSweepHdf5File (CreateSweepHdf5 once the layout is known) and
/// CreateMatFile.
struct DataFilesPlugin {
  decltype(&CreateSweepHdf5File) create_sweep_hdf5;
  decltype(&CreateMatFile) create_mat_file;
};

/// The plugin's entry point: an extern "C" function returning its DataFilesPlugin.
inline constexpr const char* kDataFilesPluginEntry = "servokit_data_files_plugin";

/// The plugin, loaded on the first call. Throws Error when it cannot be loaded.
const DataFilesPlugin& DataFiles();

}  // namespace servokit
