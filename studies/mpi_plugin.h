#pragma once
// The MPI plugin (reports/plugins.h), libservokit_mpi.so: studies/mpi_plugin.cpp, the code
// that calls MPI. studies/distributed_sweep.cpp loads it only when servokit was started by an
// MPI launcher, so that no other run loads MPI's libraries (Open MPI brings a dozen, and hwloc
// probes the machine's topology when they load).
#include <cstddef>
#include <string>

#include "studies/distributed_sweep.h"

namespace servokit {

/// What the plugin offers; each function is the one of studies/distributed_sweep.h of that name
/// (the same signature, so that a change there shows here).
struct MpiPlugin {
  // MPI_Init_thread and this process's group in MPI_COMM_WORLD.
  ProcessGroup (*initialize)(int& argc, char**& argv);
  void (*finalize)();
  decltype(&AgreeOnSuccess) agree_on_success;
  std::size_t (*broadcast_size)(std::size_t value);        // BroadcastFromRoot, a number
  std::string (*broadcast_text)(const std::string& text);  // BroadcastFromRoot, a text
  decltype(&RunDistributedSweep) run_distributed_sweep;
};

/// The plugin's entry point: an extern "C" function returning its MpiPlugin.
inline constexpr const char* kMpiPluginEntry = "servokit_mpi_plugin";

}  // namespace servokit
