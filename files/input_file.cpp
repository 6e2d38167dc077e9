#include "files/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <utility>

#include "base/errors.h"

namespace servokit {
namespace {

// The files read so far, each as it was last read: device and inode, and the time of its last
// change then. A name can change, the file cannot; and an inode that a deleted input leaves free,
// taken by a new file later in a long-running process (a Python session), has another change
// time. One entry per file however often it is read: a file edited and read again replaces its
// entry (the older change time can never be the file's again), so that a process reading a
// changing file over and over does not grow (the fuzz targets, which rewrite one file per input,
// grew by an entry per input, and libFuzzer ran a leak check after each).
using FileKey = std::pair<dev_t, ino_t>;
using ChangeTime = std::pair<std::int64_t, std::int64_t>;

FileKey KeyOf(const struct stat& status) { return {status.st_dev, status.st_ino}; }

ChangeTime ChangeTimeOf(const struct stat& status) {
  return {status.st_ctim.tv_sec, status.st_ctim.tv_nsec};
}

class InputRegistry {
 public:
  void Add(const struct stat& status) {
    const std::lock_guard<std::mutex> lock(mutex_);
    files_[KeyOf(status)] = ChangeTimeOf(status);
  }
  bool Contains(const struct stat& status) const {
    const std::lock_guard<std::mutex> lock(mutex_);
    const auto found = files_.find(KeyOf(status));
    return found != files_.end() && found->second == ChangeTimeOf(status);
  }

 private:
  mutable std::mutex mutex_;
  std::map<FileKey, ChangeTime> files_;
};

InputRegistry& Inputs() {
  static InputRegistry registry;
  return registry;
}

class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }

 private:
  int fd_;
};

}  // namespace

std::optional<std::string> TryReadInputFile(const std::string& path,
                                            std::uintmax_t limit,
                                            std::string& reason) {
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer forever. It does
  // not change reads from a regular file, the only kind read below.
  const FileDescriptor file(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY));
  struct stat status {};
  if (file.get() < 0 || ::fstat(file.get(), &status) != 0) {
    reason = std::strerror(errno);
    return std::nullopt;
  }
  if (S_ISDIR(status.st_mode)) {
    reason = "a directory, not a file";
    return std::nullopt;
  }
  if (!S_ISREG(status.st_mode)) {
    reason = "not a regular file: a FIFO, socket or device";
    return std::nullopt;
  }
  const auto size = static_cast<std::uintmax_t>(status.st_size);
  if (size > limit) {
    reason = std::to_string(size) + " bytes, over the limit of " + std::to_string(limit) +
             " bytes for such a file";
    return std::nullopt;
  }
  std::string bytes(static_cast<std::size_t>(size), '\0');
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t count = ::read(file.get(), bytes.data() + done, bytes.size() - done);
    if (count < 0 && errno == EINTR) continue;
    if (count < 0) {
      reason = std::strerror(errno);
      return std::nullopt;
    }
    if (count == 0) break;  // it shrank while being read: take what is there
    done += static_cast<std::size_t>(count);
  }
  bytes.resize(done);
  Inputs().Add(status);
  return bytes;
}

std::string ReadInputFile(const std::string& path,
                          const std::string& role,
                          std::uintmax_t limit,
                          ErrorKind kind) {
  std::string reason;
  std::optional<std::string> bytes = TryReadInputFile(path, limit, reason);
  if (bytes) return std::move(*bytes);
  const std::string message = path + ": cannot read " + role + " (" + reason + ")";
  if (kind == ErrorKind::kModel) throw ModelError(message);
  throw UsageError(message);
}

bool IsInputFile(const std::string& path) {
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) return false;
  return Inputs().Contains(status);
}

}  // namespace servokit
