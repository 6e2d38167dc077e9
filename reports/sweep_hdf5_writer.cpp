#include <fcntl.h>
#include <hdf5.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "base/errors.h"
#include "reports/data_files_plugin.h"
#include "reports/sweep_hdf5.h"

namespace servokit {
namespace {

// Owns an HDF5 identifier and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle(hid_t id, Closer close, const std::filesystem::path& path, const char* what)
      : id_(id), close_(close) {
    if (id_ < 0) throw Error(path.string() + ": HDF5 failed to " + what);
  }
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, -1)), close_(other.close_) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle& operator=(Handle&&) = delete;
  hid_t get() const { return id_; }

 private:
  hid_t id_;
  Closer close_;
};

void Check(herr_t status, const std::filesystem::path& path, const char* what) {
  if (status < 0) throw Error(path.string() + ": HDF5 failed to " + what);
}

// Object creation properties that leave no time stamp in the file.
Handle UntimedObjectProperties(hid_t list_class, const std::filesystem::path& path) {
  Handle properties(H5Pcreate(list_class), H5Pclose, path, "create a property list");
  Check(H5Pset_obj_track_times(properties.get(), 0), path, "turn object times off");
  return properties;
}

void WriteStringAttribute(hid_t object,
                          const char* name,
                          const std::string& value,
                          const std::filesystem::path& path) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, path, "make a string type");
  Check(H5Tset_size(type.get(), H5T_VARIABLE), path, "make a string type");
  Check(H5Tset_cset(type.get(), H5T_CSET_UTF8), path, "make a string type");
  Handle space(H5Screate(H5S_SCALAR), H5Sclose, path, "make a dataspace");
  Handle attribute(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
                   H5Aclose, path, "create an attribute");
  const char* text = value.c_str();
  Check(H5Awrite(attribute.get(), type.get(), &text), path, "write an attribute");
}

void WriteStringListAttribute(hid_t object,
                              const char* name,
                              const std::vector<std::string>& values,
                              const std::filesystem::path& path) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, path, "make a string type");
  Check(H5Tset_size(type.get(), H5T_VARIABLE), path, "make a string type");
  Check(H5Tset_cset(type.get(), H5T_CSET_UTF8), path, "make a string type");
  const hsize_t count = values.size();
  Handle space(H5Screate_simple(1, &count, nullptr), H5Sclose, path, "make a dataspace");
  Handle attribute(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
                   H5Aclose, path, "create an attribute");
  std::vector<const char*> texts;
  for (const std::string& value : values) texts.push_back(value.c_str());
  Check(H5Awrite(attribute.get(), type.get(), texts.data()), path, "write an attribute");
}

// Rows per chunk of the eigenvalue datasets: 2^16 (512 KB of doubles, large enough that HDF5's
// cost per chunk vanishes), or the grid's point count when smaller, so that a small sweep's file
// is small. Rows are buffered as many at a time for every dataset.
constexpr std::size_t kMostRowsPerChunk = std::size_t{1} << 16;

// The file type of a column: a little-endian double, or a NUL-padded ASCII string of `width`.
Handle ColumnType(const TableColumn& column, std::size_t width, const std::filesystem::path& path) {
  if (column.kind == ColumnKind::kNumber) {
    return Handle(H5Tcopy(H5T_IEEE_F64LE), H5Tclose, path, "make a number type");
  }
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, path, "make a string type");
  Check(H5Tset_size(type.get(), width), path, "make a string type");
  Check(H5Tset_strpad(type.get(), H5T_STR_NULLPAD), path, "make a string type");
  return type;
}

// Starts writing the file's dirty pages to disk without waiting, so that the fsync at the end
// finds little left and the disk works while the sweep goes on. Advisory: the fsync counts.
void StartWriteback(hid_t file) {
  void* handle = nullptr;
  if (H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 || handle == nullptr) return;
  ::sync_file_range(*static_cast<int*>(handle), 0, 0, SYNC_FILE_RANGE_WRITE);  // sec2 driver
}

// Chunks are written as raw bytes (H5Dwrite_chunk), the doubles as this machine holds them.
static_assert(std::endian::native == std::endian::little, "sweep.h5 stores little-endian doubles");

