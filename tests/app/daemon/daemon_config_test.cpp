#include <string>

#include <toml++/toml.h>

#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "input_error_of.hpp"
#include "observer_controller_file.hpp"

using gyrotc::app::DaemonConfig;
using gyrotc::app::parse_daemon_config;

namespace {

DaemonConfig parse(const std::string& text) { return parse_daemon_config(toml::parse(text), "test.toml"); }

// The InputError message of parsing text ("" if it parsed).
std::string error_of(const std::string& text) {
  return gyrotc::test::input_error_of([&] { parse(text); });
}

}  // namespace

TEST_CASE("both example configurations in deploy/config load as daemon configurations") {
  for (const char* name : {"gyrotc-sim.toml", "gyrotc-linux.toml"}) {
    const DaemonConfig c = gyrotc::app::load_daemon_config(gyrotc::test::config_file(name));
    CHECK(c.controller.setpoint_c == 55.0);
    CHECK(c.controller.pid.period_s == 2.0);
    CHECK(c.controller.pid.xi_c == 0.5);
    CHECK(c.controller.pid_enabled);
    CHECK(c.realtime.priority == 80);
    CHECK_FALSE(c.realtime.cpu.has_value());
    CHECK(c.controller.limits.over_temp_c == 80.0);
    CHECK(c.controller.pid.out_max == 1.0);  // the documented stage's limit
  }
}

TEST_CASE("the installed board configuration keeps the journal quiet: no line stream, no periodic status") {
  const DaemonConfig c = gyrotc::app::load_daemon_config(gyrotc::test::config_file("gyrotc-linux.toml"));
  CHECK(c.output.stream == gyrotc::app::StreamKind::none);
  CHECK(c.output.status_interval_s == 0.0);
  CHECK(c.output.status_file == "/run/gyrotc/status.json");
}

TEST_CASE("daemon config: the status and metrics files are taken relative to the configuration's folder") {
  const DaemonConfig c = parse("hal = \"sim\"\n[output]\nstatus_file = \"s.json\"\nmetrics_file = \"m.prom\"\n");
  CHECK(c.output.status_file == "s.json");  // parse() alone: load_daemon_config resolves them
  CHECK_THAT(error_of("hal = \"sim\"\n[output]\nmetrics_file = \"m.txt\"\n"),
             Catch::Contains("output.metrics_file: must end in .prom"));
}

TEST_CASE("daemon config: the [control] keys reach the controller configuration") {
  const DaemonConfig c = parse(
      "hal = \"sim\"\n[control]\nsetpoint_c = 50\nkp = 1.0\nki = 0.05\nkd = 4\nperiod_s = 2\nxi_c = 1\n"
      "pid = false\nout_min_a = -1\nout_max_a = 1.2\n[realtime]\ncpu = 0\npriority = 50\n[failsafe]\n"
      "recovery_readings = 5\n[output]\nstream = \"none\"\nrecord_csv = \"r.csv\"\n");
  CHECK(c.controller.setpoint_c == 50.0);
  CHECK(c.controller.pid.kp == 1.0);
  CHECK(c.controller.pid.ki() == Approx(0.05));
  CHECK(c.controller.pid.kd() == Approx(4.0));
  CHECK(c.controller.pid.xi_c == 1.0);
  CHECK_FALSE(c.controller.pid_enabled);
  CHECK(c.controller.pid.out_min == -1.0);
  CHECK(c.controller.pid.out_max == 1.2);
  CHECK(c.realtime.cpu == 0);
  CHECK(c.realtime.priority == 50);
  CHECK(c.controller.limits.recovery_readings == 5);
  CHECK(c.output.stream == gyrotc::app::StreamKind::none);
  CHECK(c.output.record_csv == "r.csv");
}

