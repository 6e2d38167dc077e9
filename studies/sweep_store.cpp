#include "studies/sweep_store.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cassert>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <future>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "analysis/sweep_point.h"
#include "analysis/zero_dynamics.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "base/vocabulary.h"
#include "files/input_file.h"
#include "files/output_file.h"
#include "reports/sweep_hdf5.h"
#include "reports/sweep_mat.h"
#include "reports/sweep_records.h"

#ifndef SERVOKIT_VERSION
#error "SERVOKIT_VERSION must be defined by the build"
#endif

namespace servokit {
namespace {

constexpr const char* kCheckpointMagic = "servokit-sweep-checkpoint 1";

// ---- files -----------------------------------------------------------------------------------

Error IoError(const std::filesystem::path& path, const std::string& what) {
  return Error(path.string() + ": " + what + ": " + std::strerror(errno));
}

// Opens one of the sweep's own files, never through a link and only if it is a regular file:
// a link planted in --out would make a sweep write (or cut, on resume) a file elsewhere, and a
// FIFO would block it forever. The output directory itself (O_DIRECTORY) is the user's to name.
int OpenFile(const std::filesystem::path& path, int flags) {
  const bool directory = (flags & O_DIRECTORY) != 0;
  const int fd =
      ::open(path.c_str(), flags | O_CLOEXEC | (directory ? 0 : O_NOFOLLOW | O_NONBLOCK), 0644);
  if (fd < 0 && errno == ELOOP) {
    throw UsageError(path.string() + ": is a symbolic link; servokit does not write through links");
  }
  if (fd < 0 && errno == ENXIO) {  // a FIFO without a reader
    throw UsageError(path.string() + ": is not a regular file (a FIFO, socket or device)");
  }
  if (fd < 0) throw IoError(path, "cannot open");
  struct stat status {};
  if (!directory && (::fstat(fd, &status) != 0 || !S_ISREG(status.st_mode))) {
    ::close(fd);
    throw UsageError(path.string() + ": is not a regular file (a FIFO, socket or device)");
  }
  if (!directory) ::fcntl(fd, F_SETFL, flags & O_APPEND);  // blocking again, as asked
  return fd;
}

// close() is not checked: every file whose bytes matter has been fsync'ed, and checked, first.
void CloseFile(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

void WriteAll(int fd, const std::string& text, const std::filesystem::path& path) {
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw IoError(path, "write failed");
    written += static_cast<std::size_t>(n);
  }
}

// Writes the texts one after another, as WriteAll each would, with few system calls: a block
// of a pipelined sweep has a slice per 256-point chunk, 16 of them, and a write() each
// would cost a fifth of a cheap model's analysis.
void WriteAllInOrder(int fd,
                     const std::vector<std::string>& texts,
                     const std::filesystem::path& path) {
  constexpr std::size_t kMaxVectors = 512;  // at most IOV_MAX (1024 on Linux)
  std::vector<iovec> vectors;
  vectors.reserve(std::min(texts.size(), kMaxVectors));
  for (std::size_t next = 0; next < texts.size();) {
    vectors.clear();
    for (; next < texts.size() && vectors.size() < kMaxVectors; ++next) {
      if (!texts[next].empty()) {
        vectors.push_back({const_cast<char*>(texts[next].data()), texts[next].size()});
      }
    }
    std::size_t done = 0;  // vectors written whole
    while (done < vectors.size()) {
      const ssize_t n =
          ::writev(fd, vectors.data() + done, static_cast<int>(vectors.size() - done));
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw IoError(path, "write failed");
      // A short write: skip the vectors it finished and start in the one it broke off in.
      auto left = static_cast<std::size_t>(n);
      while (done < vectors.size() && left >= vectors[done].iov_len) {
        left -= vectors[done].iov_len;
        ++done;
      }
      if (left > 0) {
        vectors[done].iov_base = static_cast<char*>(vectors[done].iov_base) + left;
        vectors[done].iov_len -= left;
      }
    }
  }
}

// Starts writing the dirty pages of [offset, offset + length) to disk without waiting, so that
// the next checkpoint's fsync finds little left to do: it then costs milliseconds instead of
// stalling every thread while hundreds of MB go out. Advisory: a failure here is harmless,
// since the fsync that follows is checked.
void StartWriteback(int fd, std::size_t offset, std::size_t length) {
  ::sync_file_range(fd, static_cast<off_t>(offset), static_cast<off_t>(length),
                    SYNC_FILE_RANGE_WRITE);
}

void SyncFile(int fd, const std::filesystem::path& path) {
  if (::fsync(fd) != 0) throw IoError(path, "fsync failed");
}

// Where WriteDurably writes `path` before it renames it into place.
std::filesystem::path TemporaryPath(const std::filesystem::path& path) {
  std::filesystem::path temporary = path;
  temporary += ".tmp";
  return temporary;
}

// One of the sweep's own small files (sweep.json, the checkpoint), opened as OpenFile does.
std::string ReadFile(const std::filesystem::path& path) {
  int fd = OpenFile(path, O_RDONLY);
  struct stat status {};
  const bool sized = ::fstat(fd, &status) == 0;
  if (!sized || static_cast<std::uintmax_t>(status.st_size) > kRecordFileLimit) {
    CloseFile(fd);
    throw Error(path.string() + ": not a servokit sweep file (larger than " +
                std::to_string(kRecordFileLimit) + " bytes)");
  }
  std::string text(static_cast<std::size_t>(status.st_size), '\0');
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::read(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  const int error = errno;
  CloseFile(fd);
  if (done != text.size()) {
    errno = error;
    throw IoError(path, "cannot read");
  }
  return text;
}

// ---- checkpoint ------------------------------------------------------------------------------

struct CheckpointRecord {
  std::string fingerprint;
  std::size_t points_done = 0;
  std::size_t points_without_solution = 0;
  std::uintmax_t points_bytes = 0;
  std::uintmax_t eigenvalues_bytes = 0;
};

std::string FormatCheckpoint(const CheckpointRecord& record) {
  return std::string(kCheckpointMagic) + "\nfingerprint=" + record.fingerprint +
         "\npoints_done=" + std::to_string(record.points_done) +
         "\npoints_without_solution=" + std::to_string(record.points_without_solution) +
         "\npoints_bytes=" + std::to_string(record.points_bytes) +
         "\neigenvalues_bytes=" + std::to_string(record.eigenvalues_bytes) + "\n";
}

CheckpointRecord ReadCheckpoint(const std::filesystem::path& path) {
  std::istringstream text(ReadFile(path));
  std::string line;
  std::map<std::string, std::string> fields;
  const bool has_magic = std::getline(text, line) && line == kCheckpointMagic;
  while (std::getline(text, line)) {
    const std::size_t equals = line.find('=');
    if (equals != std::string::npos) fields[line.substr(0, equals)] = line.substr(equals + 1);
  }
  const auto number = [&](const std::string& key) -> std::uintmax_t {
    const std::string& value = fields[key];
    std::uintmax_t parsed = 0;
    const char* end = value.data() + value.size();
    const auto [stop, error] = std::from_chars(value.data(), end, parsed);
    if (value.empty() || error != std::errc() || stop != end) {
      throw Error(path.string() + ": unreadable checkpoint (" + key + "); delete the directory " +
                  "to start the sweep again");
    }
    return parsed;
  };
  if (!has_magic || !fields.contains("fingerprint")) {
    throw Error(path.string() +
                ": not a servokit sweep checkpoint; delete the directory to start the sweep again");
  }
  return {fields["fingerprint"], static_cast<std::size_t>(number("points_done")),
          static_cast<std::size_t>(number("points_without_solution")), number("points_bytes"),
          number("eigenvalues_bytes")};
}

// The one table of SweepFileFormat's names.
UsageError AnotherSweep(const std::string& label, const std::filesystem::path& directory) {
  return UsageError(label + " " + directory.string() +
                    " holds another sweep (a different model, grid or options); use another " +
                    label + " or delete that directory");
}

// ---- sweep.json ------------------------------------------------------------------------------

nlohmann::ordered_json GridToJson(const ParameterGrid& grid) {
  nlohmann::ordered_json axes = nlohmann::ordered_json::array();
  for (const GridAxis& axis : grid.axes()) {
    nlohmann::ordered_json entry = {{"name", axis.name}};
    if (const auto* range = std::get_if<ValueRange>(&axis.values)) {
      entry["a"] = range->first;
      entry["b"] = range->last;
      entry["n"] = range->count;
    } else {
      entry["values"] = std::get<std::vector<double>>(axis.values);
    }
    // The values above are SI; the tables show the parameter in this unit, in this column.
    entry["display_unit"] = ToString(axis.display_unit);
    entry["column"] = axis.ColumnName();
    axes.push_back(std::move(entry));
  }
  return axes;
}

nlohmann::ordered_json OptionalVectorToJson(const std::optional<Eigen::VectorXd>& values) {
  if (!values) return nullptr;
  return std::vector<double>(values->begin(), values->end());
}

// The inverse of GridToJson and OptionalVectorToJson; throws nlohmann's errors on a bad record.
std::vector<GridAxis> GridFromJson(const nlohmann::json& axes) {
  std::vector<GridAxis> grid;
  for (const nlohmann::json& entry : axes) {
    GridAxis axis;
    axis.name = entry.at("name").get<std::string>();
    if (entry.contains("values")) {
      axis.values = entry.at("values").get<std::vector<double>>();
    } else {
      axis.values = ValueRange{entry.at("a").get<double>(), entry.at("b").get<double>(),
                               entry.at("n").get<std::size_t>()};
    }
    const std::string unit = entry.at("display_unit").get<std::string>();
    if (unit == ToString(DisplayUnit::kDegree)) {
      axis.display_unit = DisplayUnit::kDegree;
    } else if (unit != ToString(DisplayUnit::kSI)) {
      throw std::invalid_argument("display_unit " + unit);
    }
    grid.push_back(std::move(axis));
  }
  if (grid.empty()) throw std::invalid_argument("no grid axes");
  return grid;
}

std::optional<Eigen::VectorXd> OptionalVectorFromJson(const nlohmann::json& values) {
  if (values.is_null()) return std::nullopt;
  const std::vector<double> read = values.get<std::vector<double>>();
  return Eigen::Map<const Eigen::VectorXd>(read.data(), Eigen::Index(read.size()));
}

// ---- fingerprint -----------------------------------------------------------------------------

std::string JoinExact(const std::vector<double>& values) {
  std::string joined;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i > 0) joined += ',';
    joined += FormatExact(values[i]);
  }
  return joined;
}

std::string OptionalVectorText(const std::optional<Eigen::VectorXd>& values) {
  if (!values) return "default";
  return "[" + JoinExact(std::vector<double>(values->begin(), values->end())) + "]";
}

}  // namespace

