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
  if (id_.empty()) (void)find_device();
}

Result<std::vector<std::string>> W1Sysfs::list_ds18b20(const std::string& root) {
  DIR* dir = ::opendir(root.c_str());
  if (dir == nullptr) return Error::from_errno(errno, "cannot list w1 devices under", root);
  std::vector<std::string> ids;
  while (const dirent* entry = ::readdir(dir)) {
    if (std::string_view(entry->d_name).starts_with("28-")) ids.emplace_back(entry->d_name);
  }
  ::closedir(dir);
  std::sort(ids.begin(), ids.end());  // readdir order is arbitrary
  return ids;
}

Status W1Sysfs::find_device() {
  if (!id_.empty()) return {};
  const Result<std::vector<std::string>> ids = list_ds18b20(root_);
  if (!ids || ids->empty()) {
    return Error::make(ErrorCode::not_found, "no DS18B20 (28-*) under '%s'", root_.c_str());
  }
  if (ids->size() > 1) {
    std::string names;
    for (const std::string& id : *ids) names += (names.empty() ? "" : ", ") + id;
    return Error::make(ErrorCode::invalid_config,
                       "%zu DS18B20s under '%s' (%s) and no id configured: which one is this sensor? set its id",
                       ids->size(), root_.c_str(), names.c_str());
  }
  id_ = ids->front();
  device_path_ = root_ + "/" + id_;
  return {};
}

Result<std::size_t> W1Sysfs::do_read(W1File file, std::span<char> buffer) {
  if (Status bound = find_device(); !bound) return bound.error();
  const char* name = file == W1File::w1_slave ? "/w1_slave" : file == W1File::temperature ? "/temperature" : "/resolution";
  const std::string path = device_path_ + name;
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
