#include "gyrotc/emu/spidev_endpoint.hpp"

#include <linux/ioctl.h>
#include <linux/spi/spidev.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

namespace gyrotc::emu {

namespace {

constexpr std::uint32_t kModeMask = 0xFFFFu;  // what SPI_IOC_WR_MODE32 may set (SPI_MODE_USER_MASK's span)

unsigned word_bytes(unsigned bits_per_word) { return bits_per_word <= 8 ? 1u : bits_per_word <= 16 ? 2u : 4u; }

// The emulated controller's bits_per_word_mask: 8, 16 and 32 bits.
bool controller_word(unsigned bits_per_word) {
  return bits_per_word == 8 || bits_per_word == 16 || bits_per_word == 32;
}

std::uint8_t reverse_bits(std::uint8_t b) {
  b = static_cast<std::uint8_t>((b & 0xF0u) >> 4 | (b & 0x0Fu) << 4);
  b = static_cast<std::uint8_t>((b & 0xCCu) >> 2 | (b & 0x33u) << 2);
  return static_cast<std::uint8_t>((b & 0xAAu) >> 1 | (b & 0x55u) << 1);
}

// A buffer's words in wire order (MSB first) from the CPU's (little-endian)
// order, or with each word's bits reversed (LSB first: the whole word read
// backwards, which leaves the bytes in memory order, each bit-reversed). The
// map is its own inverse, so it serves both directions. Indexing only (no
// scratch word) keeps GCC 12's -Wstringop-overflow from guessing at bounds.
std::vector<std::uint8_t> swap_words(std::span<const std::uint8_t> in, unsigned bits_per_word, bool lsb_first) {
  const unsigned w = word_bytes(bits_per_word);
  std::vector<std::uint8_t> out(in.size());
  for (std::size_t i = 0; i + w <= in.size(); i += w) {
    for (unsigned k = 0; k < w; ++k) out[i + k] = lsb_first ? reverse_bits(in[i + k]) : in[i + w - 1 - k];
  }
  return out;
}

}  // namespace

std::vector<std::uint8_t> memory_to_wire(std::span<const std::uint8_t> memory, unsigned bits_per_word,
                                         bool lsb_first) {
  return swap_words(memory, bits_per_word, lsb_first);
}

std::vector<std::uint8_t> wire_to_memory(std::span<const std::uint8_t> wire, unsigned bits_per_word, bool lsb_first) {
  return swap_words(wire, bits_per_word, lsb_first);
}

IoctlReply IoctlReply::retry_with(std::vector<UserRange> in_ranges, std::vector<UserRange> out_ranges) {
  IoctlReply r;
  r.kind = Kind::retry;
  r.in = std::move(in_ranges);
  r.out = std::move(out_ranges);
  return r;
}

IoctlReply IoctlReply::done(int result, std::vector<std::uint8_t> bytes) {
  IoctlReply r;
  r.kind = Kind::done;
  r.result = result;
  r.data = std::move(bytes);
  return r;
}

IoctlReply IoctlReply::fail(int errno_value) {
  IoctlReply r;
  r.kind = Kind::error;
  r.error = errno_value;
  return r;
}

SpidevEndpoint::SpidevEndpoint(std::string name, SpiTarget& target) : name_(std::move(name)), target_(target) {}

SpidevState SpidevEndpoint::state() const {
  const std::lock_guard lock(mutex_);
  return state_;
}

IoctlReply SpidevEndpoint::ioctl(const IoctlCall& call) {
  if (_IOC_TYPE(call.cmd) != SPI_IOC_MAGIC) return IoctlReply::fail(ENOTTY);
  const unsigned nr = _IOC_NR(call.cmd);
  const unsigned dir = _IOC_DIR(call.cmd);
  const std::size_t size = _IOC_SIZE(call.cmd);
  if (nr == _IOC_NR(SPI_IOC_MESSAGE(1))) {
    if (dir != _IOC_WRITE) return IoctlReply::fail(ENOTTY);
    if (size % sizeof(spi_ioc_transfer) != 0) return IoctlReply::fail(EINVAL);
    return message(call, size / sizeof(spi_ioc_transfer));
  }
  switch (call.cmd) {
    case SPI_IOC_RD_MODE:
    case SPI_IOC_WR_MODE:
    case SPI_IOC_RD_LSB_FIRST:
    case SPI_IOC_WR_LSB_FIRST:
    case SPI_IOC_RD_BITS_PER_WORD:
    case SPI_IOC_WR_BITS_PER_WORD: return set_or_get(call, 1);
    case SPI_IOC_RD_MAX_SPEED_HZ:
    case SPI_IOC_WR_MAX_SPEED_HZ:
    case SPI_IOC_RD_MODE32:
    case SPI_IOC_WR_MODE32: return set_or_get(call, 4);
    default: return IoctlReply::fail(ENOTTY);
  }
}

IoctlReply SpidevEndpoint::set_or_get(const IoctlCall& call, std::size_t size) {
  const bool write = (_IOC_DIR(call.cmd) & _IOC_WRITE) != 0;
  const UserRange range{call.arg, size};
  if (write && call.in.size() < size) return IoctlReply::retry_with({range}, {});
  if (!write && call.out_size < size) return IoctlReply::retry_with({}, {range});

  const std::lock_guard lock(mutex_);
  if (!write) {
    std::uint32_t value = 0;
    switch (call.cmd) {
      case SPI_IOC_RD_MODE: value = state_.mode & 0xFFu; break;
      case SPI_IOC_RD_MODE32: value = state_.mode & kModeMask; break;
      case SPI_IOC_RD_LSB_FIRST: value = (state_.mode & SPI_LSB_FIRST) != 0 ? 1 : 0; break;
      case SPI_IOC_RD_BITS_PER_WORD: value = state_.bits_per_word; break;
      default: value = state_.max_speed_hz; break;  // SPI_IOC_RD_MAX_SPEED_HZ
    }
    std::vector<std::uint8_t> bytes(size);
    std::memcpy(bytes.data(), &value, size);  // the CPU's order, as put_user stores it
    return IoctlReply::done(0, std::move(bytes));
  }
  std::uint32_t value = 0;
  std::memcpy(&value, call.in.data(), size);
  switch (call.cmd) {
    case SPI_IOC_WR_MODE:
    case SPI_IOC_WR_MODE32: {
      if ((value & ~kModeMask) != 0) return IoctlReply::fail(EINVAL);
      const std::uint32_t mode = call.cmd == SPI_IOC_WR_MODE ? (value & 0xFFu) | (state_.mode & ~0xFFu) : value;
      if ((mode & ~kSupportedModeBits) != 0) return IoctlReply::fail(EINVAL);  // spi_setup: bad_bits
      state_.mode = mode;
      return IoctlReply::done(0);
    }
    case SPI_IOC_WR_LSB_FIRST:
      state_.mode = value != 0 ? state_.mode | SPI_LSB_FIRST : state_.mode & ~static_cast<std::uint32_t>(SPI_LSB_FIRST);
      return IoctlReply::done(0);
    case SPI_IOC_WR_BITS_PER_WORD: {
      const unsigned bits = value == 0 ? 8 : value;  // spi_setup: 0 means 8
      if (!controller_word(bits)) return IoctlReply::fail(EINVAL);
      state_.bits_per_word = static_cast<std::uint8_t>(bits);
      return IoctlReply::done(0);
    }
    default:  // SPI_IOC_WR_MAX_SPEED_HZ
      if (value == 0) return IoctlReply::fail(EINVAL);
      state_.max_speed_hz = value;
      return IoctlReply::done(0);
  }
}

IoctlReply SpidevEndpoint::message(const IoctlCall& call, std::size_t count) {
  if (count == 0) return IoctlReply::done(0);
  const std::size_t header = count * sizeof(spi_ioc_transfer);
  const UserRange transfers_range{call.arg, header};
  if (call.in.size() < header) return IoctlReply::retry_with({transfers_range}, {});

  std::vector<Transfer> transfers(count);
  std::vector<UserRange> in{transfers_range}, out;
  std::size_t tx_total = 0, rx_total = 0, tx_fetched = 0;
  for (std::size_t i = 0; i < count; ++i) {
    spi_ioc_transfer u;
    std::memcpy(&u, call.in.data() + i * sizeof u, sizeof u);
    transfers[i] = {u.tx_buf, u.rx_buf, u.len, u.speed_hz, u.delay_usecs, u.bits_per_word, u.cs_change};
    if (u.len > 0x7FFFFFFFu) return IoctlReply::fail(EMSGSIZE);
    tx_total += u.len;
    rx_total += u.len;
    if (u.tx_buf != 0 && u.len > 0) {
      in.push_back({u.tx_buf, u.len});
      tx_fetched += u.len;
    }
    if (u.rx_buf != 0 && u.len > 0) out.push_back({u.rx_buf, u.len});
  }
  if (tx_total > kBufSize || rx_total > kBufSize) return IoctlReply::fail(EMSGSIZE);
  std::size_t rx_wanted = 0;
  for (const UserRange& r : out) rx_wanted += r.size;
  const bool complete = call.in.size() == header + tx_fetched && call.out_size == rx_wanted;
  if (!complete) {
    if (in.size() == 1 && out.empty() && call.in.size() == header) {
      // Nothing to fetch or return: the transfer runs now.
    } else {
      return IoctlReply::retry_with(std::move(in), std::move(out));
    }
  }
  std::vector<std::uint8_t> rx;
  const int status = run_frames(transfers, call.in.subspan(header), rx);
  if (status < 0) return IoctlReply::fail(-status);
  return IoctlReply::done(status, std::move(rx));
}

int SpidevEndpoint::run_frames(const std::vector<Transfer>& transfers, std::span<const std::uint8_t> tx_bytes,
                               std::vector<std::uint8_t>& rx_bytes) {
  SpidevState s;
  {
    const std::lock_guard lock(mutex_);
    s = state_;
  }
  // __spi_validate: every transfer first, nothing is clocked if one is bad.
  for (const Transfer& t : transfers) {
    const unsigned bits = t.bits_per_word != 0 ? t.bits_per_word : s.bits_per_word;
    if (!controller_word(bits)) return -EINVAL;
    if (t.len % word_bytes(bits) != 0) return -EINVAL;
  }
  const bool lsb_first = (s.mode & SPI_LSB_FIRST) != 0;
  SpiWire wire{.mode = static_cast<std::uint8_t>(s.mode & 3u), .speed_hz = s.max_speed_hz,
               .cs_active_high = (s.mode & SPI_CS_HIGH) != 0};
  std::vector<std::uint8_t> frame_tx, frame_rx;
  std::vector<const Transfer*> frame_parts;  // the transfers of the open frame, in order
  std::size_t tx_offset = 0;
  int total = 0;
  bool frame_open = false;
  const auto close_frame = [&]() -> int {
    frame_rx.assign(frame_tx.size(), 0);
    const int error = target_.transfer(wire, frame_tx, frame_rx);
    if (error != 0) return -error;
    std::size_t at = 0;
    for (const Transfer* t : frame_parts) {
      const unsigned bits = t->bits_per_word != 0 ? t->bits_per_word : s.bits_per_word;
      const std::span<const std::uint8_t> wire_rx(frame_rx.data() + at, t->len);
      at += t->len;
      if (t->rx_buf != 0 && t->len > 0) {
        const std::vector<std::uint8_t> memory = wire_to_memory(wire_rx, bits, lsb_first);
        rx_bytes.insert(rx_bytes.end(), memory.begin(), memory.end());
      }
    }
    frame_tx.clear();
    frame_parts.clear();
    frame_open = false;
    return 0;
  };
  for (std::size_t i = 0; i < transfers.size(); ++i) {
    const Transfer& t = transfers[i];
    const unsigned bits = t.bits_per_word != 0 ? t.bits_per_word : s.bits_per_word;
    if (!frame_open) {
      wire.speed_hz = t.speed_hz != 0 ? t.speed_hz : s.max_speed_hz;
      frame_open = true;
    }
    std::vector<std::uint8_t> memory(t.len, 0);
    if (t.tx_buf != 0 && t.len > 0) {
      std::copy(tx_bytes.begin() + static_cast<std::ptrdiff_t>(tx_offset),
                tx_bytes.begin() + static_cast<std::ptrdiff_t>(tx_offset + t.len), memory.begin());
      tx_offset += t.len;
    }
    const std::vector<std::uint8_t> on_wire = memory_to_wire(memory, bits, lsb_first);
    frame_parts.push_back(&t);
    frame_tx.insert(frame_tx.end(), on_wire.begin(), on_wire.end());
    total += static_cast<int>(t.len);
    // cs_change on a transfer but the last: the chip is deselected after it.
    if (t.cs_change != 0 && i + 1 < transfers.size()) {
      if (const int error = close_frame(); error != 0) return error;
    }
    if (t.delay_usecs != 0) std::this_thread::sleep_for(std::chrono::microseconds(t.delay_usecs));
  }
  if (frame_open) {
    if (const int error = close_frame(); error != 0) return error;
  }
  return total;
}

int SpidevEndpoint::one_frame(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) {
  SpidevState s;
  {
    const std::lock_guard lock(mutex_);
    s = state_;
  }
  if (tx.size() > kBufSize) return -EMSGSIZE;
  if (tx.size() % word_bytes(s.bits_per_word) != 0) return -EINVAL;
  const bool lsb_first = (s.mode & SPI_LSB_FIRST) != 0;
  const SpiWire wire{.mode = static_cast<std::uint8_t>(s.mode & 3u), .speed_hz = s.max_speed_hz,
                     .cs_active_high = (s.mode & SPI_CS_HIGH) != 0};
  const std::vector<std::uint8_t> wire_tx = memory_to_wire(tx, s.bits_per_word, lsb_first);
  std::vector<std::uint8_t> wire_rx(tx.size(), 0);
  if (const int error = target_.transfer(wire, wire_tx, wire_rx); error != 0) return -error;
  const std::vector<std::uint8_t> memory = wire_to_memory(wire_rx, s.bits_per_word, lsb_first);
  std::copy(memory.begin(), memory.end(), rx.begin());
  return static_cast<int>(tx.size());
}

int SpidevEndpoint::write(std::span<const std::uint8_t> tx) {
  std::vector<std::uint8_t> rx(tx.size());
  return one_frame(tx, rx);
}

int SpidevEndpoint::read(std::span<std::uint8_t> rx) {
  if (rx.size() > kBufSize) return -EMSGSIZE;
  const std::vector<std::uint8_t> tx(rx.size(), 0);
  return one_frame(tx, rx);
}

}  // namespace gyrotc::emu
