#include "files/output_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <streambuf>
#include <vector>

#include "base/errors.h"
#include "files/input_file.h"

namespace servokit {
namespace {

[[noreturn]] void FailWriting(const std::string& path, int error) {
  // strerror(ENOSPC) is "No space left on device": the words a user looks for.
  throw Error("cannot write " + path + ": " + std::strerror(error));
}

// Writes all of `bytes` to `fd`, retrying short writes and interruptions.
void WriteAll(int fd, const char* bytes, std::size_t size, const std::string& path) {
  while (size > 0) {
    const ssize_t count = ::write(fd, bytes, size);
    if (count < 0) {
      if (errno == EINTR) continue;
      FailWriting(path, errno);
    }
    bytes += count;
    size -= static_cast<std::size_t>(count);
  }
}

// The temporary file's name for `final_path`, for mkostemp: hidden, beside the final name (a
// rename within one file system is atomic), unique once mkostemp has filled in the X's. Of a final
// name near the longest a file name may be (NAME_MAX bytes) only the start is kept, so that any
// name the file system takes as an output gets a temporary too.
std::string TemporaryPattern(const std::filesystem::path& final_path) {
  constexpr std::string_view kPrefix = ".", kSuffix = ".XXXXXX";
  std::string stem = final_path.filename().string();
  stem.resize(std::min(stem.size(), std::size_t{NAME_MAX} - kPrefix.size() - kSuffix.size()));
  return (final_path.parent_path() / (std::string(kPrefix) + stem + std::string(kSuffix))).string();
}

std::string DirectoryOf(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

}  // namespace

void RemoveStaleOutputTemporaries(const std::string& path) {
  // TemporaryPattern's name without its six X's, which mkostemp filled in.
  const std::string pattern = std::filesystem::path(TemporaryPattern(path)).filename().string();
  const std::string prefix = pattern.substr(0, pattern.size() - 6);
  const std::filesystem::path folder = std::filesystem::path(DirectoryOf(path));
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.size() != pattern.size() || name.compare(0, prefix.size(), prefix) != 0 ||
        entry.is_symlink() || !entry.is_regular_file()) {
      continue;
    }
    std::error_code error;
    std::filesystem::remove(entry.path(), error);
    if (error) throw Error(entry.path().string() + ": cannot remove: " + error.message());
  }
}

// The stream's buffer: 64 KiB, written through WriteAll when full or flushed.
class OutputFile::Buffer final : public std::streambuf {
 public:
  Buffer(int fd, const std::string& path) : fd_(fd), path_(path), bytes_(std::size_t{1} << 16) {
    setp(bytes_.data(), bytes_.data() + bytes_.size());
  }

