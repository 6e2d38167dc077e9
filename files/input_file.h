#pragma once
// Input files, read only when they are what they claim to be: a regular file of bounded size.
// A FIFO would block the read forever, /dev/zero never ends, and a multi-gigabyte file named by
// mistake would be loaded whole before any parser could object; each gets one line naming the
// file instead. Every file read here is remembered, so that no output may overwrite it
// (files/output_file.h).
#include <cstdint>
#include <optional>
#include <string>

#include "base/errors.h"

namespace servokit {

/// Size limits of the inputs, in bytes, each far above any real file of its kind and far below
/// the machine's memory.
// A model file is hand-written YAML: the largest shipped one is a few kilobytes, and a generated
// chain of 10^4 bodies about 2 MB.
inline constexpr std::uintmax_t kModelFileLimit = std::uintmax_t{64} << 20;
// A sampled trajectory or waypoint table: 10^6 samples of a few outputs are about 100 MB.
inline constexpr std::uintmax_t kTrajectoryFileLimit = std::uintmax_t{1} << 30;
// A Matrix Market file of a large flexible model: 10^7 unknowns with tens of non-zeros a row run
// to a few gigabytes; the matrices themselves must then fit in memory beside them.
inline constexpr std::uintmax_t kMatrixFileLimit = std::uintmax_t{16} << 30;
// A sweep's table read back (report --from): 10^7 points of about 150 bytes a row.
inline constexpr std::uintmax_t kTableFileLimit = std::uintmax_t{16} << 30;
// A sweep's own record (sweep.json) and the like: a few kilobytes.
inline constexpr std::uintmax_t kRecordFileLimit = std::uintmax_t{16} << 20;

/// The bytes of the file `path`. `role` names the file in messages ("the model file"). Throws,
/// as "PATH: cannot read ROLE (reason)", when it is not a regular file (a FIFO, a device, a
/// directory), when it is larger than `limit` bytes, or when it cannot be opened or read: a
/// ModelError for `kind` kModel (a file the model names), else a UsageError.
std::string ReadInputFile(const std::string& path,
                          const std::string& role,
                          std::uintmax_t limit,
                          ErrorKind kind = ErrorKind::kUsage);

/// As ReadInputFile, for a caller that words its own message: nullopt, with the reason in
/// `reason` ("No such file or directory", "not a regular file: ..."), where that would throw.
std::optional<std::string> TryReadInputFile(const std::string& path,
                                            std::uintmax_t limit,
                                            std::string& reason);

/// True when `path` names a file that this process has read through ReadInputFile, unchanged
/// since (the same device, inode and change time, whatever the name).
bool IsInputFile(const std::string& path);

}  // namespace servokit
