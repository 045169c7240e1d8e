#include "gyrotc/hal/linux/w1_sysfs.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string_view>
#include <vector>

namespace gyrotc::hal {

W1Sysfs::W1Sysfs(std::string root, std::string id) : root_(std::move(root)), id_(std::move(id)) {
  device_path_ = root_ + "/" + (id_.empty() ? "28-*" : id_);
  if (id_.empty()) find_device();
}

bool W1Sysfs::find_device() {
  DIR* dir = ::opendir(root_.c_str());
  if (dir == nullptr) return false;
  std::vector<std::string> candidates;
  while (const dirent* entry = ::readdir(dir)) {
    if (std::string_view(entry->d_name).starts_with("28-")) candidates.emplace_back(entry->d_name);
  }
  ::closedir(dir);
  if (candidates.empty()) return false;
  id_ = *std::min_element(candidates.begin(), candidates.end());  // readdir order is arbitrary
  device_path_ = root_ + "/" + id_;
  return true;
}

Result<std::size_t> W1Sysfs::do_read(W1File file, std::span<char> buffer) {
  if (id_.empty() && !find_device()) {
    return Error::make(ErrorCode::not_found, "no DS18B20 (28-*) under '%s'", root_.c_str());
  }
  const std::string path = device_path_ + (file == W1File::w1_slave ? "/w1_slave" : "/temperature");
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Error::from_errno(errno, "cannot open", path);
  std::size_t total = 0;
  while (total < buffer.size()) {
    const ssize_t n = ::read(fd, buffer.data() + total, buffer.size() - total);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int saved = errno;
      ::close(fd);
      return Error::from_errno(saved, "cannot read", path);
    }
    if (n == 0) break;
    total += static_cast<std::size_t>(n);
  }
  ::close(fd);
  return total;
}

}  // namespace gyrotc::hal