// Some columns of a table, one 1-D dataset each. With a known number of rows the datasets are
// contiguous, their space allocated when they are created; otherwise chunked, growing a chunk at
// a time, each chunk written whole (H5Dwrite_chunk, bypassing HDF5's chunk cache) in row order.
// Either way rows are buffered a chunk at a time, and the calls into HDF5, and so the file's
// bytes, depend only on the rows appended, not on how they were split among the calls to Append.
// Only one table of a file may grow (allocate space) while rows are appended: the order in which
// two growing tables allocated their chunks would depend on how their rows were interleaved.
class TableColumns {
 public:
  // `columns` are the table's; `chosen` the indices of those to write, each a dataset of `group`
  // named after it; `widths` their element sizes (8 for a number, the string width for a text);
  // `rows` the table's rows when known.
  TableColumns(hid_t file,
               hid_t group,
               const std::vector<TableColumn>& columns,
               std::vector<std::size_t> chosen,
               const std::vector<std::size_t>& widths,
               std::optional<std::size_t> rows,
               std::size_t chunk_rows,
               const std::filesystem::path& path)
      : file_(file),
        chosen_(std::move(chosen)),
        contiguous_(rows.has_value()),
        chunk_rows_(chunk_rows),
        path_(path) {
    const hsize_t size = rows.value_or(0), unlimited = H5S_UNLIMITED, chunk = chunk_rows;
    const Handle space(H5Screate_simple(1, &size, contiguous_ ? nullptr : &unlimited), H5Sclose,
                       path, "make a dataspace");
    const Handle properties = UntimedObjectProperties(H5P_DATASET_CREATE, path);
    if (contiguous_) {
      Check(H5Pset_alloc_time(properties.get(), H5D_ALLOC_TIME_EARLY), path,
            "allocate the dataset");
    } else {
      Check(H5Pset_chunk(properties.get(), 1, &chunk), path, "set the chunk size");
    }
    // Every row is written (a last chunk padded with zeros): filling the datasets first would
    // write them twice.
    Check(H5Pset_fill_time(properties.get(), H5D_FILL_TIME_NEVER), path, "turn fill values off");
    for (std::size_t i = 0; i < chosen_.size(); ++i) {
      const TableColumn& column = columns[chosen_[i]];
      types_.push_back(ColumnType(column, widths[i], path));
      datasets_.emplace_back(H5Dcreate2(group, column.name.c_str(), types_.back().get(),
                                        space.get(), H5P_DEFAULT, properties.get(), H5P_DEFAULT),
                             H5Dclose, path, "create a dataset");
      WriteStringAttribute(datasets_.back().get(), "unit", column.unit, path);
      kinds_.push_back(column.kind);
      widths_.push_back(widths[i]);
      buffers_.emplace_back(chunk_rows * widths[i], '\0');
    }
  }

  void Append(const TableChunk& rows) {
    for (std::size_t row = 0; row < rows.rows;) {
      const std::size_t take = std::min(rows.rows - row, chunk_rows_ - buffered_);
      for (std::size_t i = 0; i < chosen_.size(); ++i) {
        char* out = buffers_[i].data() + buffered_ * widths_[i];
        const std::size_t c = chosen_[i];
        if (kinds_[i] == ColumnKind::kNumber) {
          std::memcpy(out, rows.numbers[c].data() + row, take * sizeof(double));
          continue;
        }
        // The buffer is all zeros here (WriteChunk clears it): only the text's bytes are copied.
        for (std::size_t r = row; r < row + take; ++r, out += widths_[i]) {
          const std::string_view text = rows.texts[c][r];
          if (text.size() > widths_[i]) {
            throw Error(path_.string() + ": a value of the column " + std::to_string(c) +
                        " is wider than its dataset (" + std::string(text) + ")");
          }
          for (std::size_t k = 0; k < text.size(); ++k) out[k] = text[k];
        }
      }
      buffered_ += take;
      row += take;
      if (buffered_ == chunk_rows_) WriteChunk();
    }
  }

  // Writes the rows still buffered (a last, partial chunk).
  void Flush() {
    if (buffered_ > 0) WriteChunk();
  }

 private:
  void WriteChunk() {
    const hsize_t offset = written_, count = buffered_;
    const Handle memory(H5Screate_simple(1, &count, nullptr), H5Sclose, path_, "make a dataspace");
    for (std::size_t i = 0; i < chosen_.size(); ++i) {
      const hid_t dataset = datasets_[i].get();
      if (contiguous_) {
        const Handle file_space(H5Dget_space(dataset), H5Sclose, path_, "get a dataspace");
        Check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, &offset, nullptr, &count,
                                  nullptr),
              path_, "select rows");
        const hid_t memory_type =
            kinds_[i] == ColumnKind::kNumber ? H5T_NATIVE_DOUBLE : types_[i].get();
        Check(H5Dwrite(dataset, memory_type, memory.get(), file_space.get(), H5P_DEFAULT,
                       buffers_[i].data()),
              path_, "write a column");
        continue;
      }
      // A partial chunk is padded with zeros, so that the file's bytes are the same every time.
      if (kinds_[i] == ColumnKind::kNumber) {
        std::memset(buffers_[i].data() + buffered_ * widths_[i], 0,
                    (chunk_rows_ - buffered_) * widths_[i]);
      }
      const hsize_t extent = written_ + buffered_;
      Check(H5Dset_extent(dataset, &extent), path_, "extend a dataset");
      Check(
          H5Dwrite_chunk(dataset, H5P_DEFAULT, 0, &offset, buffers_[i].size(), buffers_[i].data()),
          path_, "write a chunk");
    }
    for (std::size_t i = 0; i < chosen_.size(); ++i) {
      if (kinds_[i] == ColumnKind::kText) {
        std::memset(buffers_[i].data(), 0, buffered_ * widths_[i]);  // the NULs of the padding
      }
    }
    written_ += buffered_;
    buffered_ = 0;
    StartWriteback(file_);
  }

  hid_t file_;
  std::vector<std::size_t> chosen_;
  bool contiguous_;
  std::size_t chunk_rows_;
  std::filesystem::path path_;
  std::vector<Handle> types_, datasets_;
  std::vector<ColumnKind> kinds_;
  std::vector<std::size_t> widths_;
  std::vector<std::string> buffers_;  // a chunk of each column
  std::size_t buffered_ = 0;          // rows in the buffers
  std::size_t written_ = 0;           // rows in the file
};

