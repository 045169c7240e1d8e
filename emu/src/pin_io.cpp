#include "gyrotc/emu/pin_io.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::emu {

namespace {
int open_attribute(const std::string& path, int flags) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC);
  if (fd < 0) throw app::RuntimeFailure("cannot open '" + path + "': " + std::strerror(errno));
  return fd;
}
}  // namespace

SysfsPullPin::SysfsPullPin(const std::string& line_dir)
    : path_(line_dir + "/pull"), fd_(open_attribute(path_, O_WRONLY)) {}

SysfsPullPin::~SysfsPullPin() { ::close(fd_); }

void SysfsPullPin::set_level(bool high) noexcept {
  static constexpr char kUp[] = "pull-up";
  static constexpr char kDown[] = "pull-down";
  const char* text = high ? kUp : kDown;
  const std::size_t size = high ? sizeof kUp - 1 : sizeof kDown - 1;
  if (::pwrite(fd_, text, size, 0) != static_cast<ssize_t>(size)) ++errors_;
}

SysfsValuePin::SysfsValuePin(const std::string& line_dir)
    : path_(line_dir + "/value"), fd_(open_attribute(path_, O_RDONLY)) {}

SysfsValuePin::~SysfsValuePin() { ::close(fd_); }

std::optional<bool> SysfsValuePin::level() noexcept {
  char c = 0;
  if (::pread(fd_, &c, 1, 0) != 1) return std::nullopt;
  if (c == '0') return false;
  if (c == '1') return true;
  return std::nullopt;
}

}  // namespace gyrotc::emu
