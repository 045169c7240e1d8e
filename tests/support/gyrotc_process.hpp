#pragma once
// A `gyrotc` child process for the daemon tests: start it with stderr to a
// file, watch its files, collect its exit status.

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "test_paths.hpp"

namespace gyrotc::test {

// Starts the gyrotc executable with args, stderr to err_path, stdout to /dev/null.
inline pid_t spawn_gyrotc(const std::vector<std::string>& args, const std::string& err_path) {
  const std::string exe = gyrotc_exe();
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(exe.c_str()));
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  // Truncated here, not in the child: a caller polling the file must never
  // see a previous run's lines.
  const int fd = open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return -1;
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(fd, STDERR_FILENO);
    const int null = open("/dev/null", O_WRONLY);
    dup2(null, STDOUT_FILENO);
    execv(exe.c_str(), argv.data());
    _exit(127);
  }
  close(fd);
  return pid;
}

inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Waits (bounded: 30 s) until the file at path contains text.
inline bool wait_for_text(const std::string& path, const std::string& text) {
  for (int i = 0; i < 300; ++i) {
    if (read_text(path).find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return false;
}

// tec_a of every row the child has written so far to a board record CSV
// (`record`, `calibrate --config`: the sixth column).
inline std::vector<double> record_tec_a(const std::string& path) {
  std::vector<double> out;
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) return out;
  while (std::getline(in, line)) {
    std::stringstream cells(line);
    std::string cell;
    for (int column = 0; column < 6 && std::getline(cells, cell, ','); ++column) {
      if (column == 5) out.push_back(std::stod(cell));
    }
  }
  return out;
}

inline int exit_status(pid_t pid) {
  int status = 0;
  if (waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

}  // namespace gyrotc::test
