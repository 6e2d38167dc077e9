#include "reports/sweep_records.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "analysis/types.h"
#include "analysis/zero_dynamics.h"
#include "models/errors.h"

namespace servokit {
namespace {

constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
// Bytes of a point record's fixed head (the layout of PointHead, written field by field).
constexpr std::size_t kPointHeadBytes = 40;

// The fixed part of a point record; the two texts follow it.
struct PointHead {
  double max_real_part = 0.0;
  std::int64_t rank = 0;
  std::int32_t differentiation_index = 0;
  std::int32_t internal_dynamics_order = 0;
  std::uint32_t relative_degree_bytes = 0;
  std::uint32_t error_bytes = 0;
  std::uint8_t ok = 0, realization = 0, stability = 0;
};

template <typename T>
void Put(std::string& bytes, const T& value) {
  bytes.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <typename T>
T Take(const char*& bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  bytes += sizeof(T);
  return value;
}

void PutPointHead(std::string& bytes, const PointHead& head) {
  const std::size_t start = bytes.size();
  Put(bytes, head.max_real_part);
  Put(bytes, head.rank);
  Put(bytes, head.differentiation_index);
  Put(bytes, head.internal_dynamics_order);
  Put(bytes, head.relative_degree_bytes);
  Put(bytes, head.error_bytes);
  Put(bytes, head.ok);
  Put(bytes, head.realization);
  Put(bytes, head.stability);
  bytes.append(kPointHeadBytes - (bytes.size() - start), '\0');
}

PointHead TakePointHead(const char* bytes) {
  PointHead head;
  head.max_real_part = Take<double>(bytes);
  head.rank = Take<std::int64_t>(bytes);
  head.differentiation_index = Take<std::int32_t>(bytes);
  head.internal_dynamics_order = Take<std::int32_t>(bytes);
  head.relative_degree_bytes = Take<std::uint32_t>(bytes);
  head.error_bytes = Take<std::uint32_t>(bytes);
  head.ok = Take<std::uint8_t>(bytes);
  head.realization = Take<std::uint8_t>(bytes);
  head.stability = Take<std::uint8_t>(bytes);
  return head;
}

// The records file, read in large pieces.
class RecordFile {
 public:
  explicit RecordFile(const std::filesystem::path& path)
      : path_(path), file_(path, std::ios::binary) {
    if (!file_) throw Error(path.string() + ": cannot read: " + std::strerror(errno));
    std::error_code error;
    size_ = std::filesystem::file_size(path, error);
    if (error) throw Error(path.string() + ": cannot read: " + error.message());
  }
  std::uintmax_t size() const { return size_; }
  void Rewind() {
    file_.clear();
    file_.seekg(0);
    buffer_.clear();
    position_ = 0;
  }
  // The next `bytes` bytes, valid until the next call.
  const char* Next(std::size_t bytes) {
    if (buffer_.size() - position_ < bytes) Refill(bytes);
    const char* next = buffer_.data() + position_;
    position_ += bytes;
    return next;
  }
  bool AtEnd() { return position_ == buffer_.size() && file_.peek() == EOF; }
  const std::filesystem::path& path() const { return path_; }

 private:
  void Refill(std::size_t bytes) {
    constexpr std::size_t kPiece = std::size_t{1} << 22;
    buffer_.erase(0, position_);
    position_ = 0;
    const std::size_t want = std::max(bytes, kPiece);
    const std::size_t kept = buffer_.size();
    buffer_.resize(kept + want);
    file_.read(buffer_.data() + kept, static_cast<std::streamsize>(want));
    buffer_.resize(kept + static_cast<std::size_t>(file_.gcount()));
    if (buffer_.size() < bytes) {
      throw Error(path_.string() + ": the sweep's records end in the middle of a row; delete " +
                  "the output directory to start the sweep again");
    }
  }

  std::filesystem::path path_;
  std::ifstream file_;
  std::uintmax_t size_ = 0;
  std::string buffer_;
  std::size_t position_ = 0;
};

// Sizes `chunk` for `rows` rows of `columns`, NaN and "" everywhere.
void ResetChunk(const std::vector<TableColumn>& columns, std::size_t rows, TableChunk& chunk) {
  chunk.rows = rows;
  chunk.numbers.resize(columns.size());
  chunk.texts.resize(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) {
    if (columns[c].kind == ColumnKind::kNumber) {
      chunk.numbers[c].assign(rows, kNone);
      chunk.texts[c].clear();
    } else {
      chunk.numbers[c].clear();
      chunk.texts[c].assign(rows, std::string());
    }
  }
}

// The varied parameters of point `index`, shown as in the CSV, into columns 0.. of row `row`.
void SetParameterValues(const ParameterGrid& grid,
                        std::size_t index,
                        std::size_t row,
                        std::vector<double>& values,
                        TableChunk& chunk) {
  grid.PointValues(index, values);
  for (std::size_t axis = 0; axis < values.size(); ++axis) {
    chunk.numbers[axis][row] = grid.axes()[axis].DisplayValue(values[axis]);
  }
}

class PointRecordReader final : public TableRecordReader {
 public:
  PointRecordReader(const ParameterGrid& grid, const std::filesystem::path& path)
      : grid_(grid), columns_(PointsTableColumns(grid)), file_(path) {}
  const std::vector<TableColumn>& columns() const override { return columns_; }
  std::size_t rows() const override { return grid_.num_points(); }
  void Rewind() override {
    file_.Rewind();
    next_ = 0;
  }
  std::size_t Read(std::size_t max_rows, TableChunk& chunk) override {
    const std::size_t count = std::min(max_rows, rows() - next_);
    ResetChunk(columns_, count, chunk);
    const std::size_t axes = grid_.axes().size();
    std::vector<double> values(axes);
    for (std::size_t row = 0; row < count; ++row, ++next_) {
      SetParameterValues(grid_, next_, row, values, chunk);
      const PointHead head = TakePointHead(file_.Next(kPointHeadBytes));
      std::string relative_degree(file_.Next(head.relative_degree_bytes),
                                  head.relative_degree_bytes);
      std::string error(file_.Next(head.error_bytes), head.error_bytes);
      // Columns after the parameters, in the order of PointsTableColumns.
      if (!head.ok) {
        chunk.texts[axes + 7][row] = std::move(error);
        continue;
      }
      chunk.texts[axes][row] = ToString(static_cast<Realization>(head.realization));
      chunk.numbers[axes + 1][row] = static_cast<double>(head.rank);
      if (head.internal_dynamics_order >= 0) {
        chunk.texts[axes + 2][row] = std::move(relative_degree);
        chunk.numbers[axes + 3][row] = head.differentiation_index;
        chunk.numbers[axes + 4][row] = head.internal_dynamics_order;
      }
      chunk.texts[axes + 5][row] = ToString(static_cast<Stability>(head.stability));
      chunk.numbers[axes + 6][row] = head.max_real_part;
    }
    if (next_ == rows() && !file_.AtEnd()) {
      throw Error(file_.path().string() + ": more records than the grid has points");
    }
    return count;
  }

 private:
  const ParameterGrid& grid_;
  std::vector<TableColumn> columns_;
  RecordFile file_;
  std::size_t next_ = 0;
};

class EigenvalueRecordReader final : public TableRecordReader {
 public:
  EigenvalueRecordReader(const ParameterGrid& grid, const std::filesystem::path& path)
      : grid_(grid), columns_(EigenvaluesTableColumns(grid)), file_(path) {
    if (file_.size() % kEigenvalueRecordBytes != 0) {
      throw Error(path.string() + ": the sweep's records end in the middle of a row; delete " +
                  "the output directory to start the sweep again");
    }
  }
  const std::vector<TableColumn>& columns() const override { return columns_; }
  std::size_t rows() const override {
    return static_cast<std::size_t>(file_.size() / kEigenvalueRecordBytes);
  }
  void Rewind() override {
    file_.Rewind();
    next_ = 0;
  }
  std::size_t Read(std::size_t max_rows, TableChunk& chunk) override {
    const std::size_t count = std::min(max_rows, rows() - next_);
    ResetChunk(columns_, count, chunk);
    const std::size_t axes = grid_.axes().size();
    std::vector<double> values(axes);
    for (std::size_t row = 0; row < count; ++row, ++next_) {
      const char* record = file_.Next(kEigenvalueRecordBytes);
      const auto point = Take<std::uint64_t>(record);
      const auto k = Take<std::uint64_t>(record);
      const double re = Take<double>(record);
      const double im = Take<double>(record);
      if (point >= grid_.num_points()) {
        throw Error(file_.path().string() + ": a record names point " + std::to_string(point) +
                    ", outside the grid");
      }
      SetParameterValues(grid_, static_cast<std::size_t>(point), row, values, chunk);
      const Mode mode = ModeOf({re, im});
      chunk.numbers[axes][row] = static_cast<double>(k);
      chunk.numbers[axes + 1][row] = re;
      chunk.numbers[axes + 2][row] = im;
      chunk.numbers[axes + 3][row] = mode.frequency_hz;
      chunk.numbers[axes + 4][row] = mode.damping_ratio;
    }
    return count;
  }

 private:
  const ParameterGrid& grid_;
  std::vector<TableColumn> columns_;
  RecordFile file_;
  std::size_t next_ = 0;
};

}  // namespace

void AppendRecordRows(std::size_t first,
                      std::span<const SweepPoint> points,
                      std::string& points_records,
                      std::string& eigenvalue_records) {
  std::string relative_degree;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const SweepPoint& point = points[i];
    relative_degree = point.ok ? JoinRelativeDegrees(point.relative_degree) : std::string();
    const std::string& error = point.ok ? std::string() : point.error;
    PointHead head;
    head.max_real_part = point.max_real_part;
    head.rank = point.rank;
    head.differentiation_index = point.differentiation_index;
    head.internal_dynamics_order = point.internal_dynamics_order;
    head.relative_degree_bytes = static_cast<std::uint32_t>(relative_degree.size());
    head.error_bytes = static_cast<std::uint32_t>(error.size());
    head.ok = point.ok ? 1 : 0;
    head.realization = static_cast<std::uint8_t>(point.realization);
    head.stability = static_cast<std::uint8_t>(point.stability);
    PutPointHead(points_records, head);
    points_records += relative_degree;
    points_records += error;
    for (std::size_t k = 0; k < point.eigenvalues.size(); ++k) {
      Put(eigenvalue_records, static_cast<std::uint64_t>(first + i));
      Put(eigenvalue_records, static_cast<std::uint64_t>(k));
      Put(eigenvalue_records, point.eigenvalues[k].real());
      Put(eigenvalue_records, point.eigenvalues[k].imag());
    }
  }
}

std::unique_ptr<TableRecordReader> OpenPointRecords(const ParameterGrid& grid,
                                                    const std::filesystem::path& path) {
  return std::make_unique<PointRecordReader>(grid, path);
}

std::unique_ptr<TableRecordReader> OpenEigenvalueRecords(const ParameterGrid& grid,
                                                         const std::filesystem::path& path) {
  return std::make_unique<EigenvalueRecordReader>(grid, path);
}

}  // namespace servokit
