// api::DirectorySweep and the processes of an MPI job: the API's face of studies/directory_sweep.h
// and studies/distributed_sweep.h.
#include "studies/directory_sweep.h"

#include <chrono>
#include <optional>
#include <utility>

#include "analysis/sweep.h"
#include "base/errors.h"
#include "base/option_check.h"
#include "servokit/toolkit_bridge.h"
#include "studies/distributed_sweep.h"
#include "studies/sweep_store.h"

namespace servokit::api {

SweepSettings DefaultSweepSettings() {
  return {kMaxSweepThreads, kSweepBlockSize, kMaxSweepBlockSize, kSweepCheckpointInterval.count()};
}

struct DirectorySweep::State {
  Model model;  // holds the toolkit's model the sweep refers to
  std::optional<servokit::DirectorySweep> sweep;
};

DirectorySweep::DirectorySweep(const Model& model,
                               const std::vector<SweepAxis>& axes,
                               const SweepOptions& options,
                               const DirectorySweepOptions& directory_options)
    : state_(new State{model, std::nullopt}) {
  constexpr const char* kOwner = "DirectorySweepOptions";
  RequireOption(options.threads >= 0 && options.threads <= kMaxSweepThreads, "SweepOptions",
                "threads", options.threads,
                "must be 0 (all cores) .. " + std::to_string(kMaxSweepThreads));
  RequireOption(
      directory_options.block_size >= 1 && directory_options.block_size <= kMaxSweepBlockSize,
      kOwner, "block_size", directory_options.block_size,
      "must be 1 .. " + std::to_string(kMaxSweepBlockSize));
  RequireOption(directory_options.checkpoint_interval > 0.0, kOwner, "checkpoint_interval",
                directory_options.checkpoint_interval, "must be > 0 seconds");
  servokit::SweepOptions sweep_options = ToSweepOptions(model, options);
  sweep_options.block_size = directory_options.block_size;
  SweepOutputOptions output_options;
  output_options.checkpoint_interval =
      std::chrono::duration<double>(directory_options.checkpoint_interval);
  output_options.directory_label = directory_options.directory_label;
  output_options.format_label = directory_options.format_label;
  state_->sweep.emplace(ToolkitModel(state_->model), ToGrid(model, axes), std::move(sweep_options),
                        directory_options.format, std::move(output_options),
                        directory_options.command_line);
}

DirectorySweep::~DirectorySweep() = default;

void DirectorySweep::Open(const std::string& directory) { state_->sweep->Open(directory); }

std::size_t DirectorySweep::num_points() const { return state_->sweep->num_points(); }
bool DirectorySweep::already_complete() const { return state_->sweep->already_complete(); }
std::size_t DirectorySweep::first_point() const { return state_->sweep->first_point(); }

DirectorySweep::End DirectorySweep::Run(const std::function<bool()>& stop_requested,
                                        const std::function<void(std::size_t)>& progress) {
  switch (state_->sweep->Run(stop_requested, progress)) {
    case DirectorySweepEnd::kFinished:
      return End::kFinished;
    case DirectorySweepEnd::kStopped:
      return End::kStopped;
    case DirectorySweepEnd::kStoppedInTables:
      return End::kStoppedInTables;
  }
  return End::kStopped;
}

std::size_t DirectorySweep::points_done() const { return state_->sweep->points_done(); }
std::size_t DirectorySweep::points_without_solution() const {
  return state_->sweep->points_without_solution();
}
std::string DirectorySweep::table_file_names() const { return state_->sweep->table_file_names(); }

struct MpiSession::State {
  servokit::MpiSession session;
};

MpiSession::MpiSession(int& argc, char**& argv) : state_(new State{{argc, argv}}) {}
MpiSession::~MpiSession() = default;

ProcessGroup Processes() { return servokit::Processes(); }

void OnEveryProcess(const std::function<void()>& step) { servokit::OnEveryProcess(step); }

}  // namespace servokit::api
