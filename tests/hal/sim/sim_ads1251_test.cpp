// The ADS1251 simulator's pin, driven by hand (no driver): what a reader of
// the DRDY edge events and of the SPI bus sees from the real part.
#include "gyrotc/hal/sim/sim_ads1251.hpp"

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;

namespace {

struct ConstantInput final : SimAds1251::Input {
  double mv = 0.0;
  double input_mv(double) noexcept override { return mv; }
};

constexpr double kTclkS = 1.0 / 384'000.0;
constexpr double kPeriodS = 384.0 * kTclkS;

struct Rig {
  ConstantInput input;
  VirtualClock clock;
  SimAds1251 chip;
  explicit Rig(SimAds1251::Config config = {}) : chip(input, clock, config) {
    REQUIRE(chip.spi().configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  }
  std::int32_t read24() {
    std::array<std::uint8_t, 3> tx{}, rx{};
    REQUIRE(chip.spi().transfer(tx, rx).ok());
    return Ads1251::sign_extend_24(static_cast<std::uint32_t>(rx[0]) << 16 | static_cast<std::uint32_t>(rx[1]) << 8 |
                                   rx[2]);
  }
  double next_falling() {
    const auto edge = chip.drdy().wait_edge(Edge::falling, 0.01);
    REQUIRE(edge.ok());
    return *edge;
  }
};

}  // namespace

TEST_CASE("sim ADS1251: the DRDY pulse falls at the conversion, and a positive code's MSB falls again 12 tCLK later") {
  Rig rig;
  rig.input.mv = 100.0;  // positive: MSB 0
  CHECK(rig.next_falling() == Approx(kPeriodS));
  CHECK(rig.next_falling() == Approx(kPeriodS + 12.0 * kTclkS));  // DOUT mode starts: the MSB pulls the pin low
  CHECK(rig.next_falling() == Approx(2.0 * kPeriodS));
}

TEST_CASE("sim ADS1251: a negative code keeps the pin high after the pulse: one falling edge per conversion") {
  Rig rig;
  rig.input.mv = -100.0;  // MSB 1
  CHECK(rig.next_falling() == Approx(kPeriodS));
  CHECK(rig.next_falling() == Approx(2.0 * kPeriodS));
}

TEST_CASE("sim ADS1251: reading the 24 bits queues a falling edge for every 1-to-0 step of the data") {
  Rig rig;
  rig.input.mv = -100.0;
  const double edge_s = rig.next_falling();
  rig.clock.sleep_until(edge_s + 12.0 * kTclkS);  // DOUT mode
  const std::int32_t code = rig.read24();
  CHECK(code == rig.chip.code_for_mv(-100.0));
  // The pin shows MSB..LSB, then LOW after the 24th SCLK: each 1 -> 0 is an edge.
  const auto bits = static_cast<std::uint32_t>(code) & 0xFFFFFFu;
  int expected = 0;
  for (int i = 23; i >= 0; --i) {
    const bool now = ((bits >> i) & 1u) != 0;
    const bool next = i > 0 && ((bits >> (i - 1)) & 1u) != 0;
    if (now && !next) ++expected;
  }
  REQUIRE(expected > 1);
  const auto dropped = rig.chip.drdy().discard_edges();
  REQUIRE(dropped.ok());
  CHECK(*dropped == expected);
  CHECK(rig.chip.counters().clean_reads == 1);
}

TEST_CASE("sim ADS1251: a second read inside the same DOUT window returns zeros") {
  Rig rig;
  rig.input.mv = 1234.5;
  const double edge_s = rig.next_falling();
  rig.clock.sleep_until(edge_s + 20.0 * kTclkS);
  CHECK(rig.read24() == rig.chip.code_for_mv(1234.5));
  CHECK(rig.read24() == 0);  // the shift pointer is past the 24th bit: the pin stays LOW
  CHECK(rig.chip.counters().corrupted_reads == 1);
}

TEST_CASE("sim ADS1251: a read that starts inside the DRDY pulse returns shifted data") {
  Rig rig;
  rig.input.mv = 1234.5;
  const double edge_s = rig.next_falling();
  rig.clock.sleep_until(edge_s + 1.0 * kTclkS);  // inside t2: before DOUT mode
  CHECK(rig.read24() != rig.chip.code_for_mv(1234.5));
  CHECK(rig.chip.counters().corrupted_reads == 1);
}

TEST_CASE("sim ADS1251: a read after the DOUT window mixes two conversions") {
  struct Ramp final : SimAds1251::Input {
    double input_mv(double t_s) noexcept override { return t_s < 0.0015 ? 100.0 : -100.0; }
  } ramp;
  VirtualClock clock;
  SimAds1251 chip{ramp, clock, {}};
  REQUIRE(chip.spi().configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  REQUIRE(chip.drdy().wait_edge(Edge::falling, 0.01).ok());
  clock.sleep_until(0.001 + 360.0 * kTclkS - 10e-6);  // the last 10 us of DOUT mode: 14 bits are late
  std::array<std::uint8_t, 3> tx{}, rx{};
  REQUIRE(chip.spi().transfer(tx, rx).ok());
  const std::int32_t code = Ads1251::sign_extend_24(static_cast<std::uint32_t>(rx[0]) << 16 | rx[1] << 8 | rx[2]);
  CHECK(code != chip.code_for_mv(100.0));
  CHECK(code != chip.code_for_mv(-100.0));
  CHECK(chip.counters().corrupted_reads == 1);
}

TEST_CASE("sim ADS1251: edges queue while nobody reads, oldest first with their own stamps, at most 16") {
  Rig rig;
  rig.input.mv = -100.0;  // one falling edge per conversion
  rig.clock.sleep_until(30.5 * kPeriodS);  // 30 conversions, nobody reading
  for (int k = 1; k <= 16; ++k) CHECK(rig.next_falling() == Approx(k * kPeriodS));
  CHECK(rig.chip.counters().dropped_events == 14);  // the v1 kfifo keeps the first 16
  CHECK(rig.next_falling() == Approx(31.0 * kPeriodS));
}

TEST_CASE("sim ADS1251: with a both-edge request (uAPI v1) a pulse over before the IRQ thread runs reads as rising") {
  SimAds1251::Config config;
  config.request = SimAds1251::EdgeRequest::both_v1;
  config.timing.irq_delay_max_s = 40e-6;  // the 15.6 us pulse is over in most cases
  Rig rig(config);
  rig.input.mv = -100.0;  // negative: no MSB edge, only the pulse falls
  int falling = 0;
  for (int k = 0; k < 200; ++k) {
    const auto edge = rig.chip.drdy().wait_edge(Edge::falling, 2.0 * kPeriodS);
    if (edge.ok()) ++falling;
  }
  INFO("falling-labelled DRDY pulses: " << falling << " of ~" << rig.clock.now_s() / kPeriodS);
  CHECK(falling > 0);
  CHECK(falling < 0.6 * rig.clock.now_s() / kPeriodS);  // 15.6 of 40 us: ~39 % labelled falling
}

TEST_CASE("sim ADS1251: the reader wakes up a latency after an edge it slept for, at once for a queued one") {
  SimAds1251::Config config;
  config.timing.wake_min_s = 50e-6;
  config.timing.wake_max_s = 50e-6;
  Rig rig(config);
  rig.input.mv = -100.0;
  CHECK(rig.next_falling() == Approx(kPeriodS));
  CHECK(rig.clock.now_s() == Approx(kPeriodS + 50e-6));
  rig.clock.sleep_until(3.5 * kPeriodS);
  CHECK(rig.next_falling() == Approx(2.0 * kPeriodS));
  CHECK(rig.clock.now_s() == Approx(3.5 * kPeriodS));  // already queued: no wait
}

TEST_CASE("sim ADS1251: an event is readable only irq delay after its edge, and a drain takes only readable ones") {
  SimAds1251::Config config;
  config.timing.irq_delay_max_s = 1e-3;
  Rig rig(config);
  rig.input.mv = -100.0;
  rig.clock.sleep_until(kPeriodS + 1e-9);  // the edge happened, its event is (almost surely) in flight
  const auto dropped = rig.chip.drdy().discard_edges();
  REQUIRE(dropped.ok());
  CHECK(*dropped == 0);
  CHECK(rig.next_falling() == Approx(kPeriodS));  // it arrives later, with its own stamp
}

TEST_CASE("sim ADS1251: a stalled DRDY never falls, the pin reads high") {
  Rig rig;
  rig.chip.set_drdy_stall(true);
  const auto edge = rig.chip.drdy().wait_edge(Edge::falling, 0.005);
  REQUIRE_FALSE(edge.ok());
  CHECK(edge.error().code() == ErrorCode::timeout);
  CHECK(*rig.chip.drdy().get());
}

TEST_CASE("sim ADS1251: read in SPI mode 1, 2 or 3 the code comes back shifted left by one bit, counted corrupted") {
  for (const int m : {1, 2, 3}) {
    const auto mode = static_cast<std::uint8_t>(m);
    Rig rig;
    rig.input.mv = 100.0;
    const std::int32_t code = rig.chip.code_for_mv(100.0);
    REQUIRE(rig.chip.spi().configure({.mode = mode, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
    const double edge_s = rig.next_falling();
    rig.clock.sleep_until(edge_s + 12.0 * kTclkS);  // DOUT mode, MSB on the pin
    // Every bit is taken after the part shifted: the MSB is lost, the LSB is the pin after the 24th shift (low).
    CHECK(rig.read24() == Ads1251::sign_extend_24(static_cast<std::uint32_t>(code) << 1 & 0xFFFFFFu));
    CHECK(rig.chip.counters().corrupted_reads == 1);
    CHECK(rig.chip.counters().clean_reads == 0);
  }
}

TEST_CASE("sim ADS1251: with a pin listener every level change reaches it and no edge is queued") {
  struct Recorder final : SimAds1251::PinListener {
    std::vector<std::pair<bool, double>> changes;
    void on_pin_level(bool high, double t_s) noexcept override { changes.emplace_back(high, t_s); }
  } recorder;
  ConstantInput input;
  input.mv = 100.0;  // MSB 0: the pin falls again when DOUT mode starts
  VirtualClock clock;
  SimAds1251::Config config;
  config.pin_listener = &recorder;
  SimAds1251 chip{input, clock, config};
  REQUIRE(chip.spi().configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  // The emulator's pin thread, on time: it wakes at each change the pin announces.
  double next_s = chip.run_pin();
  while (next_s < kPeriodS + 20.0 * kTclkS) {
    clock.sleep_until(next_s);
    next_s = chip.run_pin();
  }
  CHECK(next_s == Approx(kPeriodS + 360.0 * kTclkS));  // next change: the end of DOUT mode
  REQUIRE(recorder.changes.size() == 3);
  CHECK(recorder.changes[0].second == Approx(kPeriodS));
  CHECK_FALSE(recorder.changes[0].first);  // the DRDY pulse ...
  CHECK(recorder.changes[1].first);        // ... its end ...
  CHECK_FALSE(recorder.changes[2].first);  // ... and the MSB (0) when DOUT mode starts
  CHECK(recorder.changes[2].second == Approx(recorder.changes[0].second + 12.0 * kTclkS));
  const auto queued = chip.drdy().wait_edge(Edge::falling, 0.0);
  CHECK_FALSE(queued.ok());  // the kernel queues a real line's edges, not the simulator
}

TEST_CASE("sim ADS1251: an emulated pin that falls late starts its conversion's window when it falls") {
  struct Recorder final : SimAds1251::PinListener {
    std::vector<std::pair<bool, double>> changes;
    void on_pin_level(bool high, double t_s) noexcept override { changes.emplace_back(high, t_s); }
  } recorder;
  ConstantInput input;
  input.mv = 100.0;
  VirtualClock clock;
  SimAds1251::Config config;
  config.pin_listener = &recorder;
  SimAds1251 chip{input, clock, config};
  REQUIRE(chip.spi().configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  const double late_s = kPeriodS + 100.0 * kTclkS;  // the emulator's thread ran 100 tCLK late
  clock.sleep_until(late_s);
  (void)chip.run_pin();
  REQUIRE_FALSE(recorder.changes.empty());
  CHECK(recorder.changes[0].second == Approx(late_s));  // the DRDY edge is when the pin fell
  clock.sleep_until(late_s + 12.0 * kTclkS);
  (void)chip.run_pin();
  std::array<std::uint8_t, 3> tx{}, rx{};
  REQUIRE(chip.spi().transfer(tx, rx).ok());  // 12 tCLK after the real edge: inside its window
  CHECK(chip.counters().clean_reads == 1);
  clock.sleep_until(late_s + 370.0 * kTclkS);  // past this DOUT mode
  CHECK(chip.run_pin() == Approx(late_s + kPeriodS));  // the next conversion a period after the late edge
  CHECK(chip.counters().late_edges == 1);
}

TEST_CASE("sim ADS1251: with a pin listener a read sends each data bit's edge to the line") {
  struct Recorder final : SimAds1251::PinListener {
    int falling = 0;
    void on_pin_level(bool high, double) noexcept override { falling += high ? 0 : 1; }
  } recorder;
  ConstantInput input;
  VirtualClock clock;
  SimAds1251::Config config;
  config.pin_listener = &recorder;
  SimAds1251 chip{input, clock, config};
  // Code 0x555555 (alternating bits, positive): 12 falling edges in the data.
  input.mv = 0x555555 / (8388608.0 / 2500.0);
  REQUIRE(chip.spi().configure({.mode = 0, .speed_hz = 1'000'000, .bits_per_word = 8}).ok());
  double next_s = chip.run_pin();
  while (next_s <= kPeriodS + 12.0 * kTclkS) {  // the pin thread, on time, into DOUT mode
    clock.sleep_until(next_s);
    next_s = chip.run_pin();
  }
  const int before = recorder.falling;  // the pulse and the MSB (0)
  std::array<std::uint8_t, 3> tx{}, rx{};
  REQUIRE(chip.spi().transfer(tx, rx).ok());
  CHECK(rx[0] == 0x55);
  CHECK(before == 2);
  CHECK(recorder.falling - before == 12);  // 1->0 after bits 1, 3, ... 21 (11), and low after the 24th (LSB 1)
}
