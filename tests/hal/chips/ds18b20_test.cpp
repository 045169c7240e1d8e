#include "gyrotc/hal/chips/ds18b20.hpp"

#include <array>
#include <cstdio>
#include <string>

#include "gyrotc/hal/sim/sim_ds18b20.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;

namespace {

// A w1_slave file as w1_therm prints it, for 9 bytes given as text.
std::string w1_slave(const std::string& bytes, const std::string& crc, const std::string& verdict,
                     const std::string& t) {
  return bytes + " : crc=" + crc + " " + verdict + "\n" + bytes + " t=" + t + "\n";
}

const std::string kGood = w1_slave("72 01 4b 46 7f ff 0e 10 57", "57", "YES", "23125");

std::string text_of(const std::array<std::uint8_t, 9>& pad, bool crc_ok = true) {
  std::array<char, 256> out{};
  return {out.data(), SimDs18b20::render(W1File::w1_slave, pad, crc_ok, out)};
}

struct SensorRig {
  VirtualClock clock;
  SimDs18b20 chip{"28-000005e2fdc3", 25.0};
  Ds18b20 sensor{chip, clock, Ds18b20Options{}};
};

}  // namespace

TEST_CASE("CRC8 (Dallas/Maxim) of a real scratchpad checks to zero") {
  const std::array<std::uint8_t, 9> pad{0x72, 0x01, 0x4b, 0x46, 0x7f, 0xff, 0x0e, 0x10, 0x57};
  CHECK(crc8_maxim(std::span<const std::uint8_t>(pad.data(), 8)) == 0x57);
  CHECK(crc8_maxim(pad) == 0);
  const std::array<std::uint8_t, 9> power_on{0x50, 0x05, 0x4b, 0x46, 0x7f, 0xff, 0x0c, 0x10, 0x1c};
  CHECK(crc8_maxim(power_on) == 0);
}

TEST_CASE("a good w1_slave file parses into scratchpad, kernel verdict and millidegrees") {
  const auto slave = parse_w1_slave(kGood);
  REQUIRE(slave.ok());
  CHECK(slave->scratchpad[0] == 0x72);
  CHECK(slave->scratchpad[8] == 0x57);
  CHECK(slave->kernel_crc_ok);
  CHECK(slave->t_milli_c == 23125);
  SensorRig rig;
  const auto reading = rig.sensor.evaluate(kGood, 4.0);
  CHECK(reading.valid);
  CHECK(reading.temp_c == Approx(23.125));
  CHECK(reading.time_s == 4.0);
}

TEST_CASE("a negative temperature parses") {
  SensorRig rig;
  const auto reading = rig.sensor.evaluate(text_of(SimDs18b20::scratchpad_for(-10.125)), 0.0);
  REQUIRE(reading.valid);
  CHECK(reading.temp_c == Approx(-10.125));
}

TEST_CASE("the kernel's crc=NO is a CRC fault") {
  SensorRig rig;
  const auto reading = rig.sensor.evaluate(w1_slave("72 01 4b 46 7f ff 0e 10 57", "57", "NO", "23125"), 0.0);
  CHECK_FALSE(reading.valid);
  CHECK(reading.fault == TempFault::crc);
}

TEST_CASE("our own CRC check catches a scratchpad the kernel line calls YES") {
  SensorRig rig;
  const auto reading = rig.sensor.evaluate(w1_slave("73 01 4b 46 7f ff 0e 10 57", "57", "YES", "23187"), 0.0);
  CHECK_FALSE(reading.valid);
  CHECK(reading.fault == TempFault::crc);
}

TEST_CASE("an all-zero scratchpad passes a naive CRC but is a bus-held-low fault") {
  const std::array<std::uint8_t, 9> zeros{};
  CHECK(crc8_maxim(zeros) == 0);  // why it needs its own check
  SensorRig rig;
  const auto reading = rig.sensor.evaluate(w1_slave("00 00 00 00 00 00 00 00 00", "00", "YES", "0"), 0.0);
  CHECK_FALSE(reading.valid);
  CHECK(reading.fault == TempFault::all_zero);
}

TEST_CASE("85.000 C right after power-on is the power-on value, not a temperature") {
  SensorRig rig;
  const auto reading = rig.sensor.evaluate(w1_slave("50 05 4b 46 7f ff 0c 10 1c", "1c", "YES", "85000"), 0.0);
  CHECK_FALSE(reading.valid);
  CHECK(reading.fault == TempFault::power_on_value);
  CHECK(reading.temp_c == 85.0);
}

TEST_CASE("85.000 C is accepted when the previous reading was near 85 C") {
  SensorRig rig;
  REQUIRE(rig.sensor.evaluate(text_of(SimDs18b20::scratchpad_for(84.5)), 0.0).valid);
  const auto reading = rig.sensor.evaluate(text_of(SimDs18b20::scratchpad_for(85.0)), 2.0);
  CHECK(reading.valid);
  CHECK(reading.temp_c == 85.0);
}

TEST_CASE("85.000 C after a reading far from 85 C is still the power-on value") {
  SensorRig rig;
  REQUIRE(rig.sensor.evaluate(kGood, 0.0).valid);
  CHECK(rig.sensor.evaluate(text_of(SimDs18b20::scratchpad_for(85.0)), 2.0).fault == TempFault::power_on_value);
}

TEST_CASE("a value outside -55..125 C is out of range") {
  // 0x0800 = 128 C, with a correct CRC.
  std::array<std::uint8_t, 9> pad{0x00, 0x08, 0x4b, 0x46, 0x7f, 0xff, 0x0c, 0x10, 0};
  pad[8] = crc8_maxim(std::span<const std::uint8_t>(pad.data(), 8));
  SensorRig rig;
  const auto reading = rig.sensor.evaluate(text_of(pad), 0.0);
  CHECK_FALSE(reading.valid);
  CHECK(reading.fault == TempFault::out_of_range);
}

