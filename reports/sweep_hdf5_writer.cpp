#include <fcntl.h>
#include <hdf5.h>

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "models/errors.h"
#include "reports/data_files_plugin.h"
#include "reports/sweep_hdf5.h"

namespace servokit {
namespace {

// Rows written per H5Dwrite: large enough that HDF5's per-call cost vanishes, small enough that
// a chunk of a 10^8-point sweep fits in memory many times over.
constexpr std::size_t kRowsPerWrite = std::size_t{1} << 16;

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

// The width of each text column: its longest value (at least 1: HDF5 has no empty string type).
std::vector<std::size_t> TextWidths(TableRecordReader& table) {
  std::vector<std::size_t> widths = table.TextWidths();
  for (std::size_t& width : widths) width = std::max<std::size_t>(width, 1);
  return widths;
}

// The file type of column c: a double, or a NUL-padded ASCII string of its width.
Handle ColumnType(const TableColumn& column, std::size_t width, const std::filesystem::path& path) {
  if (column.kind == ColumnKind::kNumber) {
    return Handle(H5Tcopy(H5T_IEEE_F64LE), H5Tclose, path, "make a number type");
  }
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, path, "make a string type");
  Check(H5Tset_size(type.get(), width), path, "make a string type");
  Check(H5Tset_strpad(type.get(), H5T_STR_NULLPAD), path, "make a string type");
  return type;
}

// Starts writing the file's dirty pages to disk without waiting, so that the caller's fsync at
// the end finds little left and the disk works while the next rows are decoded. Advisory: the
// fsync that follows is what counts.
void StartWriteback(hid_t file) {
  void* handle = nullptr;
  if (H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 || handle == nullptr) return;
  ::sync_file_range(*static_cast<int*>(handle), 0, 0, SYNC_FILE_RANGE_WRITE);  // sec2 driver
}

void WriteTable(hid_t file,
                const char* name,
                TableRecordReader& table,
                const std::filesystem::path& path) {
  const std::vector<TableColumn>& columns = table.columns();
  const std::vector<std::size_t> widths = TextWidths(table);
  const Handle group_properties = UntimedObjectProperties(H5P_GROUP_CREATE, path);
  // Links kept in creation order, so that h5py lists the columns in table order.
  Check(H5Pset_link_creation_order(group_properties.get(),
                                   H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED),
        path, "track the order of the columns");
  Handle group(H5Gcreate2(file, name, H5P_DEFAULT, group_properties.get(), H5P_DEFAULT), H5Gclose,
               path, "create a group");
  const std::vector<std::string> names = ColumnNames(columns);
  WriteStringListAttribute(group.get(), "columns", names, path);

  const hsize_t rows = table.rows();
  Handle file_space(H5Screate_simple(1, &rows, nullptr), H5Sclose, path, "make a dataspace");
  const Handle dataset_properties = UntimedObjectProperties(H5P_DATASET_CREATE, path);
  // Every row is written: filling the datasets first would write them twice.
  Check(H5Pset_fill_time(dataset_properties.get(), H5D_FILL_TIME_NEVER), path,
        "turn fill values off");
  std::vector<Handle> datasets, types;
  datasets.reserve(columns.size());
  types.reserve(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) {
    types.push_back(ColumnType(columns[c], widths[c], path));
    datasets.emplace_back(
        H5Dcreate2(group.get(), names[c].c_str(), types.back().get(), file_space.get(), H5P_DEFAULT,
                   dataset_properties.get(), H5P_DEFAULT),
        H5Dclose, path, "create a dataset");
    WriteStringAttribute(datasets.back().get(), "unit", columns[c].unit, path);
  }

  TableChunk chunk;
  std::string text_buffer;
  hsize_t start = 0;
  while (const std::size_t count = table.Read(kRowsPerWrite, chunk)) {
    const hsize_t block = count;
    Handle memory_space(H5Screate_simple(1, &block, nullptr), H5Sclose, path, "make a dataspace");
    Check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, &start, nullptr, &block, nullptr),
          path, "select rows");
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const void* data = nullptr;
      hid_t memory_type = H5T_NATIVE_DOUBLE;
      if (columns[c].kind == ColumnKind::kNumber) {
        data = chunk.numbers[c].data();
      } else {
        // Each value NUL-padded to the column's width, as the file holds it.
        text_buffer.assign(count * widths[c], '\0');
        for (std::size_t row = 0; row < count; ++row) {
          chunk.texts[c][row].copy(text_buffer.data() + row * widths[c], widths[c]);
        }
        data = text_buffer.data();
        memory_type = types[c].get();
      }
      Check(H5Dwrite(datasets[c].get(), memory_type, memory_space.get(), file_space.get(),
                     H5P_DEFAULT, data),
            path, "write a column");
    }
    start += block;
    StartWriteback(file);
  }
}

}  // namespace

void WriteSweepHdf5File(const std::filesystem::path& path,
                        const SweepFileMetadata& metadata,
                        TableRecordReader& points,
                        TableRecordReader& eigenvalues) {
  // HDF5 prints its own error stack by default; the Error thrown here says what failed.
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Handle access(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, path, "create a property list");
  // Fixed format versions: a newer library must not write other bytes (or a file older readers,
  // such as MATLAB's, cannot open).
  Check(H5Pset_libver_bounds(access.get(), H5F_LIBVER_V18, H5F_LIBVER_V18), path,
        "fix the format version");
  // The root group is created with the file: its times are turned off in the file's creation
  // properties (a kind of group creation properties).
  const Handle creation = UntimedObjectProperties(H5P_FILE_CREATE, path);
  Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, creation.get(), access.get()), H5Fclose, path,
              "create the file");
  WriteStringAttribute(file.get(), "model", metadata.model, path);
  WriteStringAttribute(file.get(), "model_content_hash", metadata.content_hash, path);
  WriteStringAttribute(file.get(), "grid", metadata.grid, path);
  WriteStringAttribute(file.get(), "servokit_version", metadata.servokit_version, path);
  WriteTable(file.get(), "points", points, path);
  WriteTable(file.get(), "eigenvalues", eigenvalues, path);
  Check(H5Fflush(file.get(), H5F_SCOPE_GLOBAL), path, "write the file");
}

extern "C" const DataFilesPlugin* servokit_data_files_plugin() {
  static const DataFilesPlugin plugin = {&WriteSweepHdf5File, &CreateMatioFile};
  return &plugin;
}

}  // namespace servokit
