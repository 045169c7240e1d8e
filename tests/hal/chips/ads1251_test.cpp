#include "gyrotc/hal/chips/ads1251.hpp"

#include <string>

#include "gyrotc/hal/sim/sim_ads1251.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;

namespace {

struct ConstantInput final : SimAds1251::Input {
  double mv = 0.0;
  double input_mv(double) noexcept override { return mv; }
};

// The ADS1251 driver reading the bit-level simulator at the default
// 384 kHz clock (1 kSPS), 2.5 V reference.
struct Rig {
  ConstantInput input;
  VirtualClock clock;
  SimAds1251 chip{input, clock, {.fclk_hz = 384'000.0, .vref_v = 2.5}};
  Ads1251 adc{chip.spi(), chip.drdy(), Ads1251Config{}};
  Rig() { REQUIRE(adc.init().ok()); }
};

constexpr double kLsbMv = 2500.0 / 8388608.0;

}  // namespace

TEST_CASE("24-bit codes are sign-extended from two's complement") {
  CHECK(Ads1251::sign_extend_24(0x000000) == 0);
  CHECK(Ads1251::sign_extend_24(0x000001) == 1);
  CHECK(Ads1251::sign_extend_24(0x7FFFFF) == 8388607);
  CHECK(Ads1251::sign_extend_24(0x800000) == -8388608);
  CHECK(Ads1251::sign_extend_24(0xFFFFFF) == -1);
  CHECK(Ads1251::sign_extend_24(0xFF123456) == Ads1251::sign_extend_24(0x123456));  // only 24 bits count
}

TEST_CASE("a positive input is framed MSB first and converted back to mV") {
  Rig rig;
  rig.input.mv = 101.6788;
  const auto sample = rig.adc.read(0.01);
  REQUIRE(sample.ok());
  CHECK(sample->code == rig.chip.code_for_mv(101.6788));
  CHECK(sample->gyro_mv == Approx(101.6788).margin(kLsbMv));
  CHECK_FALSE(sample->clipped);
}

TEST_CASE("a negative input reads as a negative code") {
  Rig rig;
  rig.input.mv = -1234.5;
  const auto sample = rig.adc.read(0.01);
  REQUIRE(sample.ok());
  CHECK(sample->code < 0);
  CHECK(sample->gyro_mv == Approx(-1234.5).margin(kLsbMv));
}

TEST_CASE("inputs beyond +/- Vref clip at full scale and are flagged") {
  Rig rig;
  rig.input.mv = 2600.0;
  auto high = rig.adc.read(0.01);
  REQUIRE(high.ok());
  CHECK(high->code == Ads1251::kCodeMax);
  CHECK(high->clipped);
  rig.input.mv = -3000.0;
  auto low = rig.adc.read(0.01);
  REQUIRE(low.ok());
  CHECK(low->code == Ads1251::kCodeMin);
  CHECK(low->clipped);
  CHECK(low->gyro_mv == Approx(-2500.0));
}

TEST_CASE("samples are stamped with their DRDY edge, one every 384 clock periods") {
  Rig rig;
  const auto a = rig.adc.read(0.01);
  const auto b = rig.adc.read(0.01);
  REQUIRE(a.ok());
  REQUIRE(b.ok());
  CHECK(a->time_s == Approx(0.001));
  CHECK(b->time_s - a->time_s == Approx(0.001));
  CHECK(rig.clock.now_s() == Approx(0.002));
}

TEST_CASE("a stalled DRDY line times out after the timeout, with a timeout error") {
  Rig rig;
  rig.chip.set_drdy_stall(true);
  const auto sample = rig.adc.read(0.005);
  REQUIRE_FALSE(sample.ok());
  CHECK(sample.error().code() == ErrorCode::timeout);
  CHECK(std::string(sample.error().message()).find("DRDY") != std::string::npos);
  CHECK(rig.clock.now_s() == Approx(0.005));
  rig.chip.set_drdy_stall(false);
  CHECK(rig.adc.read(0.005).ok());
}

TEST_CASE("a timeout shorter than the next conversion is a timeout") {
  Rig rig;
  const auto sample = rig.adc.read(0.0005);
  REQUIRE_FALSE(sample.ok());
  CHECK(sample.error().code() == ErrorCode::timeout);
}

TEST_CASE("an SPI failure is reported as an i/o error") {
  Rig rig;
  rig.chip.set_spi_error(true);
  const auto sample = rig.adc.read(0.01);
  REQUIRE_FALSE(sample.ok());
  CHECK(sample.error().code() == ErrorCode::io);
}

TEST_CASE("a read after the DOUT window mixes two conversions") {
  ConstantInput input;
  VirtualClock clock;
  SimAds1251 chip{input, clock, {}};
  REQUIRE(chip.spi().configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  input.mv = 100.0;
  REQUIRE(chip.drdy().wait_edge(Edge::falling, 0.01).ok());
  input.mv = -100.0;  // the next conversion differs
  clock.sleep_until(clock.now_s() + 0.95e-3);  // past 348/384 kHz = 906 us
  std::array<std::uint8_t, 3> tx{}, rx{};
  REQUIRE(chip.spi().transfer(tx, rx).ok());
  const std::int32_t code = Ads1251::sign_extend_24(static_cast<std::uint32_t>(rx[0]) << 16 | rx[1] << 8 | rx[2]);
  CHECK(code != chip.code_for_mv(100.0));
  CHECK(code != chip.code_for_mv(-100.0));
  CHECK(chip.late_reads() == 1);
}

TEST_CASE("the simulator refuses SPI modes other than mode 0") {
  ConstantInput input;
  VirtualClock clock;
  SimAds1251 chip{input, clock, {}};
  CHECK_FALSE(chip.spi().configure({.mode = 1, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  CHECK_FALSE(chip.spi().configure({.mode = 3, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
}

TEST_CASE("an ADC clock whose DOUT window is shorter than the latency budget is refused, saying why") {
  // 7.68 MHz (the datasheet's 20 kSPS): window 348/7.68 MHz = 45 us.
  const Status fast = Ads1251::validate({.fclk_hz = 7'680'000.0, .vref_v = 2.5, .spi_speed_hz = 1'000'000,
                                         .latency_budget_s = 300e-6});
  REQUIRE_FALSE(fast.ok());
  CHECK(fast.error().code() == ErrorCode::invalid_config);
  const std::string message(fast.error().message());
  CHECK(message.find("DOUT window is 45.3 us") != std::string::npos);
  CHECK(message.find("latency budget 300.0 us") != std::string::npos);
  CHECK(Ads1251::validate(Ads1251Config{}).ok());  // 384 kHz: 906 us window
}

TEST_CASE("the SPI transfer time counts against the DOUT window") {
  // 906 us window, 300 us budget: 24 bits at 30 kHz take 800 us.
  CHECK_FALSE(Ads1251::validate({.fclk_hz = 384'000.0, .vref_v = 2.5, .spi_speed_hz = 30'000,
                                 .latency_budget_s = 300e-6})
                  .ok());
}

TEST_CASE("init refuses an unreadable configuration before touching the bus") {
  ConstantInput input;
  VirtualClock clock;
  SimAds1251 chip{input, clock, {}};
  Ads1251 adc{chip.spi(), chip.drdy(), {.fclk_hz = 7'680'000.0}};
  CHECK_FALSE(adc.init().ok());
  CHECK_FALSE(adc.read(0.01).ok());  // the bus was never configured
}
