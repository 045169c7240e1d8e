#include "gyrotc/app/board_config.hpp"

#include <string>

#include "gyrotc/app/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "input_error_of.hpp"

using namespace gyrotc;
using namespace gyrotc::app;

namespace {

BoardConfig parse(const std::string& text) { return parse_board_config(toml::parse(text), "board.toml"); }

std::string error_of(const std::string& text) {
  return test::input_error_of([&] { parse(text); });
}

}  // namespace

TEST_CASE("the sim example configuration parses into the documented settings") {
  const BoardConfig c = parse_board_config(toml::parse_file(gyrotc::test::config_file("gyrotc-sim.toml")),
                                           "gyrotc-sim.toml");
  CHECK(c.hal == HalKind::sim);
  CHECK(c.devices.adc_spi == "/dev/spidev0.0");
  CHECK(c.devices.adc_drdy.chip == "gpiochip0");
  CHECK(c.devices.adc_drdy.line == "25");
  CHECK(c.devices.adc.fclk_hz == 384000.0);
  CHECK(c.devices.tec_dac.vref_v == 5.0);
  CHECK(c.devices.tec.current_limit_a == 1.5);
  CHECK_FALSE(c.devices.opa548_es_sense.has_value());
  REQUIRE(c.devices.ambient_sensor.has_value());
  CHECK(c.devices.ambient_sensor->id == "28-00000000a4b1");
  REQUIRE(c.sim.initial_temp_c.has_value());
  CHECK(*c.sim.initial_temp_c == 16.0);
}

TEST_CASE("the linux example configuration parses with hal = linux") {
  const BoardConfig c = parse_board_config(toml::parse_file(gyrotc::test::config_file("gyrotc-linux.toml")),
                                           "gyrotc-linux.toml");
  CHECK(c.hal == HalKind::linux_devices);
}

TEST_CASE("hal is required and must be linux or sim") {
  CHECK(error_of("") == "board.toml: missing key 'hal' (\"linux\" or \"sim\")");
  CHECK(error_of("\n\nhal = \"qemu\"\n") == "board.toml:3: hal: expected \"linux\" or \"sim\"");
  CHECK(error_of("hal = 1\n") == "board.toml:1: hal: expected \"linux\" or \"sim\"");
}

TEST_CASE("an unknown key in a board section is rejected with its line") {
  CHECK(error_of("hal = \"sim\"\n[devices.adc]\nfclk_hz = 384000\nfclk = 1\n") ==
        "board.toml:4: devices.adc.fclk: unknown key in [devices.adc]");
  CHECK(error_of("hal = \"sim\"\n[tec]\ngain = 1.0\n") == "board.toml:3: tec.gain: unknown key in [tec]");
  CHECK(error_of("hal = \"sim\"\n[sim]\nspeed = 2\n") == "board.toml:3: sim.speed: unknown key in [sim]");
  CHECK(error_of("hal = \"sim\"\n[devices.dac]\nspi = \"x\"\n") ==
        "board.toml:2: devices.dac: unknown key in [devices]");
}

TEST_CASE("other top-level tables are left to the daemon's loader") {
  CHECK(error_of("hal = \"sim\"\n[control]\nsetpoint_c = 55.0\n[output]\nrate = \"stdout\"\n").empty());
}

TEST_CASE("a value of the wrong type or out of range names key and line") {
  CHECK(error_of("hal = \"sim\"\n[devices.adc]\nvref_v = \"2.5\"\n") ==
        "board.toml:3: devices.adc.vref_v: expected a number");
  CHECK(error_of("hal = \"sim\"\n[tec]\ncurrent_limit_a = -1\n") ==
        "board.toml:3: tec.current_limit_a: must be within 0 .. 10, got -1");
  CHECK(error_of("hal = \"sim\"\n[devices.opa548]\nes = \"gpiochip0\"\n").find(
            "board.toml:3: devices.opa548.es: expected \"chip:line\"") == 0);
  CHECK(error_of("hal = \"sim\"\n[devices.casing_sensor]\nsource = \"sysfs\"\n") ==
        "board.toml:3: devices.casing_sensor.source: expected \"w1_slave\" or \"temperature\", got \"sysfs\"");
  CHECK(error_of("hal = \"sim\"\n[sim]\nseed = -3\n") == "board.toml:3: sim.seed: expected an integer >= 0");
}

TEST_CASE("an ADC clock that cannot be read in time is refused at load, saying why") {
  const std::string e = error_of("hal = \"linux\"\n[devices.adc]\nfclk_hz = 7680000\n");
  CHECK(e.find("board.toml:3: devices.adc: ADS1251: at fclk 7680000 Hz the DOUT window is 45.3 us") == 0);
}

TEST_CASE("a sim board is built with the configured TEC stage and start temperature") {
  const BoardConfig c = parse("hal = \"sim\"\n[tec]\ndac_vref_v = 4.096\ngain_a_per_v = 0.5\n[sim]\ninitial_temp_c = 30\n");
  BoardInstance instance = make_board(c);
  REQUIRE(instance.sim_board);
  CHECK(instance.sim_board->plant().params().dac_vref_v == 4.096);
  CHECK(instance.sim_board->plant().params().gain_a_per_v == 0.5);
  const auto reading = instance.board().casing_sensor.read();
  REQUIRE(reading.valid);
  CHECK(reading.temp_c == Approx(30.0).margin(0.07));
  CHECK(instance.board().ambient_sensor == nullptr);  // no [devices.ambient_sensor]
}

TEST_CASE("a linux board whose devices are missing fails naming each device") {
  const BoardConfig c = parse(
      "hal = \"linux\"\n"
      "[devices.adc]\nspi = \"/dev/spidev-gyrotc-missing0.0\"\ndrdy = \"gpiochip-gyrotc-missing:25\"\n"
      "[devices.rate_dac]\nspi = \"/dev/spidev-gyrotc-missing1.0\"\n"
      "[devices.tec_dac]\nspi = \"/dev/spidev-gyrotc-missing1.1\"\n"
      "[devices.opa548]\nes = \"gpiochip-gyrotc-missing:24\"\n"
      "[devices.casing_sensor]\nw1_root = \"/nonexistent-gyrotc-w1\"\n");
  try {
    make_board(c);
    FAIL("make_board succeeded without devices");
  } catch (const RuntimeFailure& e) {
    const std::string m = e.what();
    CHECK(m.find("adc: cannot open spidev '/dev/spidev-gyrotc-missing0.0': No such file or directory") !=
          std::string::npos);
    CHECK(m.find("cannot open gpiochip 'gpiochip-gyrotc-missing'") != std::string::npos);
    CHECK(m.find("rate_dac: cannot open spidev '/dev/spidev-gyrotc-missing1.0'") != std::string::npos);
    CHECK(m.find("tec_dac: cannot open spidev '/dev/spidev-gyrotc-missing1.1'") != std::string::npos);
    CHECK(m.find("opa548: cannot open gpiochip") != std::string::npos);
    CHECK(m.find("casing_sensor: no DS18B20 (28-*) under '/nonexistent-gyrotc-w1'") != std::string::npos);
  }
}
