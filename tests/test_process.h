#pragma once
// Child processes for tests that run a real binary (servokit, mpirun, timeout): started in a
// directory with stdout and stderr in files there, waited for, and their output read back.
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "tests/test_files.h"

namespace servokit::testing {

struct ProcessOptions {
  std::map<std::string, std::string> environment;  // added to the test's own
  bool append_stderr = false;  // keep stderr.txt across runs (a sweep killed and restarted)
  rlim_t address_space_limit = RLIM_INFINITY;  // RLIMIT_AS of the child, bytes
};

/// Starts `command` (its first word looked up in PATH) in `directory`, which must exist, with
/// stdout and stderr going to stdout.txt and stderr.txt there; returns its pid.
inline pid_t StartProcess(const std::filesystem::path& directory,
                          std::vector<std::string> command,
                          const ProcessOptions& options = {}) {
  std::vector<char*> argv;
  for (std::string& argument : command) argv.push_back(argument.data());
  argv.push_back(nullptr);
  const std::filesystem::path out = directory / "stdout.txt", err = directory / "stderr.txt";
  const int err_flags = O_WRONLY | O_CREAT | (options.append_stderr ? O_APPEND : O_TRUNC);
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    for (const auto& [name, value] : options.environment) ::setenv(name.c_str(), value.c_str(), 1);
    if (options.address_space_limit != RLIM_INFINITY) {
      const rlimit limit{options.address_space_limit, options.address_space_limit};
      if (::setrlimit(RLIMIT_AS, &limit) != 0) ::_exit(127);
    }
    const int out_fd = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err_fd = ::open(err.c_str(), err_flags, 0644);
    if (out_fd < 0 || err_fd < 0 || ::dup2(out_fd, STDOUT_FILENO) < 0 ||
        ::dup2(err_fd, STDERR_FILENO) < 0 || ::chdir(directory.c_str()) != 0) {
      ::_exit(127);
    }
    ::execvp(argv[0], argv.data());
    ::_exit(127);
  }
  return child;
}

/// Waits for a child; returns its wait status (WIFEXITED, WTERMSIG, ...).
inline int WaitForProcess(pid_t child) {
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  return status;
}

/// The exit status, or 128 + the signal that ended the process, as shells report it.
inline int ShellStatus(int wait_status) {
  return WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : 128 + WTERMSIG(wait_status);
}

struct ProcessResult {
  int status = -1;  // ShellStatus
  std::string out, err;
};

/// What a child StartProcess() began in `directory` printed; its two files are removed.
inline ProcessResult CollectProcess(pid_t child, const std::filesystem::path& directory) {
  ProcessResult result;
  result.status = ShellStatus(WaitForProcess(child));
  result.out = ReadFile(directory / "stdout.txt");
  result.err = ReadFile(directory / "stderr.txt");
  std::filesystem::remove(directory / "stdout.txt");
  std::filesystem::remove(directory / "stderr.txt");
  return result;
}

/// Runs `command` in `directory` (created if needed) and waits for it.
inline ProcessResult RunProcess(const std::filesystem::path& directory,
                                const std::vector<std::string>& command,
                                const ProcessOptions& options = {}) {
  std::filesystem::create_directories(directory);
  return CollectProcess(StartProcess(directory, command, options), directory);
}

}  // namespace servokit::testing
