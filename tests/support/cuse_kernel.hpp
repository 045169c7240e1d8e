#pragma once
// The kernel's side of CUSE's unrestricted ioctl, for tests of the emulated
// spidev nodes without a kernel: the caller's memory is this process's, so
// the ranges the device asks for are copied straight from and to it, as
// fs/fuse/ioctl.c copies them from and to the caller's. Counts the round
// trips, and fails a test that would loop (the kernel gives up too).
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <linux/spi/spidev.h>
#include <span>
#include <vector>

#include "gyrotc/emu/spidev_endpoint.hpp"
#include "gyrotc/hal/spi_bus.hpp"

namespace gyrotc::test {

struct CuseIoctlResult {
  int result = 0;   // >= 0, or -errno
  int round_trips = 0;
};

inline CuseIoctlResult cuse_ioctl(emu::SpidevEndpoint& device, unsigned cmd, void* arg) {
  CuseIoctlResult r;
  std::vector<std::uint8_t> in;
  std::size_t out_size = 0;
  std::vector<emu::UserRange> out_ranges;
  for (;;) {
    ++r.round_trips;
    if (r.round_trips > 4) return {-EIO, r.round_trips};
    const emu::IoctlReply reply =
        device.ioctl({cmd, reinterpret_cast<std::uintptr_t>(arg), std::span<const std::uint8_t>(in), out_size});
    if (reply.kind == emu::IoctlReply::Kind::error) return {-reply.error, r.round_trips};
    if (reply.kind == emu::IoctlReply::Kind::done) {
      std::size_t at = 0;
      for (const emu::UserRange& range : out_ranges) {
        const std::size_t n = std::min(range.size, reply.data.size() - std::min(at, reply.data.size()));
        std::memcpy(reinterpret_cast<void*>(static_cast<std::uintptr_t>(range.address)), reply.data.data() + at, n);
        at += n;
      }
      r.result = reply.result;
      return r;
    }
    in.clear();
    for (const emu::UserRange& range : reply.in) {
      const auto* p = reinterpret_cast<const std::uint8_t*>(static_cast<std::uintptr_t>(range.address));
      in.insert(in.end(), p, p + range.size);
    }
    out_ranges = reply.out;
    out_size = 0;
    for (const emu::UserRange& range : out_ranges) out_size += range.size;
  }
}

// hal::SpiBus over an emulated node, calling it as SpidevBus calls a real
// spidev (the same ioctls, one SPI_IOC_MESSAGE(1) per transfer): the
// production drivers run unchanged against the emulated chips.
class CuseSpiBus final : public hal::SpiBus {
 public:
  explicit CuseSpiBus(emu::SpidevEndpoint& device) : device_(device) {}
  int round_trips = 0;

 private:
  hal::Status do_configure(const hal::SpiConfig& c) noexcept override {
    std::uint8_t mode = c.mode, bits = c.bits_per_word;
    std::uint32_t speed = c.speed_hz;
    for (auto [cmd, arg] : {std::pair<unsigned, void*>{SPI_IOC_WR_MODE, &mode},
                            std::pair<unsigned, void*>{SPI_IOC_WR_BITS_PER_WORD, &bits},
                            std::pair<unsigned, void*>{SPI_IOC_WR_MAX_SPEED_HZ, &speed}}) {
      const CuseIoctlResult r = cuse_ioctl(device_, cmd, arg);
      if (r.result < 0) return hal::Error::from_errno(-r.result, "cuse ioctl on", "emulated spidev");
    }
    config_ = c;
    return {};
  }
  hal::Status do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept override {
    spi_ioc_transfer t{};
    t.tx_buf = reinterpret_cast<std::uintptr_t>(tx.data());
    t.rx_buf = reinterpret_cast<std::uintptr_t>(rx.data());
    t.len = static_cast<std::uint32_t>(tx.size());
    t.speed_hz = config_.speed_hz;
    t.bits_per_word = config_.bits_per_word;
    const CuseIoctlResult r = cuse_ioctl(device_, SPI_IOC_MESSAGE(1), &t);
    round_trips += r.round_trips;
    if (r.result < 0) return hal::Error::from_errno(-r.result, "SPI_IOC_MESSAGE on", "emulated spidev");
    return {};
  }
  std::string_view do_name() const noexcept override { return "cuse:spidev"; }

  emu::SpidevEndpoint& device_;
  hal::SpiConfig config_;
};

}  // namespace gyrotc::test
