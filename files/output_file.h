#pragma once
// Output files, written whole or not at all, and only where they were asked for.
//
// An output is written to a temporary file that servokit creates itself beside the final name
// (exclusively: an existing file or link there is never opened), every write checked; Commit()
// flushes and syncs it, checks that it is still the file created here, and renames it over the
// final name. Until then the final name is untouched, so an interrupted run, a full disk or a
// failed write never leaves a truncated file under it; a temporary that was not committed is
// removed. The final name itself must be absent or a regular file that no input of this process
// came from: a link planted there, a FIFO, a device or a directory is refused, never followed or
// replaced.
#include <memory>
#include <ostream>
#include <string>
#include <string_view>

namespace servokit {

/// Refuses `path` as the name of an output, before any work is done: throws UsageError naming it
/// when it is empty, a symbolic link, a directory, a FIFO, socket or device, or a file this
/// process has read as an input (files/input_file.h). A missing file is a good output name.
void CheckOutputPath(const std::string& path);

/// Removes what a process killed while writing `path` through OutputFile left behind: the
/// regular files beside it named as OutputFile names its temporaries. Only for a caller that
/// knows no other process writes there (it holds a lock on the folder). Throws Error naming a
/// file it cannot remove.
void RemoveStaleOutputTemporaries(const std::string& path);

/// True when the file system holding `path` has no block left for this process (a library
/// writing by name may have been refused a write without saying so).
bool FileSystemFull(const std::string& path);

/// One output file (see the top of this header). Not copyable; use from one thread.
class OutputFile {
 public:
  /// Checks `path` (CheckOutputPath) and creates the temporary file beside it. Throws UsageError
  /// for a refused name, Error when the temporary cannot be created (naming `path`).
  explicit OutputFile(std::string path);
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;
  /// Removes the temporary file unless Commit() succeeded.
  ~OutputFile();

  /// The final name.
  const std::string& path() const { return path_; }
  /// The temporary file's name, for a library that writes a file by name (matio, HDF5,
  /// gnuplot). It may reopen and rewrite that file; Commit() checks that the name still holds
  /// the file created here.
  const std::string& temporary_path() const { return temporary_; }

  /// A buffered stream to the temporary file. A failed write throws Error naming the final
  /// file and the reason ("no space left on device") out of the stream operation.
  std::ostream& stream();
  /// Appends `bytes` (through the same buffer as stream()).
  void Write(std::string_view bytes);

  /// Flushes, syncs and closes the temporary file and renames it over path(). Throws Error,
  /// naming path(), when any of that fails, when the file system is full after the writes (a
  /// library writing by name may not have said so), or when the temporary name no longer holds
  /// the file created here; UsageError when path() has become a refused name meanwhile.
  void Commit();

 private:
  class Buffer;
  std::string path_;
  std::string temporary_;
  int fd_ = -1;
  bool committed_ = false;
  std::unique_ptr<Buffer> buffer_;
  std::unique_ptr<std::ostream> stream_;
};

/// A directory of servokit's own for a program that writes its outputs by name (gnuplot):
/// created exclusively beside the final outputs (mkdtemp: a fresh name, mode 0700, so nothing
/// can be planted in it), removed with whatever is left in it. Publish() moves a finished file
/// from it over its final name, checked as OutputFile::Commit() does.
class ScratchDirectory {
 public:
  /// Creates the directory inside `parent`. Throws Error naming `parent` when it cannot.
  explicit ScratchDirectory(const std::string& parent);
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;
  ~ScratchDirectory();

  const std::string& path() const { return path_; }
  /// Syncs the file `name` of this directory and renames it to `final_path` (CheckOutputPath
  /// first). Throws Error naming `final_path` when the file is missing or not a regular file,
  /// when the file system is full, or when the rename fails.
  void Publish(const std::string& name, const std::string& final_path) const;

 private:
  std::string path_;
};

}  // namespace servokit