TableEncoding TableEncodingOf(SweepFileFormat format) {
  switch (format) {
    case SweepFileFormat::kCsv:
      return TableEncoding::kCsv;
    case SweepFileFormat::kHdf5:
      return TableEncoding::kRecordsAndRows;
    case SweepFileFormat::kMat:
      break;
  }
  return TableEncoding::kRecords;
}

std::string SweepTableFileNames(SweepFileFormat format) {
  switch (format) {
    case SweepFileFormat::kCsv:
      return "points.csv, eigenvalues.csv";
    case SweepFileFormat::kHdf5:
      return "sweep.h5";
    case SweepFileFormat::kMat:
      return "sweep.mat";
  }
  return "";
}

void CheckSweepFileColumns(SweepFileFormat format,
                           const ParameterGrid& grid,
                           const std::string& label) {
  try {
    if (format == SweepFileFormat::kHdf5) CheckHdf5ColumnNames(grid);
    if (format == SweepFileFormat::kMat) CheckMatColumnNames(grid);
  } catch (const UsageError& problem) {
    throw UsageError(label + " " + std::string(ToString(format)) + ": " + problem.what());
  }
}

std::string DescribeGrid(const ParameterGrid& grid) {
  std::string text;
  for (const GridAxis& axis : grid.axes()) {
    if (!text.empty()) text += ' ';
    text += axis.name + "=";
    if (const auto* range = std::get_if<ValueRange>(&axis.values)) {
      text += FormatExact(range->first) + ":" + FormatExact(range->last) + ":" +
              std::to_string(range->count);
    } else {
      text += "[" + JoinExact(std::get<std::vector<double>>(axis.values)) + "]";
    }
    // The unit changes the files (column name, values shown), so it is part of the sweep; the
    // values here are SI whatever it is.
    if (axis.display_unit == DisplayUnit::kDegree) text += " shown in deg";
  }
  return text;
}

