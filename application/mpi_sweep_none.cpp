// application/mpi_sweep.h without MPI: one process. Started by mpirun all the same, a process still
// learns its rank from the launcher's environment, so that only rank 0 prints (and `servokit
// sweep` refuses to run K copies of one sweep).
#include <charconv>
#include <cstdlib>
#include <cstring>

#include "application/mpi_sweep.h"
#include "models/errors.h"

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

}  // namespace

bool BuiltWithMpi() { return false; }

MpiSession::MpiSession(int&, char**&) {}

MpiSession::~MpiSession() = default;

ProcessGroup Processes() {
  return {EnvironmentNumber("OMPI_COMM_WORLD_RANK", 0),
          EnvironmentNumber("OMPI_COMM_WORLD_SIZE", 1),
          EnvironmentNumber("OMPI_COMM_WORLD_LOCAL_SIZE", 1)};
}

void AgreeOnSuccess(std::exception_ptr failure) {
  if (failure) std::rethrow_exception(failure);
}

std::size_t BroadcastFromRoot(std::size_t value) { return value; }

std::string BroadcastFromRoot(const std::string& text) { return text; }

DistributedSweepEnd RunDistributedSweep(const SweepRunner&,
                                        const ParameterGrid&,
                                        const SweepOptions&,
                                        std::size_t,
                                        TableEncoding,
                                        const std::function<void(const FormattedBlock&)>&,
                                        const std::function<bool()>&) {
  throw Error("this servokit was built without MPI: it cannot run a distributed sweep");
}

}  // namespace servokit
