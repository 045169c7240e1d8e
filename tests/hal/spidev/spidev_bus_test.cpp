#include "gyrotc/hal/linux/spidev_bus.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc/hal/sim/sim_ads1251.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"
#include "gyrotc_catch.hpp"
#include "spidev_interposer.hpp"

using namespace gyrotc::hal;

namespace {

struct ConstantInput final : SimAds1251::Input {
  double mv = 0.0;
  double input_mv(double) noexcept override { return mv; }
};

// /dev/spidev0.0 answered by an ADS1251 simulator for the test's lifetime.
struct Rig {
  ConstantInput input;
  VirtualClock clock;
  SimAds1251 chip{input, clock, {}};
  FakeSpidev fake;
  Rig() {
    fake.device = &chip.spi();
    FakeSpidev::armed() = &fake;
  }
  ~Rig() { FakeSpidev::armed() = nullptr; }
};

}  // namespace

TEST_CASE("a missing spidev path is an error naming the path and the errno text") {
  const auto bus = SpidevBus::open("/dev/spidev-gyrotc-missing9.9");
  REQUIRE_FALSE(bus.ok());
  CHECK(bus.error().code() == ErrorCode::not_found);
  CHECK(bus.error().errno_value() == ENOENT);
  CHECK(std::string(bus.error().message()) ==
        "cannot open spidev '/dev/spidev-gyrotc-missing9.9': No such file or directory");
}

TEST_CASE("a path that is not a spidev device fails at the first ioctl, naming it") {
  // A file of this process's own (not /dev/null: parallel tests would share its lock).
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("gyrotc-not-spidev-" + std::to_string(::getpid())))
                               .string();
  std::ofstream(path) << "";
  auto bus = SpidevBus::open(path);
  std::filesystem::remove(path);
  REQUIRE(bus.ok());
  const Status s = bus.value()->configure({});
  REQUIRE_FALSE(s.ok());
  const std::string message(s.error().message());
  CHECK(message.find("SPI_IOC_WR_MODE on '" + path + "'") != std::string::npos);
  // ENOTTY natively; qemu-user answers unknown ioctls with ENOSYS.
  REQUIRE(s.error().errno_value() != 0);
  CHECK(message.find(std::strerror(s.error().errno_value())) != std::string::npos);
}

TEST_CASE("the device is opened read-write and closed with the bus") {
  Rig rig;
  {
    auto bus = SpidevBus::open("/dev/spidev0.0");
    REQUIRE(bus.ok());
    CHECK((rig.fake.open_flags & O_ACCMODE) == O_RDWR);
    CHECK_FALSE(rig.fake.closed);
  }
  CHECK(rig.fake.closed);
}

TEST_CASE("configure sets mode, bits per word and speed through the spidev ioctls") {
  Rig rig;
  auto bus = SpidevBus::open("/dev/spidev0.0");
  REQUIRE(bus.ok());
  REQUIRE(bus.value()->configure({.mode = 1, .speed_hz = 2'000'000, .bits_per_word = 8}).ok());
  CHECK(rig.fake.mode == SPI_MODE_1);
  CHECK(rig.fake.bits_per_word == 8);
  CHECK(rig.fake.max_speed_hz == 2'000'000u);
}

TEST_CASE("a failing ioctl is an error naming the request, the path and the errno text") {
  Rig rig;
  rig.fake.fail_request = SPI_IOC_WR_MAX_SPEED_HZ;
  rig.fake.fail_errno = EINVAL;
  auto bus = SpidevBus::open("/dev/spidev0.0");
  REQUIRE(bus.ok());
  const Status s = bus.value()->configure({});
  REQUIRE_FALSE(s.ok());
  CHECK(std::string(s.error().message()) == "SPI_IOC_WR_MAX_SPEED_HZ on '/dev/spidev0.0': Invalid argument");
}

TEST_CASE("the ADS1251 driver reads through SPI_IOC_MESSAGE with a zero-initialised transfer") {
  Rig rig;
  auto bus = SpidevBus::open("/dev/spidev0.0");
  REQUIRE(bus.ok());
  Ads1251 adc{*bus.value(), rig.chip.drdy(), rig.clock, Ads1251Config{}};
  REQUIRE(adc.init().ok());
  CHECK(rig.fake.mode == SPI_MODE_0);
  rig.input.mv = -321.5;
  const auto sample = adc.read(0.01);
  REQUIRE(sample.ok());
  CHECK(sample->code == rig.chip.code_for_mv(-321.5));
  CHECK(sample->gyro_mv == Approx(-321.5).margin(1e-3));

  const spi_ioc_transfer& t = rig.fake.last;
  CHECK(rig.fake.messages == 1);
  CHECK(rig.fake.bad_messages == 0);
  CHECK(t.len == 3);
  CHECK(t.tx_buf != 0);
  CHECK(t.rx_buf != 0);
  CHECK(t.tx_buf != t.rx_buf);
  CHECK(t.speed_hz == 1'000'000u);
  CHECK(t.bits_per_word == 8);
  CHECK(t.delay_usecs == 0);
  CHECK(t.cs_change == 0);
  CHECK(t.tx_nbits == 0);
  CHECK(t.rx_nbits == 0);
  CHECK(t.word_delay_usecs == 0);
  CHECK(t.pad == 0);
}

TEST_CASE("a failed SPI_IOC_MESSAGE is an error with the errno text") {
  Rig rig;
  auto bus = SpidevBus::open("/dev/spidev0.0");
  REQUIRE(bus.ok());
  REQUIRE(bus.value()->configure({}).ok());
  rig.chip.set_spi_error(true);
  std::array<std::uint8_t, 3> tx{}, rx{};
  const Status s = bus.value()->transfer(tx, rx);
  REQUIRE_FALSE(s.ok());
  CHECK(std::string(s.error().message()) == "SPI_IOC_MESSAGE on '/dev/spidev0.0': Input/output error");
}

TEST_CASE("unequal tx and rx are refused before any ioctl") {
  Rig rig;
  auto bus = SpidevBus::open("/dev/spidev0.0");
  REQUIRE(bus.ok());
  std::array<std::uint8_t, 3> tx{};
  std::array<std::uint8_t, 2> rx{};
  CHECK_FALSE(bus.value()->transfer(tx, rx).ok());
  CHECK(rig.fake.messages == 0);
}