// A group of the file, its columns listed in the attribute `columns`; h5py lists its datasets in
// creation order, which is the table's.
Handle CreateTableGroup(hid_t file,
                        const char* name,
                        const std::vector<TableColumn>& columns,
                        const std::filesystem::path& path) {
  const Handle group_properties = UntimedObjectProperties(H5P_GROUP_CREATE, path);
  Check(H5Pset_link_creation_order(group_properties.get(),
                                   H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED),
        path, "track the order of the columns");
  Handle group(H5Gcreate2(file, name, H5P_DEFAULT, group_properties.get(), H5P_DEFAULT), H5Gclose,
               path, "create a group");
  WriteStringListAttribute(group.get(), "columns", ColumnNames(columns), path);
  return group;
}

std::vector<std::size_t> Indices(std::size_t begin, std::size_t end) {
  std::vector<std::size_t> indices;
  for (std::size_t i = begin; i < end; ++i) indices.push_back(i);
  return indices;
}

// HDF5 prints its own error stack by default; the Errors thrown here say what failed. Debian's
// HDF5 is built thread-safe, where the setting is each thread's own: the file is created on one
// thread and written and closed on another, so every entry point sets it for its thread.
void SilenceHdf5Errors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

class Hdf5SweepFile final : public SweepHdf5Writer {
 public:
  Hdf5SweepFile(const std::filesystem::path& path,
                const SweepFileMetadata& metadata,
                const SweepHdf5Layout& layout)
      : path_(path),
        chunk_rows_(std::clamp<std::size_t>(layout.points, 1, kMostRowsPerChunk)),
        points_columns_(layout.points_columns),
        most_kept_error_bytes_(layout.most_kept_error_bytes),
        file_(Create(path, metadata)),
        points_group_(CreateTableGroup(file_.get(), "points", points_columns_, path)) {
    // Every column but the last, error, whose width only the finished sweep knows (Finish).
    std::vector<std::size_t> sizes;
    for (std::size_t c = 0; c + 1 < points_columns_.size(); ++c) {
      sizes.push_back(points_columns_[c].kind == ColumnKind::kNumber
                          ? sizeof(double)
                          : std::max<std::size_t>(layout.points_text_widths[c], 1));
    }
    points_.emplace(file_.get(), points_group_.get(), points_columns_, Indices(0, sizes.size()),
                    sizes, layout.points, chunk_rows_, path);
    const std::vector<TableColumn>& eigenvalues = layout.eigenvalues_columns;
    const Handle eigenvalues_group =
        CreateTableGroup(file_.get(), "eigenvalues", eigenvalues, path);
    eigenvalues_.emplace(file_.get(), eigenvalues_group.get(), eigenvalues,
                         Indices(0, eigenvalues.size()),
                         std::vector<std::size_t>(eigenvalues.size(), sizeof(double)), std::nullopt,
                         chunk_rows_, path);
  }

  // The handles close after this body: a close that fails (a full disk) says nothing.
  ~Hdf5SweepFile() override { SilenceHdf5Errors(); }
  Hdf5SweepFile(const Hdf5SweepFile&) = delete;
  Hdf5SweepFile& operator=(const Hdf5SweepFile&) = delete;

  void AppendPoints(const TableChunk& rows) override {
    SilenceHdf5Errors();
    points_->Append(rows);
    KeepErrors(rows);
  }
  void AppendEigenvalues(const TableChunk& rows) override {
    SilenceHdf5Errors();
    eigenvalues_->Append(rows);
  }

