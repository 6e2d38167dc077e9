#pragma once
// The data-files plugin (reports/plugins.h), libservokit_data_files.so: the code that calls HDF5
// (sweep_hdf5_writer.cpp) and matio (mat_file_matio.cpp). The rest of servokit reaches it only
// through DataFilesPlugin, so that only the commands that write such files load those libraries.
#include <filesystem>
#include <memory>
#include <string>

#include "reports/mat_file.h"
#include "reports/sweep_hdf5.h"
#include "reports/sweep_records.h"

namespace servokit {

/// What the plugin offers: WriteSweepHdf5 and CreateMatFile (the same signatures).
struct DataFilesPlugin {
  decltype(&WriteSweepHdf5) write_sweep_hdf5;
  decltype(&CreateMatFile) create_mat_file;
};

/// The plugin's entry point: an extern "C" function returning its DataFilesPlugin.
inline constexpr const char* kDataFilesPluginEntry = "servokit_data_files_plugin";

/// The plugin, loaded on the first call. Throws Error when it cannot be loaded.
const DataFilesPlugin& DataFiles();

// Defined in the plugin only.
void WriteSweepHdf5File(const std::filesystem::path& path,
                        const SweepFileMetadata& metadata,
                        TableRecordReader& points,
                        TableRecordReader& eigenvalues);
std::unique_ptr<MatFileWriter> CreateMatioFile(const std::string& path);

}  // namespace servokit
