#include "spidev_interposer.hpp"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdarg>
#include <cstring>
#include <span>

FakeSpidev*& FakeSpidev::armed() {
  static FakeSpidev* fake = nullptr;
  return fake;
}

extern "C" {
int __real_open(const char* path, int flags, ...);
int __real_ioctl(int fd, unsigned long request, ...);
int __real_close(int fd);
int __real_flock(int fd, int operation);

int __real_open64(const char* path, int flags, ...);

// The fake's descriptor when path is the fake spidev, else -1.
int open_fake(const char* path, int flags) {
  FakeSpidev* fake = FakeSpidev::armed();
  if (fake == nullptr || fake->path != path) return -1;
  // A real descriptor (of /dev/null) so that the number is unique.
  fake->fd = __real_open("/dev/null", O_RDONLY | O_CLOEXEC);
  fake->open_flags = flags;
  fake->closed = false;
  return fake->fd;
}

int __wrap_open(const char* path, int flags, ...) {
  if (const int fd = open_fake(path, flags); fd >= 0) return fd;
  mode_t mode = 0;
  if ((flags & (O_CREAT | O_TMPFILE)) != 0) {
    va_list args;
    va_start(args, flags);
    mode = static_cast<mode_t>(va_arg(args, unsigned));
    va_end(args);
  }
  return __real_open(path, flags, mode);
}

// With _FILE_OFFSET_BITS=64 on a 32-bit target (armhf), open() is open64().
int __wrap_open64(const char* path, int flags, ...) {
  if (const int fd = open_fake(path, flags); fd >= 0) return fd;
  mode_t mode = 0;
  if ((flags & (O_CREAT | O_TMPFILE)) != 0) {
    va_list args;
    va_start(args, flags);
    mode = static_cast<mode_t>(va_arg(args, unsigned));
    va_end(args);
  }
  return __real_open64(path, flags, mode);
}

int __wrap_ioctl(int fd, unsigned long request, ...) {
  va_list args;
  va_start(args, request);
  void* arg = va_arg(args, void*);
  va_end(args);
  FakeSpidev* fake = FakeSpidev::armed();
  if (fake == nullptr || fd != fake->fd || fake->closed) return __real_ioctl(fd, request, arg);

  if (request == fake->fail_request) {
    errno = fake->fail_errno;
    return -1;
  }
  if (request == SPI_IOC_WR_MODE) {
    fake->mode = *static_cast<std::uint8_t*>(arg);
    return 0;
  }
  if (request == SPI_IOC_WR_BITS_PER_WORD) {
    fake->bits_per_word = *static_cast<std::uint8_t*>(arg);
    return 0;
  }
  if (request == SPI_IOC_WR_MAX_SPEED_HZ) {
    fake->max_speed_hz = *static_cast<std::uint32_t*>(arg);
    return 0;
  }
  if (request == SPI_IOC_MESSAGE(1)) {
    ++fake->messages;
    std::memcpy(&fake->last, arg, sizeof fake->last);
    const spi_ioc_transfer& t = fake->last;
    if (t.len == 0 || t.tx_buf == 0 || t.rx_buf == 0 || fake->device == nullptr) {
      ++fake->bad_messages;
      errno = EINVAL;
      return -1;
    }
    const std::span<const std::uint8_t> tx(reinterpret_cast<const std::uint8_t*>(t.tx_buf), t.len);
    const std::span<std::uint8_t> rx(reinterpret_cast<std::uint8_t*>(t.rx_buf), t.len);
    // The kernel applies the bus mode set by SPI_IOC_WR_MODE to the device.
    if (!fake->device->configure({.mode = fake->mode, .speed_hz = fake->max_speed_hz,
                                  .bits_per_word = fake->bits_per_word})
             .ok() ||
        !fake->device->transfer(tx, rx).ok()) {
      errno = EIO;
      return -1;
    }
    return static_cast<int>(t.len);
  }
  ++fake->bad_messages;
  errno = ENOTTY;
  return -1;
}

// The fake's descriptor is /dev/null, which other test processes running in
// parallel use too: its lock is the fake's own, not the system's.
int __wrap_flock(int fd, int operation) {
  FakeSpidev* fake = FakeSpidev::armed();
  if (fake != nullptr && fd == fake->fd && !fake->closed) return 0;
  return __real_flock(fd, operation);
}

int __wrap_close(int fd) {
  FakeSpidev* fake = FakeSpidev::armed();
  if (fake != nullptr && fd == fake->fd && !fake->closed) fake->closed = true;
  return __real_close(fd);
}
}