  void Finish(TableRecordReader& points) override {
    SilenceHdf5Errors();
    points_->Flush();
    eigenvalues_->Flush();
    const std::size_t error = points_columns_.size() - 1;
    if (errors_kept_) {
      TableColumns errors(file_.get(), points_group_.get(), points_columns_, {error},
                          {std::max<std::size_t>(error_width_, 1)}, points_appended_, chunk_rows_,
                          path_);
      TableChunk rows;
      rows.texts.resize(points_columns_.size());
      std::size_t next_error = 0;
      for (std::size_t first = 0; first < points_appended_; first += chunk_rows_) {
        rows.rows = std::min(chunk_rows_, points_appended_ - first);
        rows.texts[error].assign(rows.rows, std::string_view());
        for (; next_error < errors_.size() && errors_[next_error].first < first + rows.rows;
             ++next_error) {
          rows.texts[error][errors_[next_error].first - first] = errors_[next_error].second;
        }
        errors.Append(rows);
      }
      errors.Flush();
    } else {  // from the records
      const std::vector<std::size_t> widths = points.TextWidths();
      TableColumns errors(file_.get(), points_group_.get(), points_columns_, {error},
                          {std::max<std::size_t>(widths[error], 1)}, points.rows(), chunk_rows_,
                          path_);
      TableChunk rows;
      while (points.Read(chunk_rows_, rows) > 0) errors.Append(rows);
      errors.Flush();
    }
    Check(H5Fflush(file_.get(), H5F_SCOPE_GLOBAL), path_, "write the file");
  }

 private:
  static Handle Create(const std::filesystem::path& path, const SweepFileMetadata& metadata) {
    // No clean-up of HDF5's at exit: after a failed write (a full disk) the file cannot be
    // flushed, so its close fails and the handler would loop over it ("infinite loop closing
    // library") and crash; the Error thrown here has said what failed, and the temporary file
    // is not kept. It must come before any other HDF5 call.
    H5dont_atexit();
    SilenceHdf5Errors();
    Handle access(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, path, "create a property list");
    // Fixed format versions: a newer library must not write other bytes (or a file older
    // readers, such as MATLAB's, cannot open).
    Check(H5Pset_libver_bounds(access.get(), H5F_LIBVER_V18, H5F_LIBVER_V18), path,
          "fix the format version");
    // The root group is created with the file: its times are turned off in the file's creation
    // properties (a kind of group creation properties).
    const Handle creation = UntimedObjectProperties(H5P_FILE_CREATE, path);
    // Exclusive (O_CREAT | O_EXCL): a link planted at the name is never followed; the caller
    // removes a file a killed run left there.
    Handle file(H5Fcreate(path.c_str(), H5F_ACC_EXCL, creation.get(), access.get()), H5Fclose, path,
                "create the file");
    WriteStringAttribute(file.get(), "model", metadata.model, path);
    WriteStringAttribute(file.get(), "model_content_hash", metadata.content_hash, path);
    WriteStringAttribute(file.get(), "grid", metadata.grid, path);
    WriteStringAttribute(file.get(), "servokit_version", metadata.servokit_version, path);
    return file;
  }

  // The error texts of the points appended, kept while they take little memory
  // (SweepHdf5Layout::most_kept_error_bytes).
  void KeepErrors(const TableChunk& rows) {
    const std::size_t error = points_columns_.size() - 1;
    for (std::size_t row = 0; row < rows.rows && errors_kept_; ++row) {
      const std::string_view text = rows.texts[error][row];
      if (text.empty()) continue;
      error_bytes_ += text.size();
      error_width_ = std::max(error_width_, text.size());
      errors_.emplace_back(points_appended_ + row, std::string(text));
      if (error_bytes_ > most_kept_error_bytes_) {
        errors_kept_ = false;
        errors_.clear();
        errors_.shrink_to_fit();
      }
    }
    points_appended_ += rows.rows;
  }

  std::filesystem::path path_;
  std::size_t chunk_rows_;
  std::vector<TableColumn> points_columns_;
  std::size_t most_kept_error_bytes_;
  std::size_t points_appended_ = 0;
  bool errors_kept_ = true;
  std::size_t error_bytes_ = 0, error_width_ = 0;
  std::vector<std::pair<std::size_t, std::string>> errors_;  // (row, text), in row order
  Handle file_;
  Handle points_group_;
  std::optional<TableColumns> points_, eigenvalues_;
};

}  // namespace

std::unique_ptr<SweepHdf5Writer> CreateSweepHdf5File(const std::filesystem::path& path,
                                                     const SweepFileMetadata& metadata,
                                                     const SweepHdf5Layout& layout) {
  return std::make_unique<Hdf5SweepFile>(path, metadata, layout);
}

extern "C" const DataFilesPlugin* servokit_data_files_plugin() {
  static const DataFilesPlugin plugin = {&CreateSweepHdf5File, &CreateMatioFile};
  return &plugin;
}

}  // namespace servokit