TEST_CASE("an empty read is its own fault") {
  SensorRig rig;
  CHECK(rig.sensor.evaluate("", 0.0).fault == TempFault::empty_read);
  CHECK(rig.sensor.evaluate("\n", 0.0).fault == TempFault::empty_read);
}

TEST_CASE("text that is not the kernel's format is a parse error") {
  SensorRig rig;
  CHECK(rig.sensor.evaluate("hello\nworld\n", 0.0).fault == TempFault::parse_error);
  CHECK(rig.sensor.evaluate("72 01 4b 46 7f ff 0e 10 57 : crc=57 YES\n", 0.0).fault == TempFault::parse_error);
  CHECK(rig.sensor.evaluate(w1_slave("72 01 4b 46 7f ff 0e 10 57", "57", "MAYBE", "23125"), 0.0).fault ==
        TempFault::parse_error);
  CHECK(rig.sensor.evaluate(w1_slave("72 01 4b 46 7f ff 0e 10 57", "57", "YES", "23x"), 0.0).fault ==
        TempFault::parse_error);
  CHECK_FALSE(parse_w1_slave("72 01 4b 46 7f ff 0e 10 : crc=57 YES\n72 01 4b 46 7f ff 0e 10 57 t=1\n").ok());
}

TEST_CASE("the temperature file is one integer in millidegrees") {
  CHECK(*parse_temperature_file("23125\n") == 23125);
  CHECK(*parse_temperature_file("-1062\n") == -1062);
  CHECK_FALSE(parse_temperature_file("23.125\n").ok());
  CHECK_FALSE(parse_temperature_file("abc").ok());
}

TEST_CASE("an unchanged value for longer than stuck_after_s is a stuck sensor") {
  VirtualClock clock;
  SimDs18b20 chip;
  Ds18b20 sensor{chip, clock, {.stuck_after_s = 60.0}};
  CHECK(sensor.evaluate(kGood, 0.0).valid);
  CHECK(sensor.evaluate(kGood, 59.0).valid);
  const auto stuck = sensor.evaluate(kGood, 61.0);
  CHECK_FALSE(stuck.valid);
  CHECK(stuck.fault == TempFault::stuck);
  CHECK(sensor.evaluate(text_of(SimDs18b20::scratchpad_for(23.1875)), 63.0).valid);  // it moved again
}

TEST_CASE("the driver reads the simulator's temperature in 1/16 C steps, stamped at conversion start") {
  SensorRig rig;
  rig.chip.set_temperature_c(23.4);  // 374.4 / 16 -> 374 / 16
  rig.clock.sleep_until(12.0);
  const auto reading = rig.sensor.read();
  REQUIRE(reading.valid);
  CHECK(reading.temp_c == Approx(23.375));
  CHECK(reading.time_s == 12.0);
}

TEST_CASE("injected sensor faults come out as their typed faults") {
  SensorRig rig;
  rig.chip.set_temperature_c(30.0);
  REQUIRE(rig.sensor.read().valid);
  rig.chip.set_fault(SimTempFault::crc_error);
  CHECK(rig.sensor.read().fault == TempFault::crc);
  rig.chip.set_fault(SimTempFault::all_zero);
  CHECK(rig.sensor.read().fault == TempFault::all_zero);
  rig.chip.set_fault(SimTempFault::disconnect);
  CHECK(rig.sensor.read().fault == TempFault::missing_device);
  rig.chip.set_fault(SimTempFault::power_on_reset);
  CHECK(rig.sensor.read().fault == TempFault::power_on_value);
  CHECK(rig.sensor.read().valid);  // the reset shows once
  rig.chip.set_fault(SimTempFault::none);
  CHECK(rig.sensor.read().temp_c == 30.0);
}

TEST_CASE("an injected stuck value freezes the reading and trips the stuck check") {
  VirtualClock clock;
  SimDs18b20 chip{"28-000000000001", 40.0};
  Ds18b20 sensor{chip, clock, {.stuck_after_s = 10.0}};
  chip.set_fault(SimTempFault::stuck);
  chip.set_temperature_c(41.0);
  CHECK(sensor.read().temp_c == 40.0);
  clock.sleep_until(11.0);
  CHECK(sensor.read().fault == TempFault::stuck);
}

TEST_CASE("with the temperature file an all-zero scratchpad is not taken for 0 C") {
  VirtualClock clock;
  SimDs18b20 chip{"28-000000000002", 30.0};
  Ds18b20 sensor{chip, clock, {.source = W1File::temperature}};
  REQUIRE(sensor.read().valid);
  chip.set_fault(SimTempFault::all_zero);
  CHECK(sensor.read().fault == TempFault::all_zero);
  chip.set_fault(SimTempFault::none);
  chip.set_temperature_c(0.0);  // a true 0 C from a 12-bit part is a temperature
  const auto cold = sensor.read();
  CHECK(cold.valid);
  CHECK(cold.temp_c == 0.0);
}

TEST_CASE("with the temperature file a part reset to a lower resolution is refused after its power-on value") {
  VirtualClock clock;
  SimDs18b20 chip{"28-000000000003", 30.0};
  Ds18b20 sensor{chip, clock, {.source = W1File::temperature}};
  REQUIRE(sensor.read().valid);
  chip.set_fault(SimTempFault::power_on_reset);
  CHECK(sensor.read().fault == TempFault::power_on_value);
  chip.set_fault(SimTempFault::low_resolution);  // its EEPROM held 9 bits
  CHECK(sensor.read().fault == TempFault::resolution);
}
