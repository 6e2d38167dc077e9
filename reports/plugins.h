#pragma once
// Plugins: parts of servokit built as shared libraries and loaded on first use, because the
// libraries they need are large and few commands need them. Linked into the executable, HDF5 and
// matio (data files) and MPI (distributed sweeps) would bring about 40 shared libraries that
// every command loads and relocates before main(): `servokit analyze` would spend 15 ms of CPU
// on start-up instead of 4.
//
// A plugin named P is the file libP.so. It is looked for, in order, in the directory named by
// the environment variable SERVOKIT_PLUGIN_DIR (for programs of other projects linked with the
// installed libraries), in the directory of the object that holds this code (the executable,
// or the Python module), in that directory's ../<libdir>/servokit (the installed layout:
// bin/servokit, lib/servokit/libP.so; SERVOKIT_PLUGIN_INSTALL_DIR), in the install prefix
// chosen at configuration (SERVOKIT_PLUGIN_PREFIX_DIR), and in the build tree's plugin
// directory (SERVOKIT_PLUGIN_BUILD_DIR).
#include <string>

namespace servokit {

/// The address of `symbol` in plugin `plugin` (e.g. "servokit_data_files"), loading the plugin
/// on the first call (thread safe; it stays loaded). Throws Error naming the plugin, the places
/// looked in and the loader's message when it cannot be loaded or lacks the symbol.
void* PluginSymbol(const std::string& plugin, const char* symbol);

}  // namespace servokit
