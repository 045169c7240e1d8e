// The OPA548's E/S sense line on the simulated board follows the pin 1 ms
// late, as the board's optocouplers do (the virtual board's emulated line up
// to 40 ms): a read right after an enable still shows the disabled pin, low,
// which must not be taken for a thermal shutdown. The virtual board showed
// what happens otherwise: every enable was a shutdown, the loop never drove.
#include <cmath>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/hal/sim/sim_board.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc;

namespace {

struct SenseRig {
  hal::SimBoard board{model::PlantParams{}, 1, [] {
                        hal::SimBoardOptions o;
                        o.adc.fclk_hz = 20.0 * 384.0;
                        return o;
                      }()};
  fit::Compensator compensator{fit::BiasModel::paper_reference()};
  app::Controller controller{app::ControllerConfig{}, compensator};
  hal::Board devices = board.board();

  // A casing reading at t_s, then the PID period there (the stage enabled).
  void period_at(double t_s) {
    board.advance_to(t_s);
    controller.on_temperature({.temp_c = 30.0, .time_s = t_s, .valid = true}, t_s);
    (void)app::run_pid_tick(controller, devices.tec, t_s);
  }
};

}  // namespace

TEST_CASE("an OPA548 just enabled is not taken for one in thermal shutdown while its E/S sense settles") {
  SenseRig rig;
  rig.period_at(2.0);
  REQUIRE(rig.controller.tec_driving());
  REQUIRE_FALSE(rig.board.opa548_chip().sense_high());  // the sense still shows the disabled pin
  app::run_thermal_poll(rig.controller, rig.devices.tec, 2.0);  // the row right after the period
  CHECK((rig.controller.flags() & app::kFlagOpa548Thermal) == 0);
  CHECK(rig.controller.tec_driving());
  rig.board.advance_to(3.0);
  app::run_thermal_poll(rig.controller, rig.devices.tec, 3.0);
  CHECK((rig.controller.flags() & app::kFlagOpa548Thermal) == 0);
  rig.period_at(4.0);
  CHECK(rig.controller.tec_driving());
}

TEST_CASE("an OPA548 in thermal shutdown is still seen at the first row once its E/S sense has settled") {
  SenseRig rig;
  rig.period_at(2.0);
  rig.board.inject_opa548_thermal_shutdown(true);
  rig.board.advance_to(2.5);
  app::run_thermal_poll(rig.controller, rig.devices.tec, 2.5);
  CHECK((rig.controller.flags() & app::kFlagOpa548Thermal) != 0);
  CHECK_FALSE(rig.controller.tec_driving());
  CHECK(rig.controller.reported_tec_a() == 0.0);
}
