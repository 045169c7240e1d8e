// The emulated spidev node's ioctls, driven through CUSE's unrestricted
// protocol as the kernel drives them (support/cuse_kernel.hpp).
#include "gyrotc/emu/spidev_endpoint.hpp"

#include <linux/spi/spidev.h>

#include <array>
#include <cerrno>
#include <cstdint>
#include <vector>

#include "cuse_kernel.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc;
using gyrotc::test::cuse_ioctl;

namespace {

// A chip that records each frame's wire bytes and settings and answers with
// the bytes it was sent, each plus one.
struct Recorder final : emu::SpiTarget {
  std::vector<std::vector<std::uint8_t>> frames;
  std::vector<emu::SpiWire> wires;
  int fail_with = 0;
  int transfer(const emu::SpiWire& wire, std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) override {
    if (fail_with != 0) return fail_with;
    frames.emplace_back(tx.begin(), tx.end());
    wires.push_back(wire);
    for (std::size_t i = 0; i < tx.size(); ++i) rx[i] = static_cast<std::uint8_t>(tx[i] + 1);
    return 0;
  }
};

}  // namespace

TEST_CASE("emulated spidev: SPI_IOC_MESSAGE(1) fetches the transfer, then its buffers, and returns the rx bytes") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  const std::array<std::uint8_t, 3> tx{0x10, 0x20, 0x30};
  std::array<std::uint8_t, 3> rx{};
  spi_ioc_transfer t{};
  t.tx_buf = reinterpret_cast<std::uintptr_t>(tx.data());
  t.rx_buf = reinterpret_cast<std::uintptr_t>(rx.data());
  t.len = 3;
  t.speed_hz = 1'000'000;
  const auto r = cuse_ioctl(node, SPI_IOC_MESSAGE(1), &t);
  CHECK(r.result == 3);           // spidev returns the bytes transferred
  CHECK(r.round_trips == 3);      // nothing, the transfer, the transfer with its buffers
  REQUIRE(chip.frames.size() == 1);
  CHECK(chip.frames[0] == std::vector<std::uint8_t>{0x10, 0x20, 0x30});
  CHECK(rx == std::array<std::uint8_t, 3>{0x11, 0x21, 0x31});
  CHECK(chip.wires[0].speed_hz == 1'000'000);
}

TEST_CASE("emulated spidev: the mode set with SPI_IOC_WR_MODE reaches the wire and reads back") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev6.0", chip);
  std::uint8_t mode = SPI_MODE_1;
  REQUIRE(cuse_ioctl(node, SPI_IOC_WR_MODE, &mode).result == 0);
  std::uint8_t back = 0xFF;
  REQUIRE(cuse_ioctl(node, SPI_IOC_RD_MODE, &back).result == 0);
  CHECK(back == SPI_MODE_1);
  std::array<std::uint8_t, 3> tx{}, rx{};
  REQUIRE(node.write(tx) == 3);
  CHECK(chip.wires.back().mode == 1);
  (void)rx;
}

TEST_CASE("emulated spidev: mode bits the controller lacks are refused with EINVAL, as spi_setup does") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  std::uint8_t mode = SPI_3WIRE;
  CHECK(cuse_ioctl(node, SPI_IOC_WR_MODE, &mode).result == -EINVAL);
  std::uint8_t back = 0xFF;
  REQUIRE(cuse_ioctl(node, SPI_IOC_RD_MODE, &back).result == 0);
  CHECK(back == 0);  // unchanged
}

TEST_CASE("emulated spidev: a maximum speed of 0 is EINVAL, and a speed set reads back") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  std::uint32_t speed = 0;
  CHECK(cuse_ioctl(node, SPI_IOC_WR_MAX_SPEED_HZ, &speed).result == -EINVAL);
  speed = 2'000'000;
  REQUIRE(cuse_ioctl(node, SPI_IOC_WR_MAX_SPEED_HZ, &speed).result == 0);
  std::uint32_t back = 0;
  REQUIRE(cuse_ioctl(node, SPI_IOC_RD_MAX_SPEED_HZ, &back).result == 0);
  CHECK(back == 2'000'000);
}

TEST_CASE("emulated spidev: a transfer's speed 0 means the device's") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  std::uint32_t speed = 500'000;
  REQUIRE(cuse_ioctl(node, SPI_IOC_WR_MAX_SPEED_HZ, &speed).result == 0);
  std::array<std::uint8_t, 2> tx{1, 2};
  spi_ioc_transfer t{};
  t.tx_buf = reinterpret_cast<std::uintptr_t>(tx.data());
  t.len = 2;
  REQUIRE(cuse_ioctl(node, SPI_IOC_MESSAGE(1), &t).result == 2);
  CHECK(chip.wires.back().speed_hz == 500'000);
}

