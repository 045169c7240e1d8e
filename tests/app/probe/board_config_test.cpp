#include "gyrotc/app/formats/board_config.hpp"

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include "gyrotc/app/support/errors.hpp"
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

// A fake /sys/bus/w1/devices with DS18B20 directories, removed afterwards.
struct FakeW1 {
  std::string root = (std::filesystem::temp_directory_path() /
                      ("gyrotc-board-w1-" + std::to_string(::getpid()) + "-" +
                       std::to_string(reinterpret_cast<std::uintptr_t>(this))))
                         .string();
  FakeW1() { std::filesystem::create_directories(root + "/w1_bus_master1"); }
  ~FakeW1() { std::filesystem::remove_all(root); }
  void add(const std::string& id) const { std::filesystem::create_directories(root + "/" + id); }
};

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
  CHECK(c.devices.tec.current_limit_a == 1.0);
  REQUIRE(c.devices.opa548_es_sense.has_value());
  CHECK(c.devices.opa548_es_sense->line == "23");
  CHECK(c.devices.casing_sensor.id == "28-00000000ca51");
  REQUIRE(c.devices.ambient_sensor.has_value());
  CHECK(c.devices.ambient_sensor->id == "28-00000000a4b1");
  REQUIRE(c.sim.initial_temp_c.has_value());
  CHECK(*c.sim.initial_temp_c == 16.0);
  CHECK(c.sim.adc_timing.wake_max_s == Approx(120e-6));
  CHECK(c.sim.adc_timing.irq_delay_max_s == Approx(20e-6));
}

TEST_CASE("the linux example configuration parses with hal = linux, both DS18B20s named") {
  const BoardConfig c = parse_board_config(toml::parse_file(gyrotc::test::config_file("gyrotc-linux.toml")),
                                           "gyrotc-linux.toml");
  CHECK(c.hal == HalKind::linux_devices);
  CHECK_FALSE(c.devices.casing_sensor.id.empty());
  REQUIRE(c.devices.ambient_sensor.has_value());
  CHECK(c.devices.ambient_sensor->id != c.devices.casing_sensor.id);
}

TEST_CASE("two DS18B20s with an empty casing id are refused, naming the ids on the bus") {
  FakeW1 bus;
  bus.add("28-000005e2fdc3");
  bus.add("28-0000061a2b3c");
  const std::string e = error_of("hal = \"linux\"\n[devices.casing_sensor]\nw1_root = \"" + bus.root + "\"\nid = \"\"\n"
                                 "[devices.ambient_sensor]\nw1_root = \"" + bus.root + "\"\nid = \"28-000005e2fdc3\"\n");
  INFO(e);
  CHECK(e.find("board.toml:4: devices.casing_sensor.id: empty, but a second DS18B20 is configured") == 0);
  CHECK(e.find("28-000005e2fdc3, 28-0000061a2b3c") != std::string::npos);
}

TEST_CASE("an empty ambient id, or one id for both sensors, is refused") {
  CHECK(error_of("hal = \"sim\"\n[devices.casing_sensor]\nid = \"28-0000061a2b3c\"\n[devices.ambient_sensor]\n")
            .find("board.toml:4: devices.ambient_sensor.id: empty, but the casing sensor is \"28-0000061a2b3c\"") == 0);
  CHECK(error_of("hal = \"sim\"\n[devices.casing_sensor]\nid = \"28-0000061a2b3c\"\n"
                 "[devices.ambient_sensor]\nid = \"28-0000061a2b3c\"\n")
            .find("board.toml:5: devices.ambient_sensor.id: \"28-0000061a2b3c\" is the casing sensor's id too") == 0);
}

