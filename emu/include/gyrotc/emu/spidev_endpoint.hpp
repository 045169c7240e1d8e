#pragma once

#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <vector>

// One emulated /dev/spidevB.C: the state the kernel's spidev driver keeps per
// device (mode, bits per word, maximum speed) and its ioctls, decoded from
// CUSE's unrestricted-ioctl protocol, with an emulated chip on the wire
// behind it. No FUSE types here: emu/fuse/cuse_spidev.cpp maps IoctlReply to
// fuse_reply_ioctl_retry / fuse_reply_ioctl / fuse_reply_err.
//
// The unrestricted protocol: CUSE hands the driver the command and the
// caller's argument (a user address) with nothing fetched; the driver asks
// for the user memory it needs (retry: ranges to copy in, ranges to copy
// out), and is called again with those bytes, until it answers. For
// SPI_IOC_MESSAGE(n): first the n struct spi_ioc_transfer at arg, then those
// again with every tx buffer (in) and every rx buffer (out), then the answer
// with the rx bytes.
//
// What a real spidev and controller do, this does (drivers/spi/spidev.c,
// spi.c): WR_MODE keeps the mode's upper bits and refuses bits the
// controller lacks (EINVAL); WR_MAX_SPEED_HZ 0 is EINVAL; a transfer's
// speed_hz and bits_per_word 0 mean the device's; a length that is not a
// whole number of words is EINVAL; more than bufsiz (4096) bytes in one
// message is EMSGSIZE; an unknown command is ENOTTY. Words of 16 or 32 bits
// are stored in memory in the CPU's order (little-endian here) and clocked
// MSB first, SPI_LSB_FIRST reverses each word's bits on the wire; the chip
// sees the wire. A wrong mode, word size or speed is the chip's to answer.
namespace gyrotc::emu {

// What goes over the wires for one chip-select frame.
struct SpiWire {
  std::uint8_t mode = 0;          // CPOL << 1 | CPHA
  std::uint32_t speed_hz = 1'000'000;
  bool cs_active_high = false;    // SPI_CS_HIGH: the chip's select is never asserted
};

// The chip behind a device: one frame (chip select held) of wire bytes, MSB
// first. Returns 0 or an errno the controller reports (an injected fault).
class SpiTarget {
 public:
  virtual ~SpiTarget() = default;
  virtual int transfer(const SpiWire& wire, std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) = 0;
};

// A range of the caller's memory for the kernel to copy.
struct UserRange {
  std::uint64_t address = 0;
  std::size_t size = 0;
};

struct IoctlCall {
  unsigned cmd = 0;
  std::uint64_t arg = 0;                  // the caller's argument: a user address
  std::span<const std::uint8_t> in;       // the bytes of the in ranges last asked for, concatenated
  std::size_t out_size = 0;               // the room of the out ranges last asked for
};

struct IoctlReply {
  enum class Kind { retry, done, error };
  Kind kind = Kind::error;
  std::vector<UserRange> in;              // retry: copy these in
  std::vector<UserRange> out;             // retry: and make room for these
  int result = 0;                         // done: the ioctl's return value
  std::vector<std::uint8_t> data;         // done: bytes for the out ranges, concatenated
  int error = 0;                          // error: the errno

  static IoctlReply retry_with(std::vector<UserRange> in_ranges, std::vector<UserRange> out_ranges);
  static IoctlReply done(int result, std::vector<std::uint8_t> bytes = {});
  static IoctlReply fail(int errno_value);
};

// The spidev driver's state of one device, as spidev_ioctl keeps it.
struct SpidevState {
  std::uint32_t mode = 0;                  // SPI_CPHA | SPI_CPOL | SPI_CS_HIGH | SPI_LSB_FIRST ...
  std::uint8_t bits_per_word = 8;
  std::uint32_t max_speed_hz = 125'000'000;  // the device tree's spi-max-frequency of the Pi's spidev overlays
};

class SpidevEndpoint {
 public:
  static constexpr std::size_t kBufSize = 4096;  // spidev's bufsiz module parameter
  // The mode bits the emulated controller supports (spi_setup refuses others).
  static constexpr std::uint32_t kSupportedModeBits = 0x01 | 0x02 | 0x04 | 0x08;  // CPHA CPOL CS_HIGH LSB_FIRST

  SpidevEndpoint(std::string name, SpiTarget& target);

  IoctlReply ioctl(const IoctlCall& call);
  // write(2) / read(2) on the node: one frame out, or one frame in (tx zeros),
  // at the device's speed and word size. Returns the byte count or -errno.
  int write(std::span<const std::uint8_t> tx);
  int read(std::span<std::uint8_t> rx);

  SpidevState state() const;
  const std::string& name() const noexcept { return name_; }

 private:
  struct Transfer {
    std::uint64_t tx_buf, rx_buf;
    std::uint32_t len, speed_hz;
    std::uint16_t delay_usecs;
    std::uint8_t bits_per_word, cs_change;
  };
  IoctlReply message(const IoctlCall& call, std::size_t count);
  IoctlReply set_or_get(const IoctlCall& call, std::size_t size);
  int run_frames(const std::vector<Transfer>& transfers, std::span<const std::uint8_t> tx_bytes,
                 std::vector<std::uint8_t>& rx_bytes);
  int one_frame(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx);

  std::string name_;
  SpiTarget& target_;
  mutable std::mutex mutex_;
  SpidevState state_;
};

// Wire order of a buffer of words (the CPU's order in memory, MSB first on
// the wire, or each word's bits reversed with lsb_first): to_wire and back.
std::vector<std::uint8_t> memory_to_wire(std::span<const std::uint8_t> memory, unsigned bits_per_word, bool lsb_first);
std::vector<std::uint8_t> wire_to_memory(std::span<const std::uint8_t> wire, unsigned bits_per_word, bool lsb_first);

}  // namespace gyrotc::emu
