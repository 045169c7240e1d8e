#pragma once

#include <linux/spi/spidev.h>

#include <cstdint>
#include <string>

#include "gyrotc/hal/spi_bus.hpp"

// A fake spidev character device behind link-time wrappers of open, ioctl
// and close: while armed, opening `path` returns a private descriptor whose
// spidev ioctls are recorded and answered by `device` (a chip simulator's
// SPI side). Everything else goes to the real calls.
struct FakeSpidev {
  std::string path = "/dev/spidev0.0";
  gyrotc::hal::SpiBus* device = nullptr;
  int fd = -1;
  int open_flags = 0;
  bool closed = false;
  std::uint8_t mode = 0xFF;
  std::uint8_t bits_per_word = 0;
  std::uint32_t max_speed_hz = 0;
  unsigned long fail_request = 0;  // this ioctl request fails with fail_errno
  int fail_errno = 0;
  int messages = 0;
  int bad_messages = 0;  // SPI_IOC_MESSAGE(n != 1) or nonsense fields
  spi_ioc_transfer last{};

  static FakeSpidev*& armed();  // the fake in use, or nullptr
};