TEST_CASE("emulated spidev: an unknown command is ENOTTY") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  int dummy = 0;
  CHECK(cuse_ioctl(node, 0x5401 /* TCGETS */, &dummy).result == -ENOTTY);
}

TEST_CASE("emulated spidev: 16-bit words are stored in the CPU's order and clocked MSB first") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  std::uint8_t bits = 16;
  REQUIRE(cuse_ioctl(node, SPI_IOC_WR_BITS_PER_WORD, &bits).result == 0);
  const std::uint16_t word = 0x1234;  // in memory (little-endian): 34 12
  std::array<std::uint8_t, 2> tx{};
  std::memcpy(tx.data(), &word, 2);
  std::array<std::uint8_t, 2> rx{};
  spi_ioc_transfer t{};
  t.tx_buf = reinterpret_cast<std::uintptr_t>(tx.data());
  t.rx_buf = reinterpret_cast<std::uintptr_t>(rx.data());
  t.len = 2;
  REQUIRE(cuse_ioctl(node, SPI_IOC_MESSAGE(1), &t).result == 2);
  CHECK(chip.frames.back() == std::vector<std::uint8_t>{0x12, 0x34});  // on the wire: MSB first
  std::uint16_t back = 0;
  std::memcpy(&back, rx.data(), 2);
  CHECK(back == 0x1335);  // the chip's reply (each wire byte + 1) as a word again
}

TEST_CASE("emulated spidev: 3 bytes of 16-bit words are EINVAL, and nothing is clocked") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  std::uint8_t bits = 16;
  REQUIRE(cuse_ioctl(node, SPI_IOC_WR_BITS_PER_WORD, &bits).result == 0);
  std::array<std::uint8_t, 3> tx{};
  spi_ioc_transfer t{};
  t.tx_buf = reinterpret_cast<std::uintptr_t>(tx.data());
  t.len = 3;
  CHECK(cuse_ioctl(node, SPI_IOC_MESSAGE(1), &t).result == -EINVAL);
  CHECK(chip.frames.empty());
}

TEST_CASE("emulated spidev: LSB first reverses each byte's bits on the wire") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  std::uint8_t on = 1;
  REQUIRE(cuse_ioctl(node, SPI_IOC_WR_LSB_FIRST, &on).result == 0);
  const std::array<std::uint8_t, 1> tx{0x01};
  REQUIRE(node.write(tx) == 1);
  CHECK(chip.frames.back() == std::vector<std::uint8_t>{0x80});
}

TEST_CASE("emulated spidev: more than bufsiz (4096) bytes in one message is EMSGSIZE") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  std::vector<std::uint8_t> tx(5000);
  spi_ioc_transfer t{};
  t.tx_buf = reinterpret_cast<std::uintptr_t>(tx.data());
  t.len = 5000;
  CHECK(cuse_ioctl(node, SPI_IOC_MESSAGE(1), &t).result == -EMSGSIZE);
}

TEST_CASE("emulated spidev: transfers of one message share a chip select unless cs_change") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  std::array<std::uint8_t, 2> a{1, 2}, b{3, 4}, c{5, 6};
  std::array<spi_ioc_transfer, 3> t{};
  for (auto [i, buf] : {std::pair<int, std::uint8_t*>{0, a.data()}, {1, b.data()}, {2, c.data()}}) {
    t[static_cast<std::size_t>(i)].tx_buf = reinterpret_cast<std::uintptr_t>(buf);
    t[static_cast<std::size_t>(i)].len = 2;
  }
  t[1].cs_change = 1;  // deselect after the second
  REQUIRE(cuse_ioctl(node, SPI_IOC_MESSAGE(3), t.data()).result == 6);
  REQUIRE(chip.frames.size() == 2);
  CHECK(chip.frames[0] == std::vector<std::uint8_t>{1, 2, 3, 4});
  CHECK(chip.frames[1] == std::vector<std::uint8_t>{5, 6});
}

TEST_CASE("emulated spidev: a controller error reaches the caller as its errno") {
  Recorder chip;
  chip.fail_with = EIO;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  std::array<std::uint8_t, 3> tx{};
  spi_ioc_transfer t{};
  t.tx_buf = reinterpret_cast<std::uintptr_t>(tx.data());
  t.len = 3;
  CHECK(cuse_ioctl(node, SPI_IOC_MESSAGE(1), &t).result == -EIO);
}

TEST_CASE("emulated spidev: an empty message (SPI_IOC_MESSAGE(0)) does nothing and returns 0") {
  Recorder chip;
  emu::SpidevEndpoint node("/dev/spidev0.0", chip);
  int dummy = 0;
  CHECK(cuse_ioctl(node, SPI_IOC_MESSAGE(0), &dummy).result == 0);
  CHECK(chip.frames.empty());
}