 protected:
  int_type overflow(int_type c) override {
    Drain();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  int sync() override {
    Drain();
    return 0;
  }

 private:
  void Drain() {
    const std::size_t size = static_cast<std::size_t>(pptr() - pbase());
    setp(bytes_.data(), bytes_.data() + bytes_.size());  // emptied even when the write fails
    WriteAll(fd_, bytes_.data(), size, path_);
  }

  int fd_;
  const std::string& path_;
  std::vector<char> bytes_;
};

bool FileSystemFull(const std::string& path) {
  struct statvfs space {};
  if (::statvfs(path.c_str(), &space) != 0) return false;
  // root may use the blocks reserved for it; others may not.
  return (::geteuid() == 0 ? space.f_bfree : space.f_bavail) == 0;
}

void CheckOutputPath(const std::string& path) {
  if (path.empty()) throw UsageError("an output file name is empty");
  struct stat status {};
  if (::lstat(path.c_str(), &status) != 0) {
    if (errno == ENOENT) return;
    throw UsageError(path + ": cannot be an output (" + std::strerror(errno) + ")");
  }
  if (S_ISLNK(status.st_mode)) {
    throw UsageError(path + ": is a symbolic link; servokit does not write through links");
  }
  if (S_ISDIR(status.st_mode)) throw UsageError(path + ": is a directory, not a file");
  if (!S_ISREG(status.st_mode)) {
    throw UsageError(path + ": is not a regular file (a FIFO, socket or device); not replaced");
  }
  if (IsInputFile(path)) {
    throw UsageError(path + ": is an input of this run (the model, a matrix or a trajectory); " +
                     "not overwritten");
  }
}

OutputFile::OutputFile(std::string path) : path_(std::move(path)) {
  CheckOutputPath(path_);
  // mkostemp creates it with O_CREAT | O_EXCL, which fails on anything already there, links
  // included.
  std::string pattern = TemporaryPattern(path_);
  fd_ = ::mkostemp(pattern.data(), O_CLOEXEC);
  if (fd_ < 0) FailWriting(path_, errno);
  temporary_ = pattern;
  ::fchmod(fd_, 0644);  // mkostemp makes 0600; an output is as readable as any other file
  buffer_ = std::make_unique<Buffer>(fd_, path_);
  stream_ = std::make_unique<std::ostream>(buffer_.get());
  // A failed write throws out of the stream operation (the buffer's Error, rethrown).
  stream_->exceptions(std::ios::badbit);
}

OutputFile::~OutputFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !temporary_.empty()) ::unlink(temporary_.c_str());
}

std::ostream& OutputFile::stream() { return *stream_; }

void OutputFile::Write(std::string_view bytes) {
  stream_->write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

void OutputFile::Commit() {
  stream_->flush();
  // The name must still hold the file made here: a library writing by name truncates and
  // rewrites it in place; anything else (a link put there, a new file) is not ours to rename.
  struct stat ours {
  }, named{};
  if (::fstat(fd_, &ours) != 0) FailWriting(path_, errno);
  if (::lstat(temporary_.c_str(), &named) != 0 || !S_ISREG(named.st_mode) ||
      named.st_dev != ours.st_dev || named.st_ino != ours.st_ino) {
    throw Error("cannot write " + path_ + ": its temporary file " + temporary_ +
                " was replaced while being written");
  }
  if (::fsync(fd_) != 0) FailWriting(path_, errno);
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) FailWriting(path_, errno);
  if (FileSystemFull(temporary_)) FailWriting(path_, ENOSPC);
  CheckOutputPath(path_);
  if (::rename(temporary_.c_str(), path_.c_str()) != 0) FailWriting(path_, errno);
  committed_ = true;
  // The rename made durable too, so that a crash right after leaves the new file, not none.
  const int directory = ::open(DirectoryOf(path_).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (directory >= 0) {
    ::fsync(directory);
    ::close(directory);
  }
}

ScratchDirectory::ScratchDirectory(const std::string& parent) {
  std::string pattern = (std::filesystem::path(parent) / ".servokit.XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw Error("cannot write into " + parent + ": " + std::strerror(errno));
  }
  path_ = pattern;
}

ScratchDirectory::~ScratchDirectory() {
  std::error_code ignored;  // what is left is abandoned; its removal may fail quietly
  std::filesystem::remove_all(path_, ignored);
}

void ScratchDirectory::Publish(const std::string& name, const std::string& final_path) const {
  const std::string source = path_ + "/" + name;
  const int fd = ::open(source.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) FailWriting(final_path, errno);
  struct stat status {};
  const bool regular = ::fstat(fd, &status) == 0 && S_ISREG(status.st_mode);
  const int synced = regular ? ::fsync(fd) : 0;
  const int error = errno;
  ::close(fd);
  if (!regular) throw Error("cannot write " + final_path + ": not written as a regular file");
  if (synced != 0) FailWriting(final_path, error);
  if (FileSystemFull(source)) FailWriting(final_path, ENOSPC);
  CheckOutputPath(final_path);
  if (::rename(source.c_str(), final_path.c_str()) != 0) FailWriting(final_path, errno);
}

}  // namespace servokit
