#include <filesystem>
#include <fstream>
#include <string>

#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "input_error_of.hpp"

using namespace gyrotc::app;
using gyrotc::test::input_error_of;

namespace {

ControllerFile sample() {
  ControllerFile c;
  c.setpoint_c = 54.5;
  c.kp = 1.25;
  c.ki = 0.0625;
  c.kd = 0.5;
  c.period_s = 2.0;
  c.xi_c = 0.75;
  c.feed_forward_a_per_c = 0.0049;
  c.feed_forward_lag_s = 312.5;
  c.setpoint_ramp_c_per_s = 0.02;
  c.rail = RailLimit{true, 1.06, -1.02, 0.0042};
  c.stuck_min_drive_a = 0.61;
  return c;
}

std::string write_temp(const std::string& name, const std::string& text) {
  const std::string path = gyrotc::test::scratch_dir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

}  // namespace

TEST_CASE("a controller file round-trips every value through its text") {
  const ControllerFile c = sample();
  const ControllerFile back = parse_controller_file(format_controller_file(c, "[identified]\nx = 1.0\n"), "c.toml");
  CHECK(back.setpoint_c == c.setpoint_c);
  CHECK(back.kp == c.kp);
  CHECK(back.ki == c.ki);
  CHECK(back.kd == c.kd);
  CHECK(back.xi_c == c.xi_c);
  CHECK(back.feed_forward_a_per_c == c.feed_forward_a_per_c);
  CHECK(back.feed_forward_lag_s == c.feed_forward_lag_s);
  CHECK(back.setpoint_ramp_c_per_s == c.setpoint_ramp_c_per_s);
  CHECK(back.rail.known);
  CHECK(back.rail.pos_a == c.rail.pos_a);
  CHECK(back.rail.neg_a == c.rail.neg_a);
  CHECK(back.rail.a_per_c == c.rail.a_per_c);
  REQUIRE(back.stuck_min_drive_a.has_value());
  CHECK(*back.stuck_min_drive_a == *c.stuck_min_drive_a);
}

TEST_CASE("applying a controller file sets the controller and keeps the board's limits") {
  ControllerConfig base;
  base.pid.out_min = -0.8;
  base.pid.out_max = 0.9;
  base.limits.over_temp_c = 75.0;
  const ControllerConfig c = apply_controller_file(sample(), base, "c.toml");
  CHECK(c.setpoint_c == 54.5);
  CHECK(c.pid.kp == 1.25);
  CHECK(c.pid.ki() == Approx(0.0625));
  CHECK(c.pid.kd() == Approx(0.5));
  CHECK(c.pid.xi_c == 0.75);
  CHECK(c.pid.out_min == -0.8);
  CHECK(c.pid.out_max == 0.9);
  CHECK(c.limits.over_temp_c == 75.0);
  CHECK(c.limits.stuck_min_drive_a == 0.61);
  CHECK(c.rail.known);
  CHECK(c.feed_forward_lag_s == 312.5);
}

TEST_CASE("a controller file with a missing key, an unknown key or the wrong format is refused naming it") {
  std::string text = format_controller_file(sample());
  const std::string no_kd = text.substr(0, text.find("kd = ")) + text.substr(text.find("period_s"));
  CHECK(input_error_of([&] { (void)parse_controller_file(no_kd, "c.toml"); }).find("control.kd: missing") !=
        std::string::npos);
  const std::string unknown = text + "\n[extra]\nx = 1\n";
  CHECK(input_error_of([&] { (void)parse_controller_file(unknown, "c.toml"); }).find("extra: unknown key") !=
        std::string::npos);
  const std::string bad_rail = "format = \"gyrotc-controller\"\n[control]\nsetpoint_c = 55.0\nkp = 1.0\nki = 0.1\n"
                               "kd = 0.0\nperiod_s = 2.0\nxi_c = 1.0\n[rail]\npos_a = 0.5\nneg_a = 0.6\na_per_c = 0.0\n";
  CHECK(input_error_of([&] { (void)parse_controller_file(bad_rail, "c.toml"); })
            .find("c.toml:11: rail.neg_a: must be below rail.pos_a") != std::string::npos);
  CHECK(input_error_of([&] { (void)parse_controller_file("format = \"gyrotc-plant\"\n", "c.toml"); })
            .find("not a controller file") != std::string::npos);
  const std::string negative_kp = text.replace(text.find("kp = 1.25"), 9, "kp = -1.0");
  CHECK(input_error_of([&] { (void)parse_controller_file(negative_kp, "c.toml"); }).find("control.kp: must be within") !=
        std::string::npos);
  std::string negative_lag = format_controller_file(sample());
  negative_lag.replace(negative_lag.find("feed_forward_lag_s = 312.5"), 26, "feed_forward_lag_s = -5.0");
  CHECK(input_error_of([&] { (void)parse_controller_file(negative_lag, "c.toml"); })
            .find("control.feed_forward_lag_s: must be within") != std::string::npos);
}

TEST_CASE("the daemon configuration's controller_file sets the controller, relative to the configuration") {
  const std::string dir = gyrotc::test::scratch_dir() + "/controller_file_cfg";
  std::filesystem::create_directories(dir);
  save_controller_file(sample(), dir + "/unit.toml");
  const std::string cfg = dir + "/gyrotc.toml";
  std::ofstream(cfg) << "hal = \"sim\"\n[control]\ncontroller_file = \"unit.toml\"\n";
  const DaemonConfig c = load_daemon_config(cfg);
  CHECK(c.controller_file == dir + "/unit.toml");
  CHECK(c.controller.pid.kp == 1.25);
  CHECK(c.controller.feed_forward_a_per_c == 0.0049);
  CHECK(c.controller.feed_forward_lag_s == 312.5);
  CHECK(c.controller.rail.known);
}

TEST_CASE("the daemon configuration reads [control] feed_forward_lag_s and refuses it next to a controller_file") {
  const std::string own = write_temp("ff_lag.toml", "hal = \"sim\"\n[control]\nfeed_forward_a_per_c = 0.005\n"
                                                    "feed_forward_lag_s = 120.0\n");
  CHECK(load_daemon_config(own).controller.feed_forward_lag_s == 120.0);
  const std::string both = write_temp("ff_lag_conflict.toml", "hal = \"sim\"\n[control]\ncontroller_file = \"unit.toml\"\n"
                                                              "feed_forward_lag_s = 120.0\n");
  CHECK(input_error_of([&] { (void)load_daemon_config(both); })
            .find("ff_lag_conflict.toml:4: control.feed_forward_lag_s: set by control.controller_file") !=
        std::string::npos);
}

TEST_CASE("the daemon configuration refuses [control] gains next to a controller_file, naming the key") {
  const std::string cfg = write_temp("controller_file_conflict.toml",
                                     "hal = \"sim\"\n[control]\ncontroller_file = \"unit.toml\"\nkp = 2.0\n");
  CHECK(input_error_of([&] { (void)load_daemon_config(cfg); })
            .find("controller_file_conflict.toml:4: control.kp: set by control.controller_file") != std::string::npos);
}