SweepRecord ReadSweepRecord(const std::filesystem::path& directory, const std::string& label) {
  SweepRecord record;
  record.file = directory / "sweep.json";
  if (!std::filesystem::is_regular_file(record.file)) {
    throw UsageError(label + " " + directory.string() +
                     ": no sweep.json there; not a directory a servokit sweep wrote");
  }
  const nlohmann::json json = nlohmann::json::parse(ReadFile(record.file), nullptr, false);
  const auto not_a_record = [&record](const std::string& why) {
    return UsageError(record.file.string() + " is not a servokit sweep record (" + why + ")");
  };
  if (!json.is_object() || !json.contains("fingerprint")) throw not_a_record("no fingerprint");
  try {
    record.model_name = json.at("model").get<std::string>();
    record.model_path = json.at("model_path").get<std::string>();
    record.content_hash = json.at("content_hash").get<std::string>();
    record.linear = json.value("kind", std::string()) == "linear";
    const std::string format = json.value("format", std::string(ToString(SweepFileFormat::kCsv)));
    const std::optional<SweepFileFormat> known = SweepFileFormatFromString(format);
    if (!known) throw std::invalid_argument("format " + format);
    record.format = *known;
    record.completed = json.at("completed").get<bool>();
    for (const auto& [name, value] : json.at("fixed_parameters").items()) {
      record.fixed_parameters.emplace_back(name, value.get<double>());
    }
    record.axes = GridFromJson(json.at("grid"));
    if (!record.linear) {
      const nlohmann::json& options = json.at("options");
      record.options.rank_tolerance = options.at("rank_tolerance").get<double>();
      record.options.imaginary_axis_tolerance =
          options.at("imaginary_axis_tolerance").get<double>();
      OperatingPointOptions& point = record.options.operating_point;
      point.residual_tolerance = options.at("residual_tolerance").get<double>();
      point.max_iterations = options.at("max_iterations").get<decltype(point.max_iterations)>();
      point.y0 = OptionalVectorFromJson(options.at("y0"));
      point.q_guess = OptionalVectorFromJson(options.at("q0"));
    }
  } catch (const std::exception& error) {
    throw not_a_record(error.what());
  }
  return record;
}

