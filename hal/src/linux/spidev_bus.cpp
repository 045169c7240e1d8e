#include "gyrotc/hal/linux/spidev_bus.hpp"

#include "gyrotc/hal/linux/device_lock.hpp"

#include <fcntl.h>
#include <linux/spi/spidev.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace gyrotc::hal {

Result<std::unique_ptr<SpidevBus>> SpidevBus::open(const std::string& path) noexcept {
  const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) return Error::from_errno(errno, "cannot open spidev", path);
  if (Status locked = lock_device(fd, path); !locked) {
    ::close(fd);
    return locked.error();
  }
  return std::unique_ptr<SpidevBus>(new SpidevBus(path, fd));
}

SpidevBus::~SpidevBus() { ::close(fd_); }

Status SpidevBus::do_configure(const SpiConfig& config) noexcept {
  std::uint8_t mode = config.mode;
  if (::ioctl(fd_, SPI_IOC_WR_MODE, &mode) < 0) return Error::from_errno(errno, "SPI_IOC_WR_MODE on", path_);
  std::uint8_t bits = config.bits_per_word;
  if (::ioctl(fd_, SPI_IOC_WR_BITS_PER_WORD, &bits) < 0) {
    return Error::from_errno(errno, "SPI_IOC_WR_BITS_PER_WORD on", path_);
  }
  std::uint32_t speed_hz = config.speed_hz;
  if (::ioctl(fd_, SPI_IOC_WR_MAX_SPEED_HZ, &speed_hz) < 0) {
    return Error::from_errno(errno, "SPI_IOC_WR_MAX_SPEED_HZ on", path_);
  }
  config_ = config;
  return {};
}

Status SpidevBus::do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept {
  if (tx.size() != rx.size() || tx.empty()) {
    return Error::make(ErrorCode::invalid_config, "spidev '%s': transfer needs equal, non-empty tx and rx",
                       path_.c_str());
  }
  spi_ioc_transfer transfer;
  std::memset(&transfer, 0, sizeof transfer);  // padding and future fields must be zero
  transfer.tx_buf = reinterpret_cast<std::uintptr_t>(tx.data());
  transfer.rx_buf = reinterpret_cast<std::uintptr_t>(rx.data());
  transfer.len = static_cast<std::uint32_t>(tx.size());
  transfer.speed_hz = config_.speed_hz;
  transfer.bits_per_word = config_.bits_per_word;
  const int n = ::ioctl(fd_, SPI_IOC_MESSAGE(1), &transfer);
  if (n < 0) return Error::from_errno(errno, "SPI_IOC_MESSAGE on", path_);
  if (static_cast<std::size_t>(n) != tx.size()) {
    return Error::make(ErrorCode::io, "spidev '%s': short transfer (%d of %zu bytes)", path_.c_str(), n,
                       tx.size());
  }
  return {};
}

}  // namespace gyrotc::hal
