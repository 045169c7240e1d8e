#include "gyrotc/hal/linux/device_lock.hpp"

#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>

namespace gyrotc::hal {

std::optional<int> flock_holder(int fd, const char* locks_path) noexcept {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return std::nullopt;
  std::FILE* f = std::fopen(locks_path, "re");
  if (f == nullptr) return std::nullopt;
  // "1: FLOCK  ADVISORY  WRITE 1234 00:05:123 0 EOF" (waiters: "1: -> FLOCK ...");
  // the file is named by its filesystem's major:minor in hex and its inode.
  std::optional<int> holder;
  char line[256];
  while (!holder && std::fgets(line, sizeof line, f) != nullptr) {
    char kind[16], mode[16], access[16];
    int pid = 0;
    unsigned major_id = 0, minor_id = 0;
    std::uint64_t inode = 0;
    const char* fields = std::strchr(line, ':');
    if (fields == nullptr || std::strstr(line, "->") != nullptr) continue;
    if (std::sscanf(fields + 1, "%15s %15s %15s %d %x:%x:%" SCNu64, kind, mode, access, &pid, &major_id, &minor_id,
                    &inode) != 7) {
      continue;
    }
    if (std::strcmp(kind, "FLOCK") == 0 && major_id == major(st.st_dev) && minor_id == minor(st.st_dev) &&
        inode == static_cast<std::uint64_t>(st.st_ino)) {
      holder = pid;
    }
  }
  std::fclose(f);
  return holder;
}

Status lock_device(int fd, std::string_view path) noexcept {
  if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return {};
  const int error = errno;
  if (error != EWOULDBLOCK) return Error::from_errno(error, "cannot lock", path);
  const std::optional<int> pid = flock_holder(fd);
  if (!pid) {
    return Error::make(ErrorCode::busy, "'%.*s' is already in use by another process (is the gyrotc service running?)",
                       static_cast<int>(path.size()), path.data());
  }
  char name[32] = "?";
  char comm_path[48];
  std::snprintf(comm_path, sizeof comm_path, "/proc/%d/comm", *pid);
  if (std::FILE* comm = std::fopen(comm_path, "re")) {
    if (std::fgets(name, sizeof name, comm) != nullptr) name[std::strcspn(name, "\n")] = '\0';
    std::fclose(comm);
  }
  return Error::make(ErrorCode::busy, "'%.*s' is already in use by PID %d (%s)", static_cast<int>(path.size()),
                     path.data(), *pid, name);
}

}  // namespace gyrotc::hal