std::vector<GridAxis> ResolveSweepAxes(const SweepRecord& record,
                                       const std::vector<std::string>& parameter_names) {
  std::vector<GridAxis> axes = record.axes;
  for (GridAxis& axis : axes) axis.parameter = ParameterIndex(parameter_names, axis.name);
  return axes;
}

SweepModelInfo DescribeSweepModel(const LoadedModel& model, const SweepOptions& options) {
  SweepModelInfo info = std::visit(
      [&](const auto& kind) {
        return SweepModelInfo{
            kind.name(),       kind.source(), kind.content_hash(), kind.parameter_names(),
            kind.parameters(), std::nullopt,  kind.dof(),          kind.num_outputs()};
      },
      model.variant());
  if (model.linear()) info.linear = options.linear;
  if (const Model* multibody = model.multibody()) {
    info.tries_polynomial = SweepTriesPolynomial(*multibody, options.classification);
  }
  return info;
}

std::string SweepFingerprint(const SweepModelInfo& model,
                             const ParameterGrid& grid,
                             const ClassificationOptions& options,
                             SweepFileFormat format) {
  std::string text = std::string("servokit ") + SERVOKIT_VERSION + "; model " + model.content_hash +
                     "; parameters";
  for (std::size_t i = 0; i < model.parameter_names.size(); ++i) {
    text += (i == 0 ? " " : ",") + model.parameter_names[i] + "=" +
            FormatExact(model.parameters[static_cast<Eigen::Index>(i)]);
  }
  text += "; vary " + DescribeGrid(grid);
  if (model.linear) {
    text += "; linear " + DescribeLinearSweepOptions(*model.linear);
  } else {
    const OperatingPointOptions& point = options.operating_point;
    text += "; rank_tolerance=" + FormatExact(options.rank_tolerance) +
            " imaginary_axis_tolerance=" + FormatExact(options.imaginary_axis_tolerance) +
            " residual_tolerance=" + FormatExact(point.residual_tolerance) +
            " max_iterations=" + std::to_string(point.max_iterations) +
            " y0=" + OptionalVectorText(point.y0) + " q0=" + OptionalVectorText(point.q_guess);
  }
  if (format != SweepFileFormat::kCsv) text += "; format " + std::string(ToString(format));
  return text;
}

