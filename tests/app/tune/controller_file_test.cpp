#include <filesystem>
#include <fstream>
#include <string>

#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "input_error_of.hpp"
#include "observer_controller_file.hpp"

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

// A board with the ambient sensor a tuned loop's feed-forward reads.
constexpr const char* kTwoSensors =
    "[devices.casing_sensor]\nid = \"28-000000000001\"\n[devices.ambient_sensor]\nid = \"28-000000000002\"\n";

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
  std::ofstream(cfg) << "hal = \"sim\"\n" << kTwoSensors << "[control]\ncontroller_file = \"unit.toml\"\n";
  const DaemonConfig c = load_daemon_config(cfg);
  CHECK(c.controller_file == dir + "/unit.toml");
  CHECK(c.controller.pid.kp == 1.25);
  CHECK(c.controller.feed_forward_a_per_c == 0.0049);
  CHECK(c.controller.feed_forward_lag_s == 312.5);
  CHECK(c.controller.rail.known);
}

TEST_CASE("the daemon configuration reads [control] feed_forward_lag_s and refuses it next to a controller_file") {
  const std::string own = write_temp("ff_lag.toml", "hal = \"sim\"\n" + std::string(kTwoSensors) +
                                                        "[control]\nfeed_forward_a_per_c = 0.005\nfeed_forward_lag_s = 120.0\n");
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

TEST_CASE("a model-based loop's controller file round-trips its model, noises and weights") {
  const ControllerFile c = gyrotc::test::observer_controller_file();
  const std::string text = format_controller_file(c);
  CHECK(text.find("version = 2") != std::string::npos);
  CHECK(text.find("type = \"observer\"") != std::string::npos);
  const ControllerFile back = parse_controller_file(text, "c.toml");
  REQUIRE(back.observer.has_value());
  CHECK(back.setpoint_c == c.setpoint_c);
  CHECK(back.period_s == c.period_s);
  const auto& m = back.observer->model;
  const auto& w = c.observer->model;
  CHECK(m.peltier_per_a_s == w.peltier_per_a_s);
  CHECK(m.joule_k_per_a2_s == w.joule_k_per_a2_s);
  CHECK(m.loss_per_s == w.loss_per_s);
  CHECK(m.shell_ratio == w.shell_ratio);
  CHECK(m.shell_tau_s == w.shell_tau_s);
  CHECK(m.internal_k_per_s == w.internal_k_per_s);
  CHECK(m.dead_time_s == w.dead_time_s);
  CHECK(m.sensor_lag_s == w.sensor_lag_s);
  CHECK(m.rail_a == w.rail_a);
  const auto& s = back.observer->spec;
  CHECK(s.design_ambient_c == c.observer->spec.design_ambient_c);
  CHECK(s.reading_noise_c == c.observer->spec.reading_noise_c);
  CHECK(s.initial_heat_w == c.observer->spec.initial_heat_w);
  CHECK(s.disturbance_w_per_sqrt_s == c.observer->spec.disturbance_w_per_sqrt_s);
  CHECK(s.error_scale_c == c.observer->spec.error_scale_c);
  CHECK(s.current_scale_a == c.observer->spec.current_scale_a);
}

TEST_CASE("a model-based loop's side node and casing weight round-trip, a file without them has none, and one out of range is refused") {
  ControllerFile c = gyrotc::test::observer_controller_file();
  c.observer->model.side_per_s = 1.25e-3;
  c.observer->model.side_tau_s = 180.0;
  c.observer->spec.casing_weight = 0.3;
  const std::string text = format_controller_file(c);
  const ControllerFile back = parse_controller_file(text, "c.toml");
  CHECK(back.observer->model.side_per_s == 1.25e-3);
  CHECK(back.observer->model.side_tau_s == 180.0);
  CHECK(back.observer->spec.casing_weight == 0.3);
  // A file written before they existed.
  std::string before = text;
  for (const char* key : {"side_per_s = ", "side_tau_s = ", "casing_weight = "}) {
    const auto at = before.find(key);
    before.erase(at, before.find('\n', at) - at + 1);
  }
  CHECK(parse_controller_file(before, "c.toml").observer->model.side_per_s == 0.0);
  CHECK(parse_controller_file(before, "c.toml").observer->spec.casing_weight == 0.0);
  std::string negative = text;
  negative.replace(negative.find("side_per_s = "), 13, "side_per_s = -");
  CHECK(input_error_of([&] { (void)parse_controller_file(negative, "c.toml"); }).find("model.side_per_s") !=
        std::string::npos);
}

TEST_CASE("applying a model-based loop's file designs a stable loop at its period within the board's limits") {
  ControllerConfig base;
  base.pid.out_min = -0.8;
  base.pid.out_max = 0.8;
  const ControllerConfig c = apply_controller_file(gyrotc::test::observer_controller_file(), base, "c.toml");
  REQUIRE(c.observer != nullptr);
  CHECK(c.pid.period_s == 1.0);
  CHECK(c.observer->spec.period_s == 1.0);
  CHECK(c.observer->model.current_limit_a == 0.8);
  CHECK(c.observer->observer_radius < 1.0);
  CHECK(c.observer->loop_radius < 1.0);
  CHECK(c.pid.out_max == 0.8);
  CHECK(c.limits.stuck_min_drive_a == 0.57);
  // A PID file applied over it takes the model-based loop away.
  CHECK(apply_controller_file(sample(), c, "pid.toml").observer == nullptr);
}

TEST_CASE("a model-based loop's file that is incomplete or mixed with the PID's keys is refused naming it") {
  const std::string text = format_controller_file(gyrotc::test::observer_controller_file());
  std::string old_version = text;
  old_version.replace(old_version.find("version = 2"), 11, "version = 1");
  CHECK(input_error_of([&] { (void)parse_controller_file(old_version, "c.toml"); })
            .find("c.toml:4: type: \"observer\" needs version = 2") != std::string::npos);
  const std::string no_model = text.substr(0, text.find("[model]")) + text.substr(text.find("[observer]"));
  CHECK(input_error_of([&] { (void)parse_controller_file(no_model, "c.toml"); }).find("c.toml: [model] missing") !=
        std::string::npos);
  std::string no_lag = text;
  no_lag.erase(no_lag.find("sensor_lag_s = "), no_lag.find("\n", no_lag.find("sensor_lag_s = ")) - no_lag.find("sensor_lag_s = ") + 1);
  CHECK(input_error_of([&] { (void)parse_controller_file(no_lag, "c.toml"); }).find("model.sensor_lag_s: missing") !=
        std::string::npos);
  std::string with_kp = text;
  with_kp.replace(with_kp.find("period_s = 1.0"), 14, "period_s = 1.0\nkp = 1.0");
  CHECK(input_error_of([&] { (void)parse_controller_file(with_kp, "c.toml"); }).find("control.kp: unknown key") !=
        std::string::npos);
  const std::string pid_with_model = format_controller_file(sample()) + "\n[model]\nrail_a = 1.0\n";
  CHECK(input_error_of([&] { (void)parse_controller_file(pid_with_model, "c.toml"); })
            .find("[model]: only a type = \"observer\" file has one") != std::string::npos);
  std::string bad_type = text;
  bad_type.replace(bad_type.find("type = \"observer\""), 17, "type = \"mpc\"");
  CHECK(input_error_of([&] { (void)parse_controller_file(bad_type, "c.toml"); })
            .find("type: must be \"pid\" or \"observer\"") != std::string::npos);
  std::string newer = text;
  newer.replace(newer.find("version = 2"), 11, "version = 3");
  CHECK(input_error_of([&] { (void)parse_controller_file(newer, "c.toml"); }).find("version: must be 1 or 2") !=
        std::string::npos);
}

TEST_CASE("a model-based loop that cannot hold its setpoint is refused when applied, naming the file") {
  ControllerFile c = gyrotc::test::observer_controller_file();
  c.observer->model.peltier_per_a_s = 1e-9;  // a TEC that moves no heat
  c.observer->model.joule_k_per_a2_s = 1e-9;
  CHECK(input_error_of([&] { (void)apply_controller_file(c, ControllerConfig{}, "hot.toml"); })
            .find("hot.toml: observer loop: no TEC current holds the setpoint") != std::string::npos);
}
