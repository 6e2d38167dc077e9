#include "reports/sweep_records.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cassert>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <string_view>
#include <utility>

#include "analysis/zero_dynamics.h"
#include "base/errors.h"
#include "base/vocabulary.h"

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

// Writes `head` into the kPointHeadBytes at `bytes`, its padding zero.
void EncodePointHead(const PointHead& head, char* bytes) {
  const auto put = [&bytes](const auto& value) {
    std::memcpy(bytes, &value, sizeof(value));
    bytes += sizeof(value);
  };
  const char* const end = bytes + kPointHeadBytes;
  put(head.max_real_part);
  put(head.rank);
  put(head.differentiation_index);
  put(head.internal_dynamics_order);
  put(head.relative_degree_bytes);
  put(head.error_bytes);
  put(head.ok);
  put(head.realization);
  put(head.stability);
  std::memset(bytes, 0, static_cast<std::size_t>(end - bytes));
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

// Records read in place, without copies: a records file mapped into memory, or records a sweep
// holds in memory (a block's, not yet in a file).
class RecordBytes {
 public:
  explicit RecordBytes(const std::filesystem::path& path) : path_(path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw Error(path.string() + ": cannot read: " + std::strerror(errno));
    struct stat status = {};
    if (::fstat(fd, &status) != 0) {
      ::close(fd);
      throw Error(path.string() + ": cannot read: " + std::strerror(errno));
    }
    size_ = static_cast<std::size_t>(status.st_size);
    if (size_ > 0) {
      void* data = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
      if (data == MAP_FAILED) {
        ::close(fd);
        throw Error(path.string() + ": cannot map: " + std::strerror(errno));
      }
      data_ = static_cast<const char*>(data);
      mapped_ = true;
      ::madvise(data, size_, MADV_SEQUENTIAL);  // advisory: read ahead
    }
    ::close(fd);  // the mapping stays valid
  }
  // `bytes` must outlive this; `what` names them in errors.
  RecordBytes(std::string_view bytes, const std::filesystem::path& what)
      : path_(what), data_(bytes.data()), size_(bytes.size()) {}
  ~RecordBytes() {
    if (mapped_) ::munmap(const_cast<char*>(data_), size_);
  }
  RecordBytes(const RecordBytes&) = delete;
  RecordBytes& operator=(const RecordBytes&) = delete;

  std::size_t size() const { return size_; }
  void Rewind() { position_ = 0; }
  // The next `bytes` bytes, in place.
  const char* Next(std::size_t bytes) {
    if (size_ - position_ < bytes) {
      throw Error(path_.string() + ": the sweep's records end in the middle of a row; delete " +
                  "the output directory to start the sweep again");
    }
    const char* next = data_ + position_;
    position_ += bytes;
    return next;
  }
  bool AtEnd() const { return position_ == size_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  const char* data_ = nullptr;
  std::size_t size_ = 0;
  std::size_t position_ = 0;
  bool mapped_ = false;
};

// Sizes `chunk` for `rows` rows of `columns`; the reader sets every cell. Text cells keep their
// strings' storage from chunk to chunk.
void ResetChunk(const std::vector<TableColumn>& columns, std::size_t rows, TableChunk& chunk) {
  chunk.rows = rows;
  chunk.numbers.resize(columns.size());
  chunk.texts.resize(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) {
    if (columns[c].kind == ColumnKind::kNumber) {
      chunk.numbers[c].resize(rows);
      chunk.texts[c].clear();
    } else {
      chunk.numbers[c].clear();
      chunk.texts[c].resize(rows);
    }
  }
}

// The varied parameters of every point, shown as in the CSV (GridAxis::Value, DisplayValue),
// from a table of each axis's values: a point's values are looked up, not computed.
class DisplayedValues {
 public:
  explicit DisplayedValues(const ParameterGrid& grid) {
    for (const GridAxis& axis : grid.axes()) {
      std::vector<double>& values = axes_.emplace_back(axis.size());
      for (std::size_t i = 0; i < values.size(); ++i) {
        values[i] = axis.DisplayValue(axis.Value(i));
      }
    }
  }
  // Point `index`'s values into columns 0.. of row `row` (row-major: the last axis fastest).
  void Set(std::size_t index, std::size_t row, TableChunk& chunk) const {
    for (std::size_t k = axes_.size(); k-- > 0;) {
      const std::size_t size = axes_[k].size();
      chunk.numbers[k][row] = axes_[k][index % size];
      index /= size;
    }
  }

 private:
  std::vector<std::vector<double>> axes_;
};

// The number of point records in `records`, from its position on, which it leaves unchanged.
std::size_t CountPointRecords(RecordBytes& records) {
  std::size_t count = 0;
  while (!records.AtEnd()) {
    const PointHead head = TakePointHead(records.Next(kPointHeadBytes));
    records.Next(std::size_t{head.relative_degree_bytes} + head.error_bytes);
    ++count;
  }
  return count;
}

// Rows 0.. of `chunk` (sized for `count` rows) from the next `count` point records, the first of
// them point `first`. Columns after the parameters in the order of PointsTableColumns; empty CSV
// fields are NaN and "".
void DecodePointRows(const DisplayedValues& values,
                     std::size_t axes,
                     RecordBytes& records,
                     std::size_t first,
                     std::size_t count,
                     TableChunk& chunk) {
  for (std::size_t row = 0; row < count; ++row) {
    values.Set(first + row, row, chunk);
    const PointHead head = TakePointHead(records.Next(kPointHeadBytes));
    const std::size_t relative_degree_bytes = head.relative_degree_bytes;
    const char* relative_degree = records.Next(relative_degree_bytes + head.error_bytes);
    const char* error = relative_degree + relative_degree_bytes;
    const bool ok = head.ok != 0;
    const bool structure = ok && head.internal_dynamics_order >= 0;
    chunk.texts[axes][row] =
        ok ? ToString(static_cast<Realization>(head.realization)) : std::string_view();
    chunk.numbers[axes + 1][row] = ok ? static_cast<double>(head.rank) : kNone;
    chunk.texts[axes + 2][row] = {relative_degree, structure ? relative_degree_bytes : 0};
    chunk.numbers[axes + 3][row] = structure ? head.differentiation_index : kNone;
    chunk.numbers[axes + 4][row] = structure ? head.internal_dynamics_order : kNone;
    chunk.texts[axes + 5][row] =
        ok ? ToString(static_cast<Stability>(head.stability)) : std::string_view();
    chunk.numbers[axes + 6][row] = ok ? head.max_real_part : kNone;
    chunk.texts[axes + 7][row] = {error, head.error_bytes};  // empty for a point with a solution
  }
}

// Rows 0.. of `chunk` (sized for `count` rows) from the next `count` eigenvalue records.
void DecodeEigenvalueRows(const DisplayedValues& values,
                          std::size_t axes,
                          std::size_t num_points,
                          RecordBytes& records,
                          std::size_t count,
                          TableChunk& chunk) {
  for (std::size_t row = 0; row < count; ++row) {
    const char* record = records.Next(kEigenvalueRecordBytes);
    const auto point = Take<std::uint64_t>(record);
    const auto k = Take<std::uint64_t>(record);
    const double re = Take<double>(record);
    const double im = Take<double>(record);
    if (point >= num_points) {
      throw Error(records.path().string() + ": a record names point " + std::to_string(point) +
                  ", outside the grid");
    }
    values.Set(static_cast<std::size_t>(point), row, chunk);
    const Mode mode = ModeOf({re, im});
    chunk.numbers[axes][row] = static_cast<double>(k);
    chunk.numbers[axes + 1][row] = re;
    chunk.numbers[axes + 2][row] = im;
    chunk.numbers[axes + 3][row] = mode.frequency_hz;
    chunk.numbers[axes + 4][row] = mode.damping_ratio;
  }
}

void CheckWholeEigenvalueRecords(const RecordBytes& records) {
  if (records.size() % kEigenvalueRecordBytes != 0) {
    throw Error(records.path().string() + ": the sweep's records end in the middle of a row; " +
                "delete the output directory to start the sweep again");
  }
}

class PointRecordReader final : public TableRecordReader {
 public:
  PointRecordReader(const ParameterGrid& grid, const std::filesystem::path& path, std::size_t rows)
      : grid_(grid), columns_(PointsTableColumns(grid)), values_(grid), file_(path), rows_(rows) {}
  const std::vector<TableColumn>& columns() const override { return columns_; }
  std::size_t rows() const override { return rows_; }
  void Rewind() override {
    file_.Rewind();
    next_ = 0;
  }
  std::vector<std::size_t> TextWidths() override {
    const std::size_t axes = grid_.axes().size();
    std::vector<std::size_t> widths(columns_.size(), 0);
    Rewind();
    for (std::size_t i = 0; i < rows(); ++i) {
      const PointHead head = TakePointHead(file_.Next(kPointHeadBytes));
      file_.Next(std::size_t{head.relative_degree_bytes} + head.error_bytes);
      if (head.ok == 0) {
        widths[axes + 7] = std::max<std::size_t>(widths[axes + 7], head.error_bytes);
        continue;
      }
      widths[axes] =
          std::max(widths[axes], ToString(static_cast<Realization>(head.realization)).size());
      if (head.internal_dynamics_order >= 0) {
        widths[axes + 2] = std::max<std::size_t>(widths[axes + 2], head.relative_degree_bytes);
      }
      widths[axes + 5] =
          std::max(widths[axes + 5], ToString(static_cast<Stability>(head.stability)).size());
    }
    Rewind();
    return widths;
  }
  std::size_t Read(std::size_t max_rows, TableChunk& chunk) override {
    const std::size_t count = std::min(max_rows, rows() - next_);
    ResetChunk(columns_, count, chunk);
    DecodePointRows(values_, grid_.axes().size(), file_, next_, count, chunk);
    next_ += count;
    if (next_ == rows() && !file_.AtEnd()) {
      throw Error(file_.path().string() + ": more records than the sweep has points");
    }
    return count;
  }

 private:
  const ParameterGrid& grid_;
  std::vector<TableColumn> columns_;
  DisplayedValues values_;
  RecordBytes file_;
  std::size_t rows_;
  std::size_t next_ = 0;
};

class EigenvalueRecordReader final : public TableRecordReader {
 public:
  EigenvalueRecordReader(const ParameterGrid& grid, const std::filesystem::path& path)
      : grid_(grid), columns_(EigenvaluesTableColumns(grid)), values_(grid), file_(path) {
    CheckWholeEigenvalueRecords(file_);
  }
  const std::vector<TableColumn>& columns() const override { return columns_; }
  std::size_t rows() const override {
    return static_cast<std::size_t>(file_.size() / kEigenvalueRecordBytes);
  }
  void Rewind() override {
    file_.Rewind();
    next_ = 0;
  }
  std::vector<std::size_t> TextWidths() override {
    Rewind();
    return std::vector<std::size_t>(columns_.size(), 0);  // numbers only
  }
  std::size_t Read(std::size_t max_rows, TableChunk& chunk) override {
    const std::size_t count = std::min(max_rows, rows() - next_);
    ResetChunk(columns_, count, chunk);
    DecodeEigenvalueRows(values_, grid_.axes().size(), grid_.num_points(), file_, count, chunk);
    next_ += count;
    return count;
  }

 private:
  const ParameterGrid& grid_;
  std::vector<TableColumn> columns_;
  DisplayedValues values_;
  RecordBytes file_;
  std::size_t next_ = 0;
};

}  // namespace

void AppendRecordRows(std::size_t first,
                      std::span<const SweepPoint> points,
                      std::string& points_records,
                      std::string& eigenvalue_records) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    const SweepPoint& point = points[i];
    // Room for the head first; it is written once the texts after it have their lengths.
    const std::size_t head_at = points_records.size();
    PointHead head;
    head.max_real_part = point.max_real_part;
    head.rank = point.rank;
    head.differentiation_index = point.differentiation_index;
    head.internal_dynamics_order = point.internal_dynamics_order;
    head.ok = point.ok ? 1 : 0;
    head.realization = static_cast<std::uint8_t>(point.realization);
    head.stability = static_cast<std::uint8_t>(point.stability);
    points_records.append(kPointHeadBytes, '\0');
    if (point.ok) {
      AppendRelativeDegrees(points_records, point.relative_degree);
      head.relative_degree_bytes =
          static_cast<std::uint32_t>(points_records.size() - head_at - kPointHeadBytes);
    } else {
      points_records += point.error;
      head.error_bytes = static_cast<std::uint32_t>(point.error.size());
    }
    EncodePointHead(head, points_records.data() + head_at);
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
  return std::make_unique<PointRecordReader>(grid, path, grid.num_points());
}

