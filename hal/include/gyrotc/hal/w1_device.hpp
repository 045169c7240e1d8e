#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "gyrotc/hal/result.hpp"

namespace gyrotc::hal {

// The files the kernel's w1_therm driver offers for a DS18B20.
enum class W1File : std::uint8_t {
  w1_slave,     // "xx xx .. xx : crc=xx YES|NO\nxx xx .. xx t=<millidegrees>\n"
  temperature,  // "<millidegrees>\n"
  resolution,   // "<bits>\n" (w1_therm since Linux 5.10): 9..12
};

// One 1-Wire device's files: W1Sysfs reads them from sysfs, the simulator
// writes them in memory. A missing device is ErrorCode::not_found.
class W1Device {
 public:
  virtual ~W1Device() = default;

  // Reads the whole file into buffer; returns the number of bytes.
  Result<std::size_t> read(W1File file, std::span<char> buffer) { return do_read(file, buffer); }
  std::string_view name() const noexcept { return do_name(); }

 private:
  virtual Result<std::size_t> do_read(W1File file, std::span<char> buffer) = 0;
  virtual std::string_view do_name() const noexcept = 0;
};

}  // namespace gyrotc::hal