TEST_CASE("daemon config: an unknown key names the file, the line and the key") {
  CHECK(error_of("hal = \"sim\"\n[control]\nsetpoint_c = 50\nsetpiont_c = 40\n") ==
        "test.toml:4: control.setpiont_c: unknown key in [control]");
  CHECK(error_of("hal = \"sim\"\n\n[controll]\nx = 1\n").rfind("test.toml:3: controll: unknown key", 0) == 0);
}

TEST_CASE("daemon config: a value of the wrong type names the line and the key") {
  CHECK(error_of("hal = \"sim\"\n[realtime]\npriority = \"high\"\n") ==
        "test.toml:3: realtime.priority: expected an integer");
  CHECK(error_of("hal = \"sim\"\n[control]\npid = 1\n") == "test.toml:3: control.pid: expected true or false");
}

TEST_CASE("daemon config: a negative period is rejected naming the line and the key") {
  CHECK(error_of("hal = \"sim\"\n[control]\n\nperiod_s = -2\n").rfind("test.toml:4: control.period_s: must be within",
                                                                        0) == 0);
}

TEST_CASE("daemon config: a setpoint at or above the over-temperature limit is rejected") {
  const std::string e = error_of("hal = \"sim\"\n[failsafe]\nover_temp_c = 60\n[control]\nsetpoint_c = 70\n");
  CHECK(e.rfind("test.toml:5: control.setpoint_c: must be within", 0) == 0);
}

TEST_CASE("daemon config: a file or serial stream without a path is rejected") {
  CHECK(error_of("hal = \"sim\"\n[output]\nstream = \"serial\"\n") ==
        "test.toml:2: output.path: required with stream = \"serial\" (the file or serial device)");
  CHECK(error_of("hal = \"sim\"\n[output]\nstream = \"udp\"\n").rfind("test.toml:3: output.stream: expected", 0) == 0);
}

TEST_CASE("daemon config: board errors come from the board section parser with their line") {
  CHECK(error_of("hal = \"sim\"\n[tec]\ncurrent_limit_a = \"x\"\n").rfind("test.toml:3: ", 0) == 0);
  CHECK(error_of("[control]\nsetpoint_c = 50\n").find("missing key 'hal'") != std::string::npos);
}

TEST_CASE("daemon config: PID output limits beyond the TEC current limit are rejected") {
  CHECK(error_of("hal = \"sim\"\n[tec]\ncurrent_limit_a = 1.0\n[control]\nout_max_a = 2.0\n")
            .rfind("test.toml:5: control.out_max_a: must be within -1 .. 1", 0) == 0);
}

TEST_CASE("daemon config: a feed-forward without an ambient sensor is rejected naming the key") {
  CHECK(error_of("hal = \"sim\"\n[control]\nfeed_forward_a_per_c = 0.02\n") ==
        "test.toml:3: control.feed_forward_a_per_c: needs the ambient reading, and [devices.ambient_sensor] is absent");
  CHECK(error_of("hal = \"sim\"\n[devices.ambient_sensor]\nid = \"28-01\"\n[devices.casing_sensor]\nid = \"28-02\"\n"
                 "[control]\nfeed_forward_a_per_c = 0.02\n")
            .empty());
}

TEST_CASE("daemon config: a model-based loop's controller file needs the ambient sensor it was identified with") {
  const std::string file = gyrotc::test::scratch_dir() + "/observer.toml";
  gyrotc::app::save_controller_file(gyrotc::test::observer_controller_file(), file);
  DaemonConfig with_ambient = gyrotc::app::load_daemon_config(gyrotc::test::sim_config_copy("observer_with_ambient"));
  REQUIRE(with_ambient.board.devices.ambient_sensor);
  gyrotc::app::use_controller_file(with_ambient, file);
  CHECK(with_ambient.controller.observer != nullptr);

  DaemonConfig without = parse("hal = \"sim\"\n");
  CHECK(gyrotc::test::input_error_of([&] { gyrotc::app::use_controller_file(without, file); }) ==
        file + ": type = \"observer\": the model-based loop reads the ambient, and test.toml has no "
               "[devices.ambient_sensor]");
}