std::unique_ptr<TableRecordReader> OpenPointRecords(const ParameterGrid& grid,
                                                    const std::filesystem::path& path,
                                                    std::size_t points) {
  return std::make_unique<PointRecordReader>(grid, path, points);
}

std::unique_ptr<TableRecordReader> OpenEigenvalueRecords(const ParameterGrid& grid,
                                                         const std::filesystem::path& path) {
  return std::make_unique<EigenvalueRecordReader>(grid, path);
}

struct RecordDecoder::DisplayedGrid : DisplayedValues {
  using DisplayedValues::DisplayedValues;
};

RecordDecoder::RecordDecoder(const ParameterGrid& grid)
    : grid_(grid),
      points_columns_(PointsTableColumns(grid)),
      eigenvalues_columns_(EigenvaluesTableColumns(grid)),
      values_(std::make_unique<DisplayedGrid>(grid)) {}

RecordDecoder::~RecordDecoder() = default;

std::size_t RecordDecoder::DecodePoints(std::string_view records,
                                        std::size_t first,
                                        TableChunk& rows) const {
  RecordBytes bytes(records, "the sweep's point records");
  const std::size_t count = CountPointRecords(bytes);
  bytes.Rewind();
  ResetChunk(points_columns_, count, rows);
  DecodePointRows(*values_, grid_.axes().size(), bytes, first, count, rows);
  return count;
}

std::size_t RecordDecoder::DecodeEigenvalues(std::string_view records, TableChunk& rows) const {
  RecordBytes bytes(records, "the sweep's eigenvalue records");
  CheckWholeEigenvalueRecords(bytes);
  const std::size_t count = records.size() / kEigenvalueRecordBytes;
  ResetChunk(eigenvalues_columns_, count, rows);
  DecodeEigenvalueRows(*values_, grid_.axes().size(), grid_.num_points(), bytes, count, rows);
  return count;
}

}  // namespace servokit
