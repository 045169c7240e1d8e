// The emulated ADS1251 behind a spidev node and a GPIO line, on a virtual
// clock: the levels it writes to the line (the edges the kernel stamps) and
// what the driver's own SPI calls read through the node.
#include "gyrotc/emu/adc_emulator.hpp"

#include <linux/spi/spidev.h>

#include <array>
#include <cerrno>
#include <utility>
#include <vector>

#include "cuse_kernel.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc;

namespace {

constexpr double kFclkHz = 38'400.0;  // 100 SPS: a part faster than the emulated board's, to keep the test short
constexpr double kTclkS = 1.0 / kFclkHz;
constexpr double kPeriodS = 384.0 * kTclkS;

struct ConstantInput final : hal::SimAds1251::Input {
  double mv = 100.0;
  double input_mv(double) noexcept override { return mv; }
};

// The line's levels as written, with the virtual time of each write.
struct Line final : emu::PinOutput {
  hal::VirtualClock* clock = nullptr;
  std::vector<std::pair<bool, double>> writes;
  void set_level(bool high) noexcept override { writes.emplace_back(high, clock != nullptr ? clock->now_s() : 0.0); }
  std::vector<double> falls() const {
    std::vector<double> t;
    for (std::size_t i = 1; i < writes.size(); ++i) {
      if (writes[i - 1].first && !writes[i].first) t.push_back(writes[i].second);
    }
    return t;
  }
};

struct Rig {
  ConstantInput input;
  hal::VirtualClock clock;
  Line line;
  emu::EventLog log{""};
  std::unique_ptr<emu::AdcEmulator> adc;
  explicit Rig(bool active_low = false) {
    line.clock = &clock;
    adc = std::make_unique<emu::AdcEmulator>(input, clock, hal::Ads1251Config{.fclk_hz = kFclkHz}, line, active_low,
                                             log);
  }
  // The pin thread, on virtual time, up to t_s.
  void run_to(double t_s) {
    for (;;) {
      const double next_s = adc->step();
      if (next_s > t_s) break;
      clock.sleep_until(next_s);
    }
    clock.sleep_until(t_s);
    (void)adc->step();
  }
};

}  // namespace

TEST_CASE("emulated ADS1251: the line idles high and each conversion pulses it low for 6 tCLK") {
  Rig rig;
  rig.input.mv = -100.0;  // negative: the MSB keeps the pin high in DOUT mode
  rig.run_to(3.5 * kPeriodS);
  REQUIRE_FALSE(rig.line.writes.empty());
  CHECK(rig.line.writes.front().first);  // the part's idle level, before any conversion
  const std::vector<double> falls = rig.line.falls();
  REQUIRE(falls.size() == 3);
  CHECK(falls[0] == Approx(kPeriodS));
  CHECK(falls[1] - falls[0] == Approx(kPeriodS));
  // The rise that ends the pulse, 6 tCLK after the fall.
  const auto rise = std::find_if(rig.line.writes.begin(), rig.line.writes.end(),
                                 [&](const auto& w) { return w.first && w.second > falls[0]; });
  REQUIRE(rise != rig.line.writes.end());
  CHECK(rise->second - falls[0] == Approx(6.0 * kTclkS));
}

TEST_CASE("emulated ADS1251: a board that inverts DRDY (drdy_active_low) writes the line inverted") {
  Rig rig(true);
  rig.input.mv = -100.0;
  rig.run_to(1.5 * kPeriodS);
  CHECK_FALSE(rig.line.writes.front().first);  // idle high at the part: low at the SBC
  int rises = 0;
  for (std::size_t i = 1; i < rig.line.writes.size(); ++i) rises += !rig.line.writes[i - 1].first && rig.line.writes[i].first;
  CHECK(rises == 1);  // the DRDY pulse, as a rising edge
}

TEST_CASE("emulated ADS1251: read in mode 0 through the node after the hold-off, the code is the conversion's") {
  Rig rig;
  rig.input.mv = 100.0;
  emu::SpidevEndpoint node("/dev/spidev0.0", *rig.adc);
  test::CuseSpiBus bus(node);
  REQUIRE(bus.configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  rig.run_to(kPeriodS + 12.0 * kTclkS);
  std::array<std::uint8_t, 3> tx{}, rx{};
  REQUIRE(bus.transfer(tx, rx).ok());
  const std::uint32_t code = static_cast<std::uint32_t>(rx[0]) << 16 | static_cast<std::uint32_t>(rx[1]) << 8 | rx[2];
  CHECK(hal::Ads1251::sign_extend_24(code) == static_cast<std::int32_t>(100.0 * 8388608.0 / 2500.0 + 0.5));
  CHECK(rig.adc->stats().chip.clean_reads == 1);
}

TEST_CASE("emulated ADS1251: read in SPI mode 1 the code comes back shifted, and the read counts corrupted") {
  Rig rig;
  rig.input.mv = 100.0;
  emu::SpidevEndpoint node("/dev/spidev0.0", *rig.adc);
  test::CuseSpiBus bus(node);
  REQUIRE(bus.configure({.mode = 1, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  rig.run_to(kPeriodS + 12.0 * kTclkS);
  std::array<std::uint8_t, 3> tx{}, rx{};
  REQUIRE(bus.transfer(tx, rx).ok());
  const std::uint32_t code = static_cast<std::uint32_t>(rx[0]) << 16 | static_cast<std::uint32_t>(rx[1]) << 8 | rx[2];
  const auto right = static_cast<std::uint32_t>(100.0 * 8388608.0 / 2500.0 + 0.5);
  CHECK(code == ((right << 1) & 0xFFFFFFu));
  CHECK(rig.adc->stats().chip.corrupted_reads == 1);
}

TEST_CASE("emulated ADS1251: a read writes each data bit's edge to the line before the ioctl returns") {
  Rig rig;
  rig.input.mv = 0x555555 / (8388608.0 / 2500.0);  // alternating bits
  emu::SpidevEndpoint node("/dev/spidev0.0", *rig.adc);
  test::CuseSpiBus bus(node);
  REQUIRE(bus.configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  rig.run_to(kPeriodS + 12.0 * kTclkS);
  const std::size_t before = rig.line.falls().size();
  std::array<std::uint8_t, 3> tx{}, rx{};
  REQUIRE(bus.transfer(tx, rx).ok());
  CHECK(rig.line.falls().size() - before == 12);
}

TEST_CASE("emulated ADS1251: a DRDY stall keeps the line high, and released the conversions come back") {
  Rig rig;
  rig.input.mv = -100.0;
  rig.adc->set_drdy_stall(true);
  rig.run_to(5.0 * kPeriodS);
  CHECK(rig.line.falls().empty());
  rig.adc->set_drdy_stall(false);
  rig.run_to(7.5 * kPeriodS);
  CHECK(rig.line.falls().size() == 2);
}

TEST_CASE("emulated ADS1251: an injected SPI error fails the transfer with EIO") {
  Rig rig;
  emu::SpidevEndpoint node("/dev/spidev0.0", *rig.adc);
  test::CuseSpiBus bus(node);
  REQUIRE(bus.configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  rig.adc->set_spi_error(true);
  std::array<std::uint8_t, 3> tx{}, rx{};
  const hal::Status s = bus.transfer(tx, rx);
  REQUIRE_FALSE(s.ok());
  CHECK(s.error().code() == hal::ErrorCode::io);
}