SweepOutput::SweepOutput(const std::filesystem::path& directory,
                         SweepModelInfo model,
                         const ParameterGrid& grid,
                         const ClassificationOptions& options,
                         std::vector<std::string> command_line,
                         const SweepOutputOptions& output_options,
                         SweepFileFormat format)
    : directory_(directory),
      paths_(format == SweepFileFormat::kCsv ? Paths{directory / "points.csv",
                                                     directory / "points.csv.partial",
                                                     directory / "eigenvalues.csv",
                                                     directory / "eigenvalues.csv.partial",
                                                     directory / "sweep.json",
                                                     directory / ".sweep-checkpoint",
                                                     {}}
                                             : Paths{{},
                                                     directory / "points.records.partial",
                                                     {},
                                                     directory / "eigenvalues.records.partial",
                                                     directory / "sweep.json",
                                                     directory / ".sweep-checkpoint",
                                                     directory / SweepTableFileNames(format)}),
      model_(std::move(model)),
      grid_(grid),
      options_(options),
      command_line_(std::move(command_line)),
      format_(format),
      fingerprint_(SweepFingerprint(model_, grid, options, format)),
      checkpoint_interval_(output_options.checkpoint_interval),
      directory_label_(output_options.directory_label) {
  Lock();
  try {
    for (const std::filesystem::path& path :
         {paths_.points, paths_.eigenvalues, paths_.record, paths_.table_file}) {
      if (!path.empty()) CheckOutputPath(path.string());
    }
    RemoveStaleTemporaries();
    if (std::filesystem::exists(paths_.checkpoint)) {
      const CheckpointRecord checkpoint = ReadCheckpoint(paths_.checkpoint);
      if (checkpoint.fingerprint != fingerprint_) throw AnotherSweep(directory_label_, directory_);
      points_done_ = checkpoint.points_done;
      points_without_solution_ = checkpoint.points_without_solution;
      Resume({checkpoint.points_bytes, checkpoint.eigenvalues_bytes});
      return;
    }
    if (std::filesystem::exists(paths_.record)) {
      nlohmann::json record = nlohmann::json::parse(ReadFile(paths_.record), nullptr, false);
      if (!record.is_object() || !record.contains("fingerprint")) {
        throw UsageError(directory_label_ + " " + directory_.string() + ": " +
                         paths_.record.string() + " is not a servokit sweep record; use another " +
                         directory_label_ + " or delete it");
      }
      if (record["fingerprint"] != fingerprint_) throw AnotherSweep(directory_label_, directory_);
      already_complete_ = record.value("completed", false) && FinalFilesExist();
      if (already_complete_) {
        // A crash right after the record said completed may have left the records behind.
        if (format_ != SweepFileFormat::kCsv) {
          std::filesystem::remove(paths_.points_partial);
          std::filesystem::remove(paths_.eigenvalues_partial);
        }
        points_done_ = grid_.num_points();
        points_without_solution_ = record.value("points_without_solution", std::size_t{0});
        return;
      }
    }
    StartAfresh();
  } catch (...) {
    CloseTables();
    CloseFile(directory_fd_);
    throw;
  }
}

SweepOutput::~SweepOutput() {
  CloseTables();
  CloseFile(directory_fd_);  // releases the lock
}

void SweepOutput::Lock() {
  std::error_code error;
  std::filesystem::create_directories(directory_, error);
  if (error) {
    throw Error(directory_.string() + ": cannot create the directory: " + error.message());
  }
  directory_fd_ = OpenFile(directory_, O_RDONLY | O_DIRECTORY);
  if (::flock(directory_fd_, LOCK_EX | LOCK_NB) != 0) {
    CloseFile(directory_fd_);
    throw UsageError(directory_label_ + " " + directory_.string() +
                     ": another servokit sweep is writing this directory");
  }
}

void SweepOutput::RemoveStaleTemporaries() const {
  // A run killed inside WriteDurably leaves its temporary behind. Most resumed runs overwrite
  // it at their next checkpoint, but one killed after its last checkpoint never writes another,
  // and the finished directory would keep a stray file. We hold the lock: nobody else writes.
  for (const std::filesystem::path& path : {paths_.checkpoint, paths_.record, paths_.table_file}) {
    if (path.empty()) continue;
    std::error_code error;
    std::filesystem::remove(TemporaryPath(path), error);
    if (error) {
      throw Error(TemporaryPath(path).string() + ": cannot remove: " + error.message());
    }
  }
  // The same for OutputFile's temporaries of the table file written whole at the end
  // (sweep.mat) and of its ".tmp" stage.
  if (paths_.table_file.empty()) return;
  RemoveStaleOutputTemporaries(paths_.table_file.string());
  RemoveStaleOutputTemporaries(TemporaryPath(paths_.table_file).string());
}

void SweepOutput::StartAfresh() {
  // The record first: a run killed before its first checkpoint is then recognised as this
  // sweep (and started again) rather than refused as another.
  WriteRecord(false);
  constexpr int kCreate = O_WRONLY | O_CREAT | O_TRUNC | O_APPEND;
  points_fd_ = OpenFile(paths_.points_partial, kCreate);
  eigenvalues_fd_ = OpenFile(paths_.eigenvalues_partial, kCreate);
  // Binary records have no header: the columns are known from the grid.
  const bool csv = format_ == SweepFileFormat::kCsv;
  const std::string points_header = csv ? PointsCsvHeader(grid_) : std::string();
  const std::string eigenvalues_header = csv ? EigenvaluesCsvHeader(grid_) : std::string();
  WriteAll(points_fd_, points_header, paths_.points_partial);
  WriteAll(eigenvalues_fd_, eigenvalues_header, paths_.eigenvalues_partial);
  sizes_ = {points_header.size(), eigenvalues_header.size()};
  if (format_ == SweepFileFormat::kHdf5) StartHdf5File();
  Checkpoint();
}

