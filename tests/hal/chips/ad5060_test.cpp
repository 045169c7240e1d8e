#include "gyrotc/hal/chips/ad5060.hpp"

#include <array>
#include <cmath>

#include "gyrotc/hal/sim/sim_ad5060.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;

TEST_CASE("a frame is 6 don't-care bits, PD1 PD0 and 16 data bits") {
  CHECK(Ad5060::frame(0x1234, Ad5060PowerDown::normal) == 0x001234u);
  CHECK(Ad5060::frame(0xFFFF, Ad5060PowerDown::normal) == 0x00FFFFu);
  CHECK(Ad5060::frame(0x1234, Ad5060PowerDown::gnd_1k) == 0x011234u);
  CHECK(Ad5060::frame(0x1234, Ad5060PowerDown::gnd_100k) == 0x021234u);
  CHECK(Ad5060::frame(0x1234, Ad5060PowerDown::three_state) == 0x031234u);
}

TEST_CASE("volts map to straight binary codes, clamped to the DAC range") {
  CHECK(Ad5060::code_for_v(1.25, 2.5) == 32768);
  CHECK(Ad5060::code_for_v(0.0, 2.5) == 0);
  CHECK(Ad5060::code_for_v(-0.3, 2.5) == 0);
  CHECK(Ad5060::code_for_v(2.5, 2.5) == 65535);
  CHECK(Ad5060::code_for_v(7.0, 2.5) == 65535);
  CHECK(Ad5060::code_for_v(2.5 / 65536.0 * 1000.4, 2.5) == 1000);
  CHECK(Ad5060::code_for_v(std::nan(""), 2.5) == 0);
}

TEST_CASE("the driver's frames are decoded by the simulator into the output voltage") {
  SimAd5060 chip{"sim:ad5060", 2.5};
  Ad5060 dac{chip, {.vref_v = 2.5}};
  REQUIRE(dac.init().ok());
  REQUIRE(dac.write_v(1.0).ok());
  CHECK(chip.code() == Ad5060::code_for_v(1.0, 2.5));
  CHECK(chip.mode() == Ad5060PowerDown::normal);
  CHECK(chip.output_v() == Approx(1.0).margin(2.5 / 65536.0));
  CHECK(dac.last_code() == chip.code());
}

TEST_CASE("power-down sends the configured PD bits and the output goes to 0 V") {
  SimAd5060 chip{"sim:ad5060", 2.5};
  Ad5060 dac{chip, {.vref_v = 2.5, .spi_speed_hz = 1'000'000, .power_down_mode = Ad5060PowerDown::gnd_1k}};
  REQUIRE(dac.init().ok());
  REQUIRE(dac.write_v(2.0).ok());
  REQUIRE(dac.power_down().ok());
  CHECK(chip.mode() == Ad5060PowerDown::gnd_1k);
  CHECK(chip.output_v() == 0.0);
  REQUIRE(dac.write_v(2.0).ok());  // any normal-mode write powers it up again
  CHECK(chip.mode() == Ad5060PowerDown::normal);
}

TEST_CASE("the simulator ignores a frame that is not 24 bits long") {
  SimAd5060 chip{"sim:ad5060", 2.5};
  REQUIRE(chip.configure({.mode = 1, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  std::array<std::uint8_t, 2> tx{0x80, 0x00}, rx{};
  REQUIRE(chip.transfer(tx, rx).ok());
  CHECK(chip.ignored_frames() == 1);
  CHECK(chip.frames() == 0);
  CHECK(chip.code() == 0);
}

TEST_CASE("the simulated AD5060 written in SPI mode 0 latches every bit one late: the frame shifted left") {
  SimAd5060 chip{"sim:ad5060", 2.5};
  REQUIRE(chip.configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  const std::array<std::uint8_t, 3> tx{0x00, 0x12, 0x34}, rx_init{};
  std::array<std::uint8_t, 3> rx = rx_init;
  REQUIRE(chip.transfer(tx, rx).ok());
  CHECK(chip.code() == 0x2468);
  Ad5060 dac{chip, {}};
  CHECK(dac.init().ok());  // the driver's own mode 1 then latches right
  REQUIRE(chip.transfer(tx, rx).ok());
  CHECK(chip.code() == 0x1234);
}

TEST_CASE("the simulated AD5060 ignores a frame clocked above its 30 MHz") {
  SimAd5060 chip{"sim:ad5060", 2.5};
  REQUIRE(chip.configure({.mode = 1, .speed_hz = 40'000'000, .bits_per_word = 8}).ok());
  const std::array<std::uint8_t, 3> tx{0x00, 0x12, 0x34};
  std::array<std::uint8_t, 3> rx{};
  REQUIRE(chip.transfer(tx, rx).ok());
  CHECK(chip.ignored_frames() == 1);
  CHECK(chip.code() == 0);
}
