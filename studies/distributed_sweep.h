#pragma once
// Distributed sweeps (issue #6): `mpirun -np K servokit sweep ...` splits the grid over the K
// MPI ranks and writes the same files as one process, byte for byte.
//
// The grid is cut into the blocks of one process (SweepOptions::block_size, counted from the
// first point still to compute); block b is computed by rank b mod K, with its own OpenMP
// threads, and formatted there (FormatBlock, the one formatting path). Rank 0 owns the output
// directory: it receives every block in index order and appends it as a single process would
// (SweepOutput), so checkpoints and resume work unchanged, with or without MPI. Every other rank
// writes nothing, prints nothing (main() gives it null streams) and ends with rank 0's verdict:
//
//   - an error on any rank (before or during the sweep) reaches rank 0, which prints it as the
//     one `servokit: error:` line; every rank exits with its status;
//   - a stop request (SIGINT, SIGTERM) on any rank stops all of them at a block boundary, with
//     the checkpoint written by rank 0; every rank exits with status 130.
//
// The MPI code lives in mpi_plugin.cpp, built as the MPI plugin (studies/mpi_plugin.h) when
// CMake finds MPI (SERVOKIT_HAVE_MPI); mpi_processes.cpp loads it only under an MPI launcher and
// otherwise gives the same functions for one process.
#include <cstddef>
#include <exception>
#include <functional>
#include <string>

#include "analysis/parameter_grid.h"
#include "analysis/sweep.h"
#include "base/process_group.h"
#include "modeling/model.h"
#include "studies/sweep_store.h"

namespace servokit {

/// Whether this servokit can run distributed sweeps: built with MPI, and (started by a launcher)
/// its MPI plugin loaded.
bool BuiltWithMpi();
/// Why it cannot (BuiltWithMpi() false): one line for an error message.
std::string MpiUnavailableReason();

/// While alive, this process is one rank of an MPI job: constructed at the top of main(), it
/// loads the MPI plugin and initialises MPI (MPI_Init_thread, funneled: only the main thread
/// calls MPI) when servokit was built with MPI and started by an MPI launcher (mpirun sets
/// OMPI_COMM_WORLD_SIZE or PMIX_RANK), and finalises it on destruction. Started any other way it
/// does nothing, so a plain `servokit analyze` neither loads MPI nor prints anything of MPI's.
/// A plugin that cannot be loaded is not an error here: `servokit sweep` says so
/// (MpiUnavailableReason).
class MpiSession {
 public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

/// This process's group: MPI_COMM_WORLD inside an MpiSession, else this process alone. In a
/// build without MPI started by mpirun, rank and size come from the launcher's environment
/// (so that only rank 0 prints), and `servokit sweep` refuses to run.
ProcessGroup Processes();

/// Collective (every process calls it): returns when no process failed (`failure` is null
/// everywhere); otherwise throws on every process an error of the lowest failing rank's exit
/// status (ExitCodeFor), with its message on rank 0 (the one that prints it).
void AgreeOnSuccess(std::exception_ptr failure);

/// Collective: runs `step` on every process; a failure on any ends all of them (AgreeOnSuccess).
template <typename Step>
void OnEveryProcess(Step step) {
  std::exception_ptr failure;
  try {
    step();
  } catch (...) {
    failure = std::current_exception();
  }
  AgreeOnSuccess(failure);
}

/// Collective: rank 0's `value`, on every process.
std::size_t BroadcastFromRoot(std::size_t value);
/// Collective: rank 0's `text`, on every process.
std::string BroadcastFromRoot(const std::string& text);

/// How a distributed sweep ended, on every process.
struct DistributedSweepEnd {
  std::size_t done = 0;  // points written: the grid's size, or less when stopped on request
  bool stopped = false;  // a process asked to stop (interrupt); done is then a block boundary
};

/// Collective: computes grid points first_point .. grid.num_points() - 1 over all processes
/// (the blocks of RunSweep, block b on rank b mod size) and calls `write` on rank 0 for every
/// block, in index order (it is never called elsewhere). `stop_requested` is asked on every
/// process after each block it computes or writes; true on any process stops all of them at the
/// next block boundary. An exception on any process (from an evaluation, `write` or MPI) ends
/// all of them and is rethrown on every process as AgreeOnSuccess does. Needs size > 1 and MPI.
/// Computes the points of one sweep from `first_point` on, block by block, and hands each block
/// to the consumer (RunSweep bound to a model, its grid, options and workspaces); returns
/// the index after the last point consumed. The distributed sweep calls it once per block it
/// computes, with a consumer that stops after that block.
using SweepRunner =
    std::function<std::size_t(std::size_t first_point, const SweepConsumer& consume)>;

/// RunDistributedSweep for any kind of model: blocks are computed by `run` (SweepRunner), whose
/// blocks must be options.block_size points, and formatted with `encoding` (CSV text, or the
/// binary records of the HDF5 and MAT formats) by the rank that computes them.
DistributedSweepEnd RunDistributedSweep(const SweepRunner& run,
                                        const ParameterGrid& grid,
                                        const SweepOptions& options,
                                        std::size_t first_point,
                                        TableEncoding encoding,
                                        const std::function<void(const FormattedBlock&)>& write,
                                        const std::function<bool()>& stop_requested);

}  // namespace servokit
