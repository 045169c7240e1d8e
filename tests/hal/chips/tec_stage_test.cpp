#include "gyrotc/hal/chips/tec_stage.hpp"

#include <string>
#include <vector>

#include "gyrotc/hal/sim/sim_ad5060.hpp"
#include "gyrotc/hal/sim/sim_opa548.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;

namespace {

// Records the order in which the TEC DAC and the OPA548 drive pin change.
struct Recorder final : SimAd5060::Listener, SimOpa548::Listener {
  std::vector<std::string> events;
  void on_dac_output(double v, Ad5060PowerDown) noexcept override { events.push_back("dac " + std::to_string(v)); }
  void on_opa548_drive(bool released) noexcept override { events.push_back(released ? "enable" : "disable"); }
};

struct StageRig {
  Recorder recorder;
  SimAd5060 dac_chip{"sim:ad5060-tec", 2.5, &recorder};
  SimOpa548 amp_chip{&recorder};
  Ad5060 dac{dac_chip, {.vref_v = 2.5}};
  Opa548 amp{amp_chip.es_drive(), &amp_chip.es_sense()};
  TecStage tec{dac, amp, {.gain_a_per_v = 1.0, .current_limit_a = 1.2}};
  StageRig() { REQUIRE(dac.init().ok()); }
};

}  // namespace

TEST_CASE("the OPA548 is disabled until enabled") {
  StageRig rig;
  CHECK_FALSE(rig.amp_chip.output_enabled());
  CHECK_FALSE(rig.amp.enabled());
  REQUIRE(rig.tec.enable(true).ok());
  CHECK(rig.amp_chip.output_enabled());
}

TEST_CASE("0 A is DAC mid-scale and the current maps through the stage gain") {
  StageRig rig;
  REQUIRE(rig.tec.set_current_a(0.0).ok());
  CHECK(rig.dac_chip.code() == 32768);
  REQUIRE(rig.tec.set_current_a(0.5).ok());
  CHECK(rig.dac_chip.output_v() == Approx(1.75).margin(1e-4));
  REQUIRE(rig.tec.set_current_a(-0.5).ok());
  CHECK(rig.dac_chip.output_v() == Approx(0.75).margin(1e-4));
}

TEST_CASE("current commands beyond the limit are clamped to it") {
  StageRig rig;
  REQUIRE(rig.tec.set_current_a(5.0).ok());
  CHECK(rig.tec.last_current_a() == 1.2);
  CHECK(rig.dac_chip.output_v() == Approx(2.45).margin(1e-4));
  REQUIRE(rig.tec.set_current_a(-5.0).ok());
  CHECK(rig.tec.last_current_a() == -1.2);
}

TEST_CASE("safe_off sets the DAC to 0 A first, then disables the OPA548") {
  StageRig rig;
  REQUIRE(rig.tec.set_current_a(1.0).ok());
  REQUIRE(rig.tec.enable(true).ok());
  rig.recorder.events.clear();
  REQUIRE(rig.tec.safe_off().ok());
  REQUIRE(rig.recorder.events.size() == 2);
  CHECK(rig.recorder.events[0] == "dac " + std::to_string(1.25));
  CHECK(rig.recorder.events[1] == "disable");
  CHECK_FALSE(rig.amp_chip.output_enabled());
}

TEST_CASE("with a sense line a thermal shutdown shows while enabled") {
  StageRig rig;
  REQUIRE(rig.tec.senses_thermal());
  REQUIRE(rig.tec.enable(true).ok());
  auto status = rig.tec.thermal_status();
  REQUIRE(status.ok());
  CHECK(*status == ThermalStatus::clear);
  rig.amp_chip.inject_thermal_shutdown(true);
  status = rig.tec.thermal_status();
  REQUIRE(status.ok());
  CHECK(*status == ThermalStatus::shutdown);
  CHECK_FALSE(rig.amp_chip.output_enabled());
  rig.amp_chip.inject_thermal_shutdown(false);
  CHECK(*rig.tec.thermal_status() == ThermalStatus::clear);
}

TEST_CASE("while disabled the thermal state is unknown: E/S is held low by the board") {
  StageRig rig;
  rig.amp_chip.inject_thermal_shutdown(true);
  CHECK(*rig.tec.thermal_status() == ThermalStatus::unknown);
  rig.amp_chip.inject_thermal_shutdown(false);
  CHECK(*rig.tec.thermal_status() == ThermalStatus::unknown);
}

TEST_CASE("without a sense line a thermal shutdown is not reported clear: the state is unknown") {
  // Reading the drive line back gives the level the GPIO drives, not the pin.
  SimOpa548 chip;
  Opa548 amp{chip.es_drive(), nullptr};
  REQUIRE(amp.enable(true).ok());
  chip.inject_thermal_shutdown(true);
  CHECK_FALSE(chip.output_enabled());
  const auto status = amp.thermal_status();
  REQUIRE(status.ok());
  CHECK(*status == ThermalStatus::unknown);
  CHECK_FALSE(amp.has_sense());
}