void SweepOutput::Resume(const FileSizes& sizes) {
  sizes_ = sizes;
  if (points_done_ == grid_.num_points()) return;  // Finish() may have renamed them already
  for (const auto& [path, size] : {std::pair{paths_.points_partial, sizes.points},
                                   std::pair{paths_.eigenvalues_partial, sizes.eigenvalues}}) {
    const auto missing = [&] {
      return Error(path.string() + ": missing or shorter than the checkpoint records (" +
                   std::to_string(size) + " bytes); delete " + directory_.string() +
                   " to start the sweep again");
    };
    if (!std::filesystem::exists(std::filesystem::symlink_status(path))) throw missing();
    int fd = OpenFile(path, O_WRONLY);
    struct stat status {};
    if (::fstat(fd, &status) != 0 || static_cast<std::uintmax_t>(status.st_size) < size) {
      CloseFile(fd);
      throw missing();
    }
    // Rows written after the checkpoint may be incomplete; they are computed again.
    const bool cut = ::ftruncate(fd, static_cast<off_t>(size)) == 0;
    CloseFile(fd);
    if (!cut) throw IoError(path, "cannot cut to the checkpoint");
  }
  points_fd_ = OpenFile(paths_.points_partial, O_WRONLY | O_APPEND);
  eigenvalues_fd_ = OpenFile(paths_.eigenvalues_partial, O_WRONLY | O_APPEND);
  if (format_ == SweepFileFormat::kHdf5) StartHdf5File();
  last_checkpoint_ = std::chrono::steady_clock::now();
}

SweepFileMetadata SweepOutput::TableFileMetadata() const {
  return {model_.name, model_.content_hash, DescribeGrid(grid_), SERVOKIT_VERSION};
}

void SweepOutput::StartHdf5File() {
  const SweepFileMetadata metadata = TableFileMetadata();
  const std::filesystem::path path = TemporaryPath(paths_.table_file);
  // HDF5 creates it exclusively (never through a link): whatever a killed run left there goes.
  std::error_code ignored;
  std::filesystem::remove(path, ignored);
  const std::size_t relative_degree_width = RelativeDegreeTextWidth(model_.dof, model_.outputs);
  records_ = std::make_unique<RecordDecoder>(grid_);
  if (points_done_ == 0) {
    // Loading HDF5 (some 40 shared libraries) and creating the file take some 10 ms: they run
    // beside the analysis of the first points, and the first block appended waits for them.
    const ParameterGrid& grid = grid_;
    hdf5_pending_ = std::async(std::launch::async, [path, metadata, &grid, relative_degree_width] {
      return CreateSweepHdf5(path, metadata, grid, relative_degree_width);
    });
    return;
  }
  hdf5_ = CreateSweepHdf5(path, metadata, grid_, relative_degree_width);
  // The rows of the points done before (a resumed sweep), from their records: the file's bytes
  // depend only on the rows, so it becomes the one an uninterrupted run writes.
  constexpr std::size_t kRowsPerRead = std::size_t{1} << 16;
  const std::unique_ptr<TableRecordReader> points =
      OpenPointRecords(grid_, paths_.points_partial, points_done_);
  while (points->Read(kRowsPerRead, rows_) > 0) hdf5_->AppendPoints(rows_);
  const std::unique_ptr<TableRecordReader> eigenvalues =
      OpenEigenvalueRecords(grid_, paths_.eigenvalues_partial);
  while (eigenvalues->Read(kRowsPerRead, rows_) > 0) hdf5_->AppendEigenvalues(rows_);
}

SweepHdf5Writer& SweepOutput::Hdf5File() {
  if (hdf5_pending_.valid()) hdf5_ = hdf5_pending_.get();  // rethrows what creating it threw
  // A run resumed with every point done starts it at Finish, from its records (at once).
  if (!hdf5_) StartHdf5File();
  return *hdf5_;
}

void SweepOutput::AppendToHdf5File(const FormattedBlock& block) {
  if (!block.points_rows.empty()) {  // decoded by the threads that formatted the block
    for (const TableChunk& rows : block.points_rows) Hdf5File().AppendPoints(rows);
    for (const TableChunk& rows : block.eigenvalue_rows) Hdf5File().AppendEigenvalues(rows);
    return;
  }
  std::size_t first = block.first;
  for (const std::string& records : block.points_csv) {
    first += records_->DecodePoints(records, first, rows_);
    Hdf5File().AppendPoints(rows_);
  }
  for (const std::string& records : block.eigenvalues_csv) {
    records_->DecodeEigenvalues(records, rows_);
    Hdf5File().AppendEigenvalues(rows_);
  }
}

