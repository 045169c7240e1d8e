#pragma once

#include <memory>
#include <string>
#include <utility>

#include "gyrotc/hal/spi_bus.hpp"

namespace gyrotc::hal {

// /dev/spidevB.C through the spidev ioctls: SPI_IOC_WR_MODE,
// SPI_IOC_WR_BITS_PER_WORD, SPI_IOC_WR_MAX_SPEED_HZ, and one zero-initialised
// spi_ioc_transfer per SPI_IOC_MESSAGE(1). open() also takes the device's
// exclusive lock (lock_device): a device another gyrotc holds is
// ErrorCode::busy. Every failure names the path and the errno text.
class SpidevBus final : public SpiBus {
 public:
  static Result<std::unique_ptr<SpidevBus>> open(const std::string& path) noexcept;
  ~SpidevBus() override;
  SpidevBus(const SpidevBus&) = delete;
  SpidevBus& operator=(const SpidevBus&) = delete;

 private:
  SpidevBus(std::string path, int fd) noexcept : path_(std::move(path)), fd_(fd) {}

  Status do_configure(const SpiConfig& config) noexcept override;
  Status do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept override;
  std::string_view do_name() const noexcept override { return path_; }

  std::string path_;
  int fd_;
  SpiConfig config_{};
};

}  // namespace gyrotc::hal
