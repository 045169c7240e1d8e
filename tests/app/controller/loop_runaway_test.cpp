// The runaway check (FailSafeLimits::runaway_s, runaway_c): a model-based
// loop whose command pushes the casing reading away from the setpoint hands
// the TEC to the PID, whatever its model says; a loop braking on its way to
// the setpoint, a command that helps, and the PID are left alone.
#include <cmath>
#include <memory>

#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/model/plant_housing.hpp"
#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/app/runtime/fault_supervisor.hpp"
#include "gyrotc_catch.hpp"
#include "misconfigured_loop.hpp"

using namespace gyrotc::app;
using gyrotc::hal::TempFault;
using gyrotc::hal::TemperatureReading;

namespace {

TemperatureReading runaway_reading(double temp_c, double t_s) { return {temp_c, t_s, true, TempFault::none}; }

// A loop that heats above the setpoint (it holds against a -20 C room where
// the room is 20 C: support/misconfigured_loop.hpp); with `right`, the loop
// as designed for the default housing, the same check's limits.
ControllerConfig runaway_config(bool right = false) {
  if (!right) return gyrotc::test::misconfigured_loop_config(40.0, -20.0);
  ControllerConfig config = gyrotc::test::misconfigured_loop_config(40.0, -20.0);
  gyrotc::control::ObserverLoopSpec spec;
  spec.setpoint_c = config.setpoint_c;
  config.observer = std::make_shared<const gyrotc::control::ObserverLoopDesign>(
      gyrotc::control::design_observer_loop(gyrotc::model::housing_model(gyrotc::model::PlantParams{}), spec));
  return config;
}

// A controller ticked every period, its casing reading moving `rate_c_per_s`
// (a housing the TEC does not reach: the check must not need one).
struct RunawayRig {
  gyrotc::fit::Compensator compensator{gyrotc::fit::BiasModel::paper_reference()};
  ControllerConfig config;
  Controller controller;
  double now_s = 0.0;
  double casing_c;

  RunawayRig(ControllerConfig c, double start_c) : config(c), controller(config, compensator), casing_c(start_c) {
    controller.on_ambient_temperature(runaway_reading(20.0, 0.0), 0.0);
  }
  TecCommand run_for(double seconds, double rate_c_per_s) {
    TecCommand last = controller.last_command();
    const double period_s = config.pid.period_s;
    for (const double end_s = now_s + seconds; now_s < end_s - 1e-9;) {
      now_s += period_s;
      casing_c += rate_c_per_s * period_s;
      controller.on_temperature(runaway_reading(std::round(casing_c * 16.0) / 16.0, now_s - 0.75), now_s);
      last = controller.on_pid_tick(now_s);
    }
    return last;
  }
};

// The supervisor alone, one casing reading and one command a second.
struct RunawayCheck {
  FailSafeLimits limits;
  FaultSupervisor supervisor{limits};
  double now_s = 0.0;

  bool raised_after(double seconds, double start_c, double rate_c_per_s, double current_a, bool model_drove,
                    double setpoint_c = 55.0) {
    for (double c = start_c; now_s < seconds - 1e-9; c += rate_c_per_s) {
      now_s += 1.0;
      supervisor.on_temperature(runaway_reading(std::round(c * 16.0) / 16.0, now_s), now_s);
      supervisor.on_loop_command(model_drove, current_a, setpoint_c, now_s);
    }
    return (supervisor.flags() & kFlagLoopRunaway) != 0;
  }
};

}  // namespace

TEST_CASE("a model-based loop whose command drives the reading away from the setpoint hands the TEC to the PID") {
  RunawayRig rig(runaway_config(), 56.0);
  const FailSafeLimits& l = rig.config.limits;
  TecCommand cmd = rig.run_for(10.0, 0.0);
  REQUIRE(cmd.enable);
  INFO("current " << cmd.current_a << " A at " << rig.casing_c << " C");
  REQUIRE(cmd.current_a > 0.0);  // heating above the setpoint
  // The reading rises as a heated casing's would, 2 C a minute.
  cmd = rig.run_for(l.runaway_s - 10.0, 2.0 / 60.0);
  INFO("current " << cmd.current_a << " A at " << rig.casing_c << " C");
  CHECK(cmd.current_a > 0.0);
  CHECK((cmd.flags & kFlagLoopRunaway) == 0);  // not before runaway_s
  cmd = rig.run_for(30.0, 2.0 / 60.0);
  CHECK((cmd.flags & kFlagLoopRunaway) != 0);
  CHECK((kFaultFlags & kFlagLoopRunaway) != 0);
  // The PID drives from the next period on: it cools a casing above the setpoint.
  cmd = rig.run_for(10.0, 0.0);
  CHECK(cmd.enable);
  CHECK(cmd.current_a < 0.0);
  CHECK(std::isnan(rig.controller.loop_estimate().held_c));  // no model-based loop runs
}