void SweepOutput::Append(const FormattedBlock& block) {
  assert(block.first == points_done_ && points_fd_ >= 0);
  assert(block.points_csv.size() == block.eigenvalues_csv.size());
  const FileSizes before = sizes_;
  WriteAllInOrder(points_fd_, block.points_csv, paths_.points_partial);
  WriteAllInOrder(eigenvalues_fd_, block.eigenvalues_csv, paths_.eigenvalues_partial);
  for (std::size_t slice = 0; slice < block.points_csv.size(); ++slice) {
    sizes_.points += block.points_csv[slice].size();
    sizes_.eigenvalues += block.eigenvalues_csv[slice].size();
  }
  if (format_ == SweepFileFormat::kCsv) {
    StartWriteback(points_fd_, before.points, sizes_.points - before.points);
    StartWriteback(eigenvalues_fd_, before.eigenvalues, sizes_.eigenvalues - before.eigenvalues);
  }
  if (format_ == SweepFileFormat::kHdf5) AppendToHdf5File(block);
  points_done_ += block.points;
  points_without_solution_ += block.points_without_solution;
  if (std::chrono::steady_clock::now() - last_checkpoint_ >= checkpoint_interval_) {
    Checkpoint();
  }
}

void SweepOutput::Checkpoint() {
  if (points_fd_ >= 0) SyncFile(points_fd_, paths_.points_partial);
  if (eigenvalues_fd_ >= 0) SyncFile(eigenvalues_fd_, paths_.eigenvalues_partial);
  WriteDurably(paths_.checkpoint,
               FormatCheckpoint({fingerprint_, points_done_, points_without_solution_,
                                 sizes_.points, sizes_.eigenvalues}));
  last_checkpoint_ = std::chrono::steady_clock::now();
}

bool SweepOutput::Finish(const std::function<bool()>& stop_requested) {
  assert(points_done_ == grid_.num_points());
  if (already_complete_) return true;
  if (stop_requested && stop_requested()) return false;
  if (format_ == SweepFileFormat::kCsv) {
    // The checkpoint must say "all done" before the first rename: a crash between the renames
    // then resumes here instead of missing a partial file.
    if (points_fd_ >= 0) Checkpoint();
    CloseTables();
    RenameCsvTables();
  } else {
    // The records are read back as written (the page cache holds them); they need not be made
    // durable first: a crash before sweep.json says completed resumes at the last checkpoint,
    // and the file built again then has the same bytes.
    CloseTables();
    if (!WriteTableFile(stop_requested)) return false;
  }
  SyncDirectory();
  WriteRecord(true);
  std::filesystem::remove(paths_.checkpoint);
  // The records go after the checkpoint: a crash in between finds sweep.json completed and the
  // table file, and the constructor removes the stale records.
  if (format_ != SweepFileFormat::kCsv) {
    std::filesystem::remove(paths_.points_partial);
    std::filesystem::remove(paths_.eigenvalues_partial);
  }
  SyncDirectory();
  already_complete_ = true;
  return true;
}

bool SweepOutput::FinalFilesExist() const {
  if (format_ != SweepFileFormat::kCsv) return std::filesystem::exists(paths_.table_file);
  return std::filesystem::exists(paths_.points) && std::filesystem::exists(paths_.eigenvalues);
}

void SweepOutput::RenameCsvTables() {
  for (const auto& [partial, final_path] :
       {std::pair{paths_.points_partial, paths_.points},
        std::pair{paths_.eigenvalues_partial, paths_.eigenvalues}}) {
    if (std::filesystem::exists(partial)) {
      CheckOutputPath(final_path.string());
      std::filesystem::rename(partial, final_path);
    } else if (!std::filesystem::exists(final_path)) {
      throw Error(partial.string() + ": missing; delete " + directory_.string() +
                  " to start the sweep again");
    }
  }
}

