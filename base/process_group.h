#pragma once
// The processes that run a computation together: this one alone, or the ranks of an MPI job
// (studies/distributed_sweep.h). Part of the public API (servokit/servokit.h includes it and
// hands it out as it is), so it sits in the lowest layer with the errors.

namespace servokit {

struct ProcessGroup {
  int rank = 0;           // this process, in [0, size)
  int size = 1;           // all processes of the job
  int ranks_on_node = 1;  // processes of the job on this machine (sharing its cores)
  bool IsRoot() const { return rank == 0; }
};

}  // namespace servokit