TEST_CASE("a model-based loop that cools a casing above the setpoint is no runaway, however the reading moves") {
  RunawayRig rig(runaway_config(true), 56.0);
  TecCommand cmd = rig.run_for(10.0, 0.0);
  REQUIRE(cmd.current_a < 0.0);
  cmd = rig.run_for(3.0 * rig.config.limits.runaway_s, 2.0 / 60.0);  // a load the TEC cannot hold
  CHECK(cmd.enable);
  CHECK((cmd.flags & kFlagLoopRunaway) == 0);
  CHECK(std::isfinite(rig.controller.loop_estimate().held_c));
}

TEST_CASE("a loop braking on its way to the setpoint is no runaway: the reading comes closer") {
  RunawayCheck c;
  // Cooling below the setpoint for 5 minutes while the reading rises towards it.
  CHECK_FALSE(c.raised_after(300.0, 50.0, 0.01, -0.5, true));
}

TEST_CASE("a command opposing the error trips the check once the reading has moved runaway_c further away") {
  RunawayCheck c;
  // 0.5 C a minute away: runaway_s (120 s) brings it 1 C away, runaway_c.
  CHECK_FALSE(c.raised_after(100.0, 50.0, -0.5 / 60.0, -0.5, true));
  CHECK(c.raised_after(130.0, 50.0 - 100.0 * 0.5 / 60.0, -0.5 / 60.0, -0.5, true));
}

TEST_CASE("a slow drift under an opposing command is no runaway until it has gone runaway_c further") {
  RunawayCheck c;
  // 0.1 C a minute: 10 minutes to go 1 C further away.
  CHECK_FALSE(c.raised_after(500.0, 50.0, -0.1 / 60.0, -0.5, true));
  CHECK(c.raised_after(700.0, 50.0 - 500.0 * 0.1 / 60.0, -0.1 / 60.0, -0.5, true));
}

TEST_CASE("the PID's command is not judged by the runaway check") {
  RunawayCheck c;
  CHECK_FALSE(c.raised_after(600.0, 50.0, -2.0 / 60.0, -0.5, false));
}

TEST_CASE("a reload that brings another model-based loop clears loop_runaway and runs the new loop") {
  RunawayRig rig(runaway_config(), 56.0);
  rig.run_for(rig.config.limits.runaway_s + 40.0, 2.0 / 60.0);
  REQUIRE((rig.controller.flags() & kFlagLoopRunaway) != 0);
  ControllerReload reload(runaway_config(true));
  rig.controller.request_reload(reload);
  const TecCommand cmd = rig.run_for(10.0, 0.0);
  CHECK((cmd.flags & kFlagLoopRunaway) == 0);
  CHECK(cmd.current_a < 0.0);
  CHECK(std::isfinite(rig.controller.loop_estimate().held_c));
}

TEST_CASE("once the PID holds in the runaway loop's place a frozen reading under its swinging command raises temp_stuck") {
  RunawayRig rig(runaway_config(), 56.0);
  rig.run_for(rig.config.limits.runaway_s + 40.0, 2.0 / 60.0);
  REQUIRE((rig.controller.flags() & kFlagLoopRunaway) != 0);
  // The reading freezes an eighth of a degree below the setpoint: the PID's
  // integral swings the command from cooling through 0 A to heating, so only
  // the swing (stuck_span_a), not the drive (stuck_min_drive_a), shows the
  // casing should have moved. The model's check would never fire: no model runs.
  rig.casing_c = rig.config.setpoint_c - 0.1;
  const TecCommand held = rig.run_for(rig.config.limits.stuck_s / 2.0, 0.0);
  REQUIRE((held.flags & kFlagTempStuck) == 0);
  const TecCommand cmd = rig.run_for(rig.config.limits.stuck_s, 0.0);
  CHECK((cmd.flags & kFlagTempStuck) != 0);
}