bool SweepOutput::WriteTableFile(const std::function<bool()>& stop_requested) {
  const bool have_records = std::filesystem::exists(paths_.points_partial) &&
                            std::filesystem::exists(paths_.eigenvalues_partial);
  if (!have_records) {
    if (std::filesystem::exists(paths_.table_file)) return true;  // built before a crash
    throw Error(paths_.points_partial.string() + ": missing; delete " + directory_.string() +
                " to start the sweep again");
  }
  const std::unique_ptr<TableRecordReader> points = OpenPointRecords(grid_, paths_.points_partial);
  const std::filesystem::path temporary = TemporaryPath(paths_.table_file);
  if (format_ == SweepFileFormat::kHdf5) {
    // Written as the sweep ran; a run resumed with every point done starts it here.
    Hdf5File().Finish(*points);
    hdf5_.reset();  // closes the file
  } else {
    const std::unique_ptr<TableRecordReader> eigenvalues =
        OpenEigenvalueRecords(grid_, paths_.eigenvalues_partial);
    if (!WriteSweepMat(temporary, TableFileMetadata(), *points, *eigenvalues, stop_requested)) {
      return false;
    }
  }
  int fd = OpenFile(temporary, O_RDONLY);
  try {
    SyncFile(fd, temporary);
  } catch (...) {
    CloseFile(fd);
    throw;
  }
  CloseFile(fd);
  CheckOutputPath(paths_.table_file.string());
  std::filesystem::rename(temporary, paths_.table_file);
  return true;
}

void SweepOutput::WriteRecord(bool completed) const {
  nlohmann::ordered_json fixed = nlohmann::ordered_json::object();
  for (std::size_t i = 0; i < model_.parameter_names.size(); ++i) {
    bool varied = false;
    for (const GridAxis& axis : grid_.axes()) varied = varied || axis.parameter == i;
    if (!varied) {
      fixed[model_.parameter_names[i]] = model_.parameters[static_cast<Eigen::Index>(i)];
    }
  }
  const OperatingPointOptions& point = options_.operating_point;
  nlohmann::ordered_json record = {
      {"model", model_.name},
      {"model_path", model_.source},
      {"content_hash", model_.content_hash},
      {"command_line", command_line_},
      {"fixed_parameters", fixed},
      {"grid", GridToJson(grid_)},
      {"order", "row-major: the first varied parameter varies slowest, the last fastest"},
      {"points", grid_.num_points()},
      {"options",
       {{"rank_tolerance", options_.rank_tolerance},
        {"imaginary_axis_tolerance", options_.imaginary_axis_tolerance},
        {"residual_tolerance", point.residual_tolerance},
        {"max_iterations", point.max_iterations},
        {"y0", OptionalVectorToJson(point.y0)},
        {"q0", OptionalVectorToJson(point.q_guess)}}},
      {"servokit_version", SERVOKIT_VERSION},
      {"fingerprint", fingerprint_},
      {"completed", completed}};
  if (!model_.linear) {
    // Which route classifies the points (SweepTriesPolynomial).
    record["zero_dynamics_route"] = model_.tries_polynomial ? "polynomial" : "eigenvalues";
  }

  if (model_.linear) {
    // A linear model is analysed at q = 0, u = 0 (no Newton, no y0/q0) with its own options.
    const LinearAnalysisOptions& linear = *model_.linear;
    const LinearZeroDynamicsOptions& zeros = linear.zero_dynamics;
    record["options"] = {{"rank_tolerance", linear.rank_tolerance},
                         {"imaginary_axis_tolerance", zeros.imaginary_axis_tolerance},
                         {"eigen_solver", std::string(ToString(zeros.solver))},
                         {"which", std::string(ToString(zeros.target))},
                         {"shift", zeros.shift},
                         {"eigenvalues", zeros.arpack.eigenvalues},
                         {"dense_threshold", zeros.dense_threshold}};
    record["kind"] = "linear";
  }
  if (format_ != SweepFileFormat::kCsv) record["format"] = std::string(ToString(format_));
  if (completed) record["points_without_solution"] = points_without_solution_;
  WriteDurably(paths_.record, record.dump(2) + "\n");
}

void SweepOutput::WriteDurably(const std::filesystem::path& path,
                               const std::string& contents) const {
  const std::filesystem::path temporary = TemporaryPath(path);
  int fd = OpenFile(temporary, O_WRONLY | O_CREAT | O_TRUNC);
  try {
    WriteAll(fd, contents, temporary);
    SyncFile(fd, temporary);
  } catch (...) {
    CloseFile(fd);
    throw;
  }
  CloseFile(fd);
  CheckOutputPath(path.string());
  std::filesystem::rename(temporary, path);
  SyncDirectory();
}

void SweepOutput::SyncDirectory() const { SyncFile(directory_fd_, directory_); }

void SweepOutput::CloseTables() {
  CloseFile(points_fd_);
  CloseFile(eigenvalues_fd_);
}

}  // namespace servokit
