// studies/distributed_sweep.h with MPI: the MPI plugin (studies/mpi_plugin.h), built when CMake
// finds MPI (SERVOKIT_HAVE_MPI).
//
// The protocol of RunDistributedSweep. Every message from a rank to rank 0 (tag kResultTag) is
// one byte buffer: a MessageHeader, then its text. A rank sends its blocks in index order,
// then one final message: finished, stopped (a stop request) or failed (the error's kind and
// message). MPI keeps the order of messages between two ranks, so rank 0 can take block b
// from rank b mod size, in order, and then drain each rank up to its final message. Rank 0
// ends the sweep by sending every other rank one Verdict (tag kVerdictTag): a rank checks for it
// before each block (rank 0 stopped early) and waits for it after its final message.
//
// Waiting (for a message, for a send to complete) polls every kPollInterval instead of
// blocking in MPI, whose blocking calls spin on a core: with more threads than cores, a
// waiting rank 0 would otherwise slow down the threads computing the block it waits for.
#include "studies/mpi_plugin.h"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "studies/distributed_sweep.h"

namespace servokit {
namespace {

constexpr int kResultTag = 1;   // rank -> rank 0: blocks, then the final message
constexpr int kVerdictTag = 2;  // rank 0 -> rank: how the sweep ended
constexpr int kErrorTag = 3;    // AgreeOnSuccess: the failing rank's message to rank 0

// A message waits at most this long after it could have been taken: small against a block
// (milliseconds at least), large enough that a waiting rank costs no measurable CPU.
constexpr std::chrono::microseconds kPollInterval{100};

// Sends that may be in flight from one rank: it computes the next block while rank 0 has not
// yet taken the previous one, but never runs more than this far ahead (memory: one block each).
constexpr std::size_t kSendsInFlight = 2;

bool mpi_active = false;
ProcessGroup world;

void CheckMpi(int code, const char* call) {
  if (code == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int length = 0;
  MPI_Error_string(code, text, &length);
  throw Error(std::string(call) +
              " failed: " + std::string(text, static_cast<std::size_t>(length)));
}

// ---- errors across ranks ---------------------------------------------------------------------

// A failure as it travels between ranks: 0 for none, else 1 + its ErrorKind, so that the rank
// that throws it again throws an error of the same kind (the command line's exit status follows
// from the kind, application/exit_codes.h).
int FailureCodeOf(const std::exception_ptr& failure) {
  try {
    std::rethrow_exception(failure);
  } catch (const Error& error) {
    return 1 + static_cast<int>(error.kind());
  } catch (...) {
    return 1 + static_cast<int>(ErrorKind::kOther);
  }
}

std::string MessageOf(const std::exception_ptr& failure) {
  try {
    std::rethrow_exception(failure);
  } catch (const std::exception& error) {
    return error.what();
  } catch (...) {
    return "unknown internal error";
  }
}

// The error another rank reported (FailureCodeOf), of its kind.
[[noreturn]] void ThrowFailure(int code, const std::string& message) {
  const int kind = code - 1;
  const bool known =
      kind >= static_cast<int>(ErrorKind::kUsage) && kind <= static_cast<int>(ErrorKind::kOther);
  throw Error(message, known ? static_cast<ErrorKind>(kind) : ErrorKind::kOther);
}

std::string OnRank(int rank, const std::string& message) {
  return "rank " + std::to_string(rank) + ": " + message;
}

// ---- messages --------------------------------------------------------------------------------

enum class MessageKind : std::uint64_t { kBlock, kFinished, kStopped, kFailed };

// Ranks run the same binary on the same kind of machine (one build), so the header travels as
// raw bytes.
struct MessageHeader {
  MessageKind kind = MessageKind::kBlock;
  std::uint64_t first = 0, points = 0, points_without_solution = 0;  // kBlock
  std::uint64_t points_bytes = 0, eigenvalues_bytes = 0;  // kBlock: the text that follows
  std::uint64_t failure_code = 0, message_bytes = 0;      // kFailed: the message that follows
};
static_assert(std::is_trivially_copyable_v<MessageHeader>);

enum class VerdictKind : std::uint64_t { kFinished, kStopped, kFailed };

struct Verdict {
  VerdictKind kind = VerdictKind::kFinished;
  std::uint64_t done = 0;          // points written by rank 0
  std::uint64_t failure_code = 0;  // kFailed
};
static_assert(std::is_trivially_copyable_v<Verdict>);

using Buffer = std::vector<char>;

void AppendBytes(Buffer& buffer, const void* data, std::size_t size) {
  if (size == 0) return;
  const std::size_t offset = buffer.size();
  buffer.resize(offset + size);
  std::memcpy(buffer.data() + offset, data, size);
}

int MessageSize(const Buffer& buffer) {
  if (buffer.size() > static_cast<std::size_t>(INT_MAX)) {
    throw Error("a block of the sweep formats to " + std::to_string(buffer.size()) +
                " bytes, more than one MPI message holds; use a smaller block size");
  }
  return static_cast<int>(buffer.size());
}

Buffer BlockMessage(const FormattedBlock& block) {
  MessageHeader header;
  header.first = block.first;
  header.points = block.points;
  header.points_without_solution = block.points_without_solution;
  for (const std::string& slice : block.points_csv) header.points_bytes += slice.size();
  for (const std::string& slice : block.eigenvalues_csv) header.eigenvalues_bytes += slice.size();
  Buffer buffer;
  buffer.reserve(sizeof header + header.points_bytes + header.eigenvalues_bytes);
  AppendBytes(buffer, &header, sizeof header);
  for (const std::string& slice : block.points_csv) AppendBytes(buffer, slice.data(), slice.size());
  for (const std::string& slice : block.eigenvalues_csv) {
    AppendBytes(buffer, slice.data(), slice.size());
  }
  return buffer;
}

Buffer FinalMessage(MessageKind kind, int failure_code, const std::string& message) {
  MessageHeader header;
  header.kind = kind;
  header.failure_code = static_cast<std::uint64_t>(failure_code);
  header.message_bytes = message.size();
  Buffer buffer;
  AppendBytes(buffer, &header, sizeof header);
  AppendBytes(buffer, message.data(), message.size());
  return buffer;
}

MessageHeader ReadHeader(const Buffer& buffer, int source) {
  MessageHeader header;
  if (buffer.size() < sizeof header) {
    throw Error(
        OnRank(source, "malformed sweep message (" + std::to_string(buffer.size()) + " bytes)"));
  }
  std::memcpy(&header, buffer.data(), sizeof header);
  const std::size_t text = header.kind == MessageKind::kBlock
                               ? header.points_bytes + header.eigenvalues_bytes
                               : header.message_bytes;
  if (buffer.size() != sizeof header + text) {
    throw Error(
        OnRank(source, "malformed sweep message (" + std::to_string(buffer.size()) + " bytes)"));
  }
  return header;
}

// The block a kBlock message carries, as one slice of each table.
void ReadBlock(const Buffer& buffer, const MessageHeader& header, FormattedBlock& block) {
  const char* text = buffer.data() + sizeof header;
  block.first = header.first;
  block.points = header.points;
  block.points_without_solution = header.points_without_solution;
  block.points_csv.assign(1, std::string(text, header.points_bytes));
  block.eigenvalues_csv.assign(1,
                               std::string(text + header.points_bytes, header.eigenvalues_bytes));
}

std::string ReadMessageText(const Buffer& buffer, const MessageHeader& header) {
  return std::string(buffer.data() + sizeof header, header.message_bytes);
}

void Pause() { std::this_thread::sleep_for(kPollInterval); }

// Waits for the next message from `source` with `tag` and receives it whole.
Buffer Receive(int source, int tag) {
  MPI_Status status;
  for (int arrived = 0;;) {
    CheckMpi(MPI_Iprobe(source, tag, MPI_COMM_WORLD, &arrived, &status), "MPI_Iprobe");
    if (arrived) break;
    Pause();
  }
  int size = 0;
  CheckMpi(MPI_Get_count(&status, MPI_BYTE, &size), "MPI_Get_count");
  Buffer buffer(static_cast<std::size_t>(size));
  CheckMpi(MPI_Recv(buffer.data(), size, MPI_BYTE, source, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE),
           "MPI_Recv");
  return buffer;
}

void WaitFor(MPI_Request& request) {
  for (int done = 0;;) {
    CheckMpi(MPI_Test(&request, &done, MPI_STATUS_IGNORE), "MPI_Test");
    if (done) return;
    Pause();
  }
}

// Non-blocking sends, each owning its buffer until MPI is done with it.
class SendQueue {
 public:
  SendQueue() = default;
  SendQueue(const SendQueue&) = delete;
  SendQueue& operator=(const SendQueue&) = delete;
  // Completes the pending sends: MPI must not read a buffer that is gone.
  ~SendQueue() {
    try {
      WaitAll();
    } catch (...) {  // MPI failed: the error handler has reported it already
    }
  }

  /// Sends `buffer` to `destination`, after waiting for the oldest send if `limit` are pending.
  void Send(Buffer buffer, int destination, int tag, std::size_t limit) {
    while (sends_.size() >= limit) WaitOldest();
    sends_.push_back({MPI_REQUEST_NULL, std::move(buffer)});
    Pending& send = sends_.back();
    CheckMpi(MPI_Isend(send.buffer.data(), MessageSize(send.buffer), MPI_BYTE, destination, tag,
                       MPI_COMM_WORLD, &send.request),
             "MPI_Isend");
  }
  void WaitAll() {
    while (!sends_.empty()) WaitOldest();
  }

 private:
  struct Pending {
    MPI_Request request;
    Buffer buffer;
  };
  void WaitOldest() {
    WaitFor(sends_.front().request);
    sends_.pop_front();
  }
  std::deque<Pending> sends_;  // a deque keeps each buffer in place while others come and go
};

Buffer VerdictMessage(const Verdict& verdict) {
  Buffer buffer;
  AppendBytes(buffer, &verdict, sizeof verdict);
  return buffer;
}

// ---- the sweep -------------------------------------------------------------------------------

// The blocks of one sweep: block b holds points first(b) .. first(b) + size(b) - 1.
struct BlockPlan {
  std::size_t first_point, block_size, total;
  std::size_t count() const { return (total - first_point + block_size - 1) / block_size; }
  std::size_t first(std::size_t b) const { return first_point + b * block_size; }
  std::size_t size(std::size_t b) const { return std::min(block_size, total - first(b)); }
  int owner(std::size_t b, int ranks) const {
    return static_cast<int>(b % static_cast<std::size_t>(ranks));
  }
};

// Computes block b into `block` with this rank's threads (RunSweep over that block alone).
// `run` is RunSweep bound to the model and its workspaces (SweepRunner).
void ComputeBlock(const SweepRunner& run,
                  const ParameterGrid& grid,
                  const SweepOptions& options,
                  const BlockPlan& plan,
                  std::size_t b,
                  TableEncoding encoding,
                  FormattedBlock& block) {
  const int threads = SweepThreads(options);
  run(plan.first(b), [&](std::size_t first, std::span<const SweepPoint> points) {
    FormatBlock(grid, first, points, threads, encoding, block);
    return false;  // one block only
  });
}

// Rank 0: writes every block in order, its own and the other ranks'.
class Root {
 public:
  Root(const ProcessGroup& group, const BlockPlan& plan)
      : group_(group), plan_(plan), finished_(static_cast<std::size_t>(group.size), false) {
    finished_[0] = true;
  }

  DistributedSweepEnd Run(const SweepRunner& run,
                          const ParameterGrid& grid,
                          const SweepOptions& options,
                          TableEncoding encoding,
                          const std::function<void(const FormattedBlock&)>& write,
                          const std::function<bool()>& stop_requested) {
    Verdict verdict;
    verdict.done = plan_.first_point;
    std::exception_ptr failure;
    try {
      for (std::size_t b = 0; b < plan_.count(); ++b) {
        const int owner = plan_.owner(b, group_.size);
        if (owner == 0) {
          ComputeBlock(run, grid, options, plan_, b, encoding, block_);
        } else if (!ReceiveBlock(owner, plan_.first(b), plan_.size(b))) {
          verdict.kind = VerdictKind::kStopped;
          break;
        }
        write(block_);
        verdict.done = block_.first + block_.points;
        if (stop_requested()) {
          verdict.kind = VerdictKind::kStopped;
          break;
        }
      }
    } catch (...) {
      failure = std::current_exception();
      verdict.kind = VerdictKind::kFailed;
      verdict.failure_code = static_cast<std::uint64_t>(FailureCodeOf(failure));
    }
    End(verdict);
    if (failure) std::rethrow_exception(failure);
    return {static_cast<std::size_t>(verdict.done), verdict.kind == VerdictKind::kStopped};
  }

 private:
  // Takes the next message of `rank` into block_: true for the block of `points` points from
  // `first`, false when the rank stopped instead; throws the error of a rank that failed.
  bool ReceiveBlock(int rank, std::size_t first, std::size_t points) {
    const Buffer buffer = Receive(rank, kResultTag);
    const MessageHeader header = ReadHeader(buffer, rank);
    if (header.kind != MessageKind::kBlock) finished_[static_cast<std::size_t>(rank)] = true;
    switch (header.kind) {
      case MessageKind::kBlock:
        if (header.first != first || header.points != points) {
          throw Error(OnRank(rank, "sent " + std::to_string(header.points) + " points from " +
                                       std::to_string(header.first) + " where rank 0 expected " +
                                       std::to_string(points) + " from " + std::to_string(first) +
                                       " (another block size?)"));
        }
        ReadBlock(buffer, header, block_);
        return true;
      case MessageKind::kStopped:
        return false;
      case MessageKind::kFailed:
        ThrowFailure(static_cast<int>(header.failure_code),
                     OnRank(rank, ReadMessageText(buffer, header)));
      case MessageKind::kFinished:
        break;
    }
    throw Error(OnRank(rank, "finished before the block at point " + std::to_string(first)));
  }

  // Tells every rank how the sweep ended, then takes (and drops) whatever each still sends, up
  // to its final message, so that no rank waits forever for a send to complete.
  void End(const Verdict& verdict) {
    SendQueue verdicts;
    for (int rank = 1; rank < group_.size; ++rank) {
      verdicts.Send(VerdictMessage(verdict), rank, kVerdictTag, static_cast<std::size_t>(INT_MAX));
    }
    for (int rank = 1; rank < group_.size; ++rank) {
      while (!finished_[static_cast<std::size_t>(rank)]) {
        const Buffer buffer = Receive(rank, kResultTag);
        if (ReadHeader(buffer, rank).kind != MessageKind::kBlock) {
          finished_[static_cast<std::size_t>(rank)] = true;
        }
      }
    }
    verdicts.WaitAll();
  }

  const ProcessGroup group_;
  const BlockPlan plan_;
  std::vector<bool> finished_;  // by rank: its final message has arrived
  FormattedBlock block_;
};

bool VerdictArrived() {
  int arrived = 0;
  CheckMpi(MPI_Iprobe(0, kVerdictTag, MPI_COMM_WORLD, &arrived, MPI_STATUS_IGNORE), "MPI_Iprobe");
  return arrived != 0;
}

// Every rank but 0: computes blocks rank, rank + size, ... and sends them to rank 0.
DistributedSweepEnd RunWorker(const ProcessGroup& group,
                              const BlockPlan& plan,
                              const SweepRunner& run,
                              const ParameterGrid& grid,
                              const SweepOptions& options,
                              TableEncoding encoding,
                              const std::function<bool()>& stop_requested) {
  SendQueue sends;
  MessageKind end = MessageKind::kFinished;
  std::exception_ptr failure;
  try {
    FormattedBlock block;
    for (std::size_t b = static_cast<std::size_t>(group.rank); b < plan.count();
         b += static_cast<std::size_t>(group.size)) {
      if (VerdictArrived()) break;  // rank 0 has ended the sweep
      ComputeBlock(run, grid, options, plan, b, encoding, block);
      sends.Send(BlockMessage(block), 0, kResultTag, kSendsInFlight);
      if (stop_requested()) {
        end = MessageKind::kStopped;
        break;
      }
    }
  } catch (...) {
    failure = std::current_exception();
    end = MessageKind::kFailed;
  }
  sends.Send(failure ? FinalMessage(end, FailureCodeOf(failure), MessageOf(failure))
                     : FinalMessage(end, 0, ""),
             0, kResultTag, kSendsInFlight);
  sends.WaitAll();
  const Buffer buffer = Receive(0, kVerdictTag);
  Verdict verdict;
  if (buffer.size() != sizeof verdict) throw Error("malformed verdict from rank 0");
  std::memcpy(&verdict, buffer.data(), sizeof verdict);
  if (verdict.kind == VerdictKind::kFailed) {
    if (failure) std::rethrow_exception(failure);
    // Printed by rank 0 only; here it only carries the error's kind (the exit status).
    ThrowFailure(static_cast<int>(verdict.failure_code), "the sweep failed on another rank");
  }
  return {static_cast<std::size_t>(verdict.done), verdict.kind == VerdictKind::kStopped};
}

ProcessGroup Initialize(int& argc, char**& argv) {
  int provided = 0;
  // MPI_ERRORS_ARE_FATAL stays the handler: a failed MPI call ends the whole job rather than
  // leave a rank waiting for a message that never comes.
  CheckMpi(MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
  mpi_active = true;
  CheckMpi(MPI_Comm_rank(MPI_COMM_WORLD, &world.rank), "MPI_Comm_rank");
  CheckMpi(MPI_Comm_size(MPI_COMM_WORLD, &world.size), "MPI_Comm_size");
  MPI_Comm node = MPI_COMM_NULL;
  CheckMpi(
      MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, world.rank, MPI_INFO_NULL, &node),
      "MPI_Comm_split_type");
  CheckMpi(MPI_Comm_size(node, &world.ranks_on_node), "MPI_Comm_size");
  CheckMpi(MPI_Comm_free(&node), "MPI_Comm_free");
  return world;
}

void Finalize() {
  if (mpi_active) MPI_Finalize();
  mpi_active = false;
  world = {};
}

void AgreeOnSuccessWithMpi(std::exception_ptr failure) {
  if (!mpi_active || world.size == 1) {
    if (failure) std::rethrow_exception(failure);
    return;
  }
  const int status = failure ? FailureCodeOf(failure) : 0;
  std::vector<int> statuses(static_cast<std::size_t>(world.size));
  CheckMpi(MPI_Allgather(&status, 1, MPI_INT, statuses.data(), 1, MPI_INT, MPI_COMM_WORLD),
           "MPI_Allgather");
  const auto failed = std::find_if(statuses.begin(), statuses.end(), [](int s) { return s != 0; });
  if (failed == statuses.end()) return;
  const int rank = static_cast<int>(failed - statuses.begin());
  if (rank == world.rank) {
    if (rank != 0) {
      const std::string message = MessageOf(failure);
      CheckMpi(MPI_Send(message.data(), static_cast<int>(message.size()), MPI_BYTE, 0, kErrorTag,
                        MPI_COMM_WORLD),
               "MPI_Send");
    }
    std::rethrow_exception(failure);
  }
  if (world.rank == 0) {
    const Buffer message = Receive(rank, kErrorTag);
    ThrowFailure(*failed, OnRank(rank, std::string(message.begin(), message.end())));
  }
  ThrowFailure(*failed, OnRank(rank, "failed"));  // not printed: rank 0 prints
}

std::size_t BroadcastSize(std::size_t value) {
  if (!mpi_active) return value;
  std::uint64_t shared = value;
  CheckMpi(MPI_Bcast(&shared, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD), "MPI_Bcast");
  return static_cast<std::size_t>(shared);
}

std::string BroadcastText(const std::string& text) {
  if (!mpi_active) return text;
  std::string shared = text;
  shared.resize(BroadcastSize(text.size()));
  CheckMpi(MPI_Bcast(shared.data(), static_cast<int>(shared.size()), MPI_CHAR, 0, MPI_COMM_WORLD),
           "MPI_Bcast");
  return shared;
}

DistributedSweepEnd RunDistributedSweepWithMpi(
    const SweepRunner& run,
    const ParameterGrid& grid,
    const SweepOptions& options,
    std::size_t first_point,
    TableEncoding encoding,
    const std::function<void(const FormattedBlock&)>& write,
    const std::function<bool()>& stop_requested) {
  if (!mpi_active) throw Error("RunDistributedSweep: MPI is not initialised");
  const BlockPlan plan = {first_point, std::max<std::size_t>(options.block_size, 1),
                          std::max(grid.num_points(), first_point)};
  if (world.IsRoot()) {
    return Root(world, plan).Run(run, grid, options, encoding, write, stop_requested);
  }
  return RunWorker(world, plan, run, grid, options, encoding, stop_requested);
}

}  // namespace

extern "C" const MpiPlugin* servokit_mpi_plugin() {
  static const MpiPlugin plugin = {&Initialize,    &Finalize,      &AgreeOnSuccessWithMpi,
                                   &BroadcastSize, &BroadcastText, &RunDistributedSweepWithMpi};
  return &plugin;
}

}  // namespace servokit
