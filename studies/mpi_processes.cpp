// studies/distributed_sweep.h for every build: a process started by an MPI launcher in a build with
// MPI loads the MPI plugin (studies/mpi_plugin.h) and runs as one rank of the job; any other
// process is alone and never loads MPI. Started by mpirun without the plugin (a build without
// MPI), a process still learns its rank from the launcher's environment, so that only rank 0
// prints (and `servokit sweep` refuses to run K copies of one sweep).
#include <charconv>
#include <cstdlib>
#include <cstring>

#include "base/errors.h"
#include "reports/plugins.h"
#include "studies/distributed_sweep.h"
#include "studies/mpi_plugin.h"

namespace servokit {
namespace {

// The launcher's variable `name` as a whole number, or `fallback`.
int EnvironmentNumber(const char* name, int fallback) {
  const char* text = std::getenv(name);
  if (text == nullptr) return fallback;
  int value = 0;
  const char* end = text + std::strlen(text);
  const auto [stop, error] = std::from_chars(text, end, value);
  return error == std::errc() && stop == end ? value : fallback;
}

// Open MPI's mpirun sets OMPI_COMM_WORLD_SIZE; PMIx launchers (Open MPI 5, Slurm's srun) set
// PMIX_RANK.
bool StartedByMpiLauncher() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr || std::getenv("PMIX_RANK") != nullptr;
}

// The MPI plugin while an MpiSession runs with it (main()'s thread only).
const MpiPlugin* mpi = nullptr;
ProcessGroup world;
// Why the plugin could not be loaded, when started by a launcher.
std::string plugin_problem;

const MpiPlugin& ActiveMpi() {
  if (mpi == nullptr) throw Error("MPI is not initialised in this process");
  return *mpi;
}

}  // namespace

bool BuiltWithMpi() {
#ifdef SERVOKIT_HAVE_MPI
  return plugin_problem.empty();
#else
  return false;
#endif
}

MpiSession::MpiSession(int& argc, char**& argv) {
#ifdef SERVOKIT_HAVE_MPI
  if (!StartedByMpiLauncher()) return;
  try {
    const auto entry =
        reinterpret_cast<const MpiPlugin* (*)()>(PluginSymbol("servokit_mpi", kMpiPluginEntry));
    const MpiPlugin* plugin = entry();
    world = plugin->initialize(argc, argv);
    mpi = plugin;
  } catch (const Error& failure) {
    // Said by `servokit sweep`, the one command that needs MPI; the others run as one process.
    plugin_problem = failure.what();
  }
#else
  (void)argc;
  (void)argv;
#endif
}

MpiSession::~MpiSession() {
  if (mpi != nullptr) mpi->finalize();
  mpi = nullptr;
  world = {};
}

ProcessGroup Processes() {
  if (mpi != nullptr) return world;
  return {EnvironmentNumber("OMPI_COMM_WORLD_RANK", 0),
          EnvironmentNumber("OMPI_COMM_WORLD_SIZE", 1),
          EnvironmentNumber("OMPI_COMM_WORLD_LOCAL_SIZE", 1)};
}

std::string MpiUnavailableReason() {
  if (!plugin_problem.empty()) return plugin_problem;
  return "this servokit was built without MPI; run it without mpirun, or rebuild it with MPI "
         "(libopenmpi-dev)";
}

void AgreeOnSuccess(std::exception_ptr failure) {
  if (mpi != nullptr) return mpi->agree_on_success(failure);
  if (failure) std::rethrow_exception(failure);
}

std::size_t BroadcastFromRoot(std::size_t value) {
  return mpi != nullptr ? mpi->broadcast_size(value) : value;
}

std::string BroadcastFromRoot(const std::string& text) {
  return mpi != nullptr ? mpi->broadcast_text(text) : text;
}

DistributedSweepEnd RunDistributedSweep(const SweepRunner& run,
                                        const ParameterGrid& grid,
                                        const SweepOptions& options,
                                        std::size_t first_point,
                                        TableEncoding encoding,
                                        const std::function<void(const FormattedBlock&)>& write,
                                        const std::function<bool()>& stop_requested) {
  return ActiveMpi().run_distributed_sweep(run, grid, options, first_point, encoding, write,
                                           stop_requested);
}

}  // namespace servokit