TEST_CASE("one DS18B20 configured with an empty id and two on the bus fails, naming both") {
  FakeW1 bus;
  bus.add("28-000005e2fdc3");
  bus.add("28-0000061a2b3c");
  const BoardConfig c = parse("hal = \"linux\"\n[devices.adc]\nspi = \"/dev/spidev-gyrotc-missing0.0\"\n"
                              "[devices.casing_sensor]\nw1_root = \"" + bus.root + "\"\n");
  try {
    make_board(c);
    FAIL("make_board succeeded without devices");
  } catch (const RuntimeFailure& e) {
    INFO(e.what());
    CHECK(std::string(e.what()).find("casing_sensor: 2 DS18B20s under '" + bus.root +
                                     "' (28-000005e2fdc3, 28-0000061a2b3c) and no id configured") != std::string::npos);
  }
}

TEST_CASE("the simulated ADS1251 reader's timing is read in microseconds and range-checked") {
  const BoardConfig c = parse("hal = \"sim\"\n[sim]\nadc_wake_min_us = 10\nadc_wake_max_us = 300\n"
                              "adc_stall_probability = 0.02\nadc_stall_max_us = 3000\nadc_irq_delay_max_us = 40\n"
                              "adc_spi_start_max_us = 100\nadc_spi_return_max_us = 50\n");
  const auto& a = c.sim.adc_timing;
  CHECK(a.wake_min_s == Approx(10e-6));
  CHECK(a.wake_max_s == Approx(300e-6));
  CHECK(a.stall_probability == 0.02);
  CHECK(a.stall_max_s == Approx(3e-3));
  CHECK(a.irq_delay_max_s == Approx(40e-6));
  CHECK(a.spi_start_max_s == Approx(100e-6));
  CHECK(a.spi_return_max_s == Approx(50e-6));
  CHECK(error_of("hal = \"sim\"\n[sim]\nadc_wake_min_us = 50\nadc_wake_max_us = 20\n") ==
        "board.toml:4: sim.adc_wake_max_us: must be within 50 .. 1e+06, got 20");
  CHECK(error_of("hal = \"sim\"\n[sim]\nadc_stall_probability = 2\n") ==
        "board.toml:3: sim.adc_stall_probability: must be within 0 .. 1, got 2");
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
  CHECK(e.find("board.toml:3: devices.adc: ADS1251: at fclk 7680000 Hz the DOUT window is 16.9 us") == 0);
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

TEST_CASE("a GPIO line takes its pull and active-low from <key>_bias and <key>_active_low") {
  const BoardConfig c = parse("hal = \"sim\"\n[devices.adc]\ndrdy = \"gpiochip0:25\"\ndrdy_bias = \"disabled\"\n"
                              "[devices.opa548]\nes_sense = \"gpiochip0:23\"\nes_sense_bias = \"pull-up\"\n"
                              "es_sense_active_low = true\n");
  CHECK(c.devices.adc_drdy.bias == gyrotc::hal::GpioBias::disabled);
  CHECK_FALSE(c.devices.adc_drdy.active_low);
  REQUIRE(c.devices.opa548_es_sense.has_value());
  CHECK(c.devices.opa548_es_sense->bias == gyrotc::hal::GpioBias::pull_up);
  CHECK(c.devices.opa548_es_sense->active_low);
  CHECK(c.devices.opa548_es.bias == gyrotc::hal::GpioBias::as_is);  // defaults: as the board left it
  CHECK_FALSE(c.devices.opa548_es.active_low);
}

TEST_CASE("an unknown bias, or a sense line's flags without the line, are refused naming the key") {
  CHECK(error_of("hal = \"sim\"\n[devices.adc]\ndrdy_bias = \"up\"\n")
            .find("board.toml:3: devices.adc.drdy_bias: expected \"as-is\", \"disabled\", \"pull-up\" or \"pull-down\", got \"up\"") == 0);
  CHECK(error_of("hal = \"sim\"\n[devices.opa548]\nes_sense_active_low = true\n")
            .find("board.toml:3: devices.opa548.es_sense: es_sense_bias / es_sense_active_low given without") == 0);
}
