// The emulated board on a virtual clock: what the daemon's frames and lines
// do to the plant, what the sense line shows, and the control commands.
#include "gyrotc/emu/board_emulator.hpp"

#include <array>
#include <fstream>
#include <string>

#include "cuse_kernel.hpp"
#include "gyrotc/emu/hil_report.hpp"
#include "gyrotc/hal/chips/ad5060.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc;

namespace {

struct Line final : emu::PinOutput {
  std::optional<bool> level;
  void set_level(bool high) noexcept override { level = high; }
};
struct Drive final : emu::PinInput {
  std::optional<bool> value = false;
  std::optional<bool> level() noexcept override { return value; }
};

app::BoardConfig board_config(bool sense_active_low) {
  app::BoardConfig b;
  b.hal = app::HalKind::linux_devices;
  b.devices.adc.fclk_hz = 38'400.0;
  b.devices.adc_drdy = {"gyrotc-emu", "DRDY"};
  b.devices.opa548_es = {"gyrotc-emu", "ES"};
  b.devices.opa548_es_sense = hal::GpioRef{"gyrotc-emu", "ES_SENSE", hal::GpioBias::pull_up, sense_active_low};
  b.devices.casing_sensor.id = "28-0000061a2b3c";
  b.devices.ambient_sensor = hal::W1SensorConfig{};
  b.devices.ambient_sensor->id = "28-000005e2fdc3";
  return b;
}

struct Rig {
  hal::VirtualClock clock{100.0};
  Line drdy, sense;
  Drive es;
  std::string log_path = test::scratch_dir() + "/board-emulator.csv";
  emu::EventLog log{log_path};
  std::unique_ptr<emu::BoardEmulator> board;
  explicit Rig(bool sense_active_low = false) {
    emu::EmulatorOptions o;
    o.board = board_config(sense_active_low);
    o.plant.initial_temp_c = 25.0;
    board = std::make_unique<emu::BoardEmulator>(o, clock, drdy, es, &sense, log);
  }
  // The TEC DAC at `amps` through its node, as TecStage writes it.
  void tec_current(double amps) {
    emu::SpidevEndpoint node("/dev/spidev6.1", board->tec_dac());
    test::CuseSpiBus bus(node);
    hal::Ad5060 dac(bus, {.vref_v = 5.0});
    REQUIRE(dac.init().ok());
    REQUIRE(dac.write_v(2.5 + amps).ok());  // gain 1 A/V, mid-scale 0 A
  }
  void run(double seconds) {
    const double end = clock.now_s() + seconds;
    while (clock.now_s() < end) {
      clock.sleep_until(clock.now_s() + 0.1);
      board->poll_es();
      board->step_plant();
    }
  }
};

}  // namespace

TEST_CASE("emulated board: the TEC heats the casing only while the daemon drives E/S high") {
  Rig rig;
  rig.tec_current(0.5);
  rig.run(20.0);
  CHECK(rig.board->snapshot().tec_a == Approx(0.0));  // E/S low: disabled
  const double before = rig.board->snapshot().casing_c;
  rig.es.value = true;
  rig.run(60.0);
  CHECK(rig.board->snapshot().tec_a == Approx(0.5).margin(0.01));
  CHECK(rig.board->snapshot().casing_c > before + 1.0);
}

TEST_CASE("emulated board: the sense line shows E/S, low in an injected thermal shutdown, inverted when wired so") {
  Rig rig(true);  // es_sense_active_low: an opto that inverts
  rig.es.value = true;
  rig.run(0.2);
  REQUIRE(rig.sense.level);
  CHECK(*rig.sense.level == false);  // E/S high, seen through the inverting opto
  CHECK(rig.board->apply("fault opa548-shutdown on") == "ok");
  rig.run(0.2);
  CHECK(*rig.sense.level == true);  // the part pulls E/S low
  CHECK(rig.board->snapshot().opa548_shutdown);
  CHECK(rig.board->snapshot().tec_a == Approx(0.0));
}

TEST_CASE("emulated board: every TEC DAC frame and E/S change is in the event log with its time") {
  Rig rig;
  rig.tec_current(0.25);
  rig.es.value = true;
  rig.run(1.0);
  rig.log.flush();
  const auto events = emu::read_event_log(rig.log_path);
  const auto dac = std::find_if(events.begin(), events.end(), [](const emu::LogEvent& e) {
    return e.kind == "dac" && e.device == "tec_dac" && e.value == std::to_string(hal::Ad5060::code_for_v(2.75, 5.0));
  });
  CHECK(dac != events.end());
  const auto es = std::find_if(events.begin(), events.end(),
                               [](const emu::LogEvent& e) { return e.kind == "es" && e.device == "drive"; });
  REQUIRE(es != events.end());
  CHECK(es->value == "1");
  CHECK(es->t_s == Approx(100.1));
}

TEST_CASE("emulated board: sensor faults go to the bus of the sensor named") {
  Rig rig;
  CHECK(rig.board->apply("fault casing disconnect") == "ok");
  auto& bus = *rig.board->w1_buses().begin()->second;
  CHECK(bus.fault("28-0000061a2b3c") == hal::SimTempFault::disconnect);
  CHECK(bus.fault("28-000005e2fdc3") == hal::SimTempFault::none);
  CHECK(rig.board->apply("fault casing none") == "ok");
  CHECK(bus.fault("28-0000061a2b3c") == hal::SimTempFault::none);
}

TEST_CASE("emulated board: a bad control command gets an error that names it") {
  Rig rig;
  CHECK_THAT(rig.board->apply("fault casing melted"), Catch::Contains("error: sensor faults:"));
  CHECK_THAT(rig.board->apply("ambient warm"), Catch::Contains("error:"));
  CHECK_THAT(rig.board->apply("frobnicate"), Catch::Contains("unknown command 'frobnicate'"));
  CHECK_THAT(rig.board->apply("status"), Catch::Contains("ok t_s=100.000"));
}

TEST_CASE("emulated board: the chamber ambient follows an ambient ramp") {
  Rig rig;
  CHECK(rig.board->apply("ambient 30 0.5") == "ok");
  rig.run(10.0);
  CHECK(rig.board->snapshot().ambient_c == Approx(35.0).margin(0.1));
}
