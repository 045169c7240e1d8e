#include "gyrotc/app/daemon/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <stdexcept>
#include <string_view>

#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/formats/toml_table.hpp"

namespace gyrotc::app {
namespace {

void check_top_level(const toml::table& root, const std::string& source) {
  static constexpr std::string_view kKnown[] = {"hal",     "devices",     "tec",    "sim",     "control",
                                                "calibration", "output", "realtime", "failsafe"};
  for (auto&& [key, node] : root) {
    if (std::find(std::begin(kKnown), std::end(kKnown), key.str()) == std::end(kKnown)) {
      throw InputError(source + ":" + std::to_string(node.source().begin.line) + ": " + std::string(key.str()) +
                       ": unknown key (expected hal, [devices], [tec], [sim], [control], [calibration], [output], "
                       "[realtime], [failsafe])");
    }
  }
}

FailSafeLimits parse_failsafe(const TomlTable& t) {
  FailSafeLimits l;
  l.stale_periods = t.number("stale_periods", l.stale_periods, 1.0, 1000.0);
  l.stuck_s = t.number("stuck_s", l.stuck_s, 1.0, 86400.0);
  l.stuck_min_drive_a = t.number("stuck_min_drive_a", l.stuck_min_drive_a, 0.0, 100.0);
  l.stuck_span_a = t.number("stuck_span_a", l.stuck_span_a, 0.0, 100.0);
  l.stuck_sigma = t.number("stuck_sigma", l.stuck_sigma, 1.0, 1000.0);
  l.stuck_sigma_s = t.number("stuck_sigma_s", l.stuck_sigma_s, 0.0, 86400.0);
  l.stuck_probe_s = t.number("stuck_probe_s", l.stuck_probe_s, 0.0, 86400.0);
  l.stuck_probe_hold_s = t.number("stuck_probe_hold_s", l.stuck_probe_hold_s, 1.0, 3600.0);
  l.runaway_s = t.number("runaway_s", l.runaway_s, 1.0, 86400.0);
  l.runaway_c = t.number("runaway_c", l.runaway_c, 0.0625, 100.0);
  l.recovery_readings = static_cast<int>(t.integer("recovery_readings", l.recovery_readings, 1, 1000));
  l.min_valid_c = t.number("min_valid_c", l.min_valid_c, -55.0, 125.0);
  l.max_valid_c = t.number("max_valid_c", l.max_valid_c, -55.0, 125.0);
  if (l.min_valid_c >= l.max_valid_c) t.fail_at("max_valid_c", "must be above failsafe.min_valid_c");
  l.over_temp_c = t.number("over_temp_c", l.over_temp_c, -55.0, 125.0);
  l.opa548_cooldown_s = t.number("opa548_cooldown_s", l.opa548_cooldown_s, 0.0, 86400.0);
  l.adc_stall_s = t.number("adc_stall_s", l.adc_stall_s, 0.1, 3600.0);
  l.ambient_stale_s = t.number("ambient_stale_s", l.ambient_stale_s, 1.0, 86400.0);
  return l;
}

}  // namespace

DaemonConfig parse_daemon_config(const toml::table& root, const std::string& source) {
  check_top_level(root, source);
  DaemonConfig c;
  c.source = source;
  c.board = parse_board_config(root, source);
  const double limit_a = c.board.devices.tec.current_limit_a;

  const TomlTable failsafe(toml_section(root, "failsafe", source), "failsafe", source,
                           {"stale_periods", "stuck_s", "stuck_min_drive_a", "stuck_span_a", "stuck_sigma", "stuck_sigma_s", "stuck_probe_s",
                            "stuck_probe_hold_s", "runaway_s", "runaway_c",
                            "recovery_readings",
                            "over_temp_c", "opa548_cooldown_s", "adc_stall_s", "ambient_stale_s", "min_valid_c",
                            "max_valid_c"});
  c.controller.limits = parse_failsafe(failsafe);

  const TomlTable control(toml_section(root, "control", source), "control", source,
                          {"setpoint_c", "kp", "ki", "kd", "period_s", "xi_c", "out_min_a", "out_max_a", "pid",
                           "feed_forward_a_per_c", "feed_forward_lag_s", "setpoint_ramp_c_per_s", "rate_out_v_per_dps",
                           "sensor_period_s", "controller_file"});
  c.controller_file = control.string("controller_file", "");
  if (!c.controller_file.empty()) {
    // The file (gyrotc tune's) sets the controller: the same keys here would be ignored.
    for (const char* key : {"setpoint_c", "kp", "ki", "kd", "period_s", "xi_c", "feed_forward_a_per_c",
                            "feed_forward_lag_s", "setpoint_ramp_c_per_s"}) {
      if (control.get(key) != nullptr) {
        control.fail_at(key, "set by control.controller_file (\"" + c.controller_file + "\"); give one or the other");
      }
    }
  }
  ControllerConfig& cc = c.controller;
  // The setpoint must be one the casing can hold without tripping a fail-safe.
  cc.setpoint_c = control.number("setpoint_c", cc.setpoint_c, cc.limits.min_valid_c, cc.limits.over_temp_c - 1.0);
  const double period_s = control.number("period_s", cc.pid.period_s, 0.01, 3600.0);
  // Seed Section 6.1 gain form (KI = Kp T/TI, KD = Kp TD/T): defaults Eq. 17/18.
  const double kp = control.number("kp", 0.48, 1e-9, kUnbounded);
  const double ki = control.number("ki", 0.32, 1e-9, kUnbounded);
  const double kd = control.number("kd", 10.0, 0.0, kUnbounded);
  cc.pid = control::PidParams::from_gains(kp, ki, kd, period_s);
  cc.pid.xi_c = control.number("xi_c", 0.5, 0.0, 200.0);
  cc.pid.out_min = control.number("out_min_a", -limit_a, -limit_a, limit_a);
  cc.pid.out_max = control.number("out_max_a", limit_a, -limit_a, limit_a);
  if (cc.pid.out_min >= cc.pid.out_max) control.fail_at("out_max_a", "must be above control.out_min_a");
  cc.pid_enabled = control.boolean("pid", true);
  cc.feed_forward_a_per_c = control.number("feed_forward_a_per_c", 0.0, -10.0, 10.0);
  if (cc.feed_forward_a_per_c != 0.0 && !c.board.devices.ambient_sensor) {
    control.fail_at("feed_forward_a_per_c", "needs the ambient reading, and [devices.ambient_sensor] is absent");
  }
  cc.feed_forward_lag_s = control.number("feed_forward_lag_s", 0.0, 0.0, 1e5);
  cc.setpoint_ramp_c_per_s = control.number("setpoint_ramp_c_per_s", 0.0, 0.0, 100.0);
  cc.rate_out_v_per_dps = control.number("rate_out_v_per_dps", cc.rate_out_v_per_dps, 1e-9, 1000.0);
  cc.rate_dac_vref_v = c.board.devices.rate_dac.vref_v;
  c.sensor_period_s = control.number("sensor_period_s", 1.0, 0.75, 60.0);  // a 12-bit conversion takes 750 ms
  if (c.sensor_period_s > period_s) {
    control.fail_at("sensor_period_s", "must not exceed control.period_s (a fresh reading every PID period)");
  }
  try {
    validate(cc);
  } catch (const std::invalid_argument& e) {
    control.fail_at("setpoint_c", e.what());
  }

  const TomlTable calibration(toml_section(root, "calibration", source), "calibration", source, {"file"});
  c.calibration_file = calibration.string("file", "");

  const TomlTable output(toml_section(root, "output", source), "output", source,
                     {"stream", "path", "baud", "period_s", "record_csv", "record_max_mb", "status_interval_s",
                          "write_timeout_s", "status_file", "metrics_file"});
  OutputConfig& o = c.output;
  const std::string stream = output.string("stream", "stdout");
  if (stream == "stdout") {
    o.stream = StreamKind::stdout_stream;
  } else if (stream == "file") {
    o.stream = StreamKind::file;
  } else if (stream == "serial") {
    o.stream = StreamKind::serial;
  } else if (stream == "none") {
    o.stream = StreamKind::none;
  } else {
    output.fail_at("stream", "expected \"stdout\", \"file\", \"serial\" or \"none\", got \"" + stream + "\"");
  }
  o.path = output.string("path", "");
  if ((o.stream == StreamKind::file || o.stream == StreamKind::serial) && o.path.empty()) {
    output.fail_at("path", "required with stream = \"" + stream + "\" (the file or serial device)");
  }
  o.baud = static_cast<int>(output.integer("baud", o.baud, 1200, 921600));
  o.period_s = output.number("period_s", o.period_s, 0.001, 3600.0);
  o.record_csv = output.string("record_csv", "");
  o.record_max_mb = output.number("record_max_mb", o.record_max_mb, 0.0, 1e6);
  o.status_interval_s = output.number("status_interval_s", o.status_interval_s, 0.0, 86400.0);
  o.write_timeout_s = output.number("write_timeout_s", o.write_timeout_s, 0.0, 10.0);
  o.status_file = output.string("status_file", o.status_file);
  o.metrics_file = output.string("metrics_file", "");
  if (!o.metrics_file.empty() && !o.metrics_file.ends_with(".prom")) {
    // node_exporter's textfile collector reads *.prom only.
    output.fail_at("metrics_file", "must end in .prom (node_exporter's textfile collector reads only those)");
  }

  const TomlTable realtime(toml_section(root, "realtime", source), "realtime", source, {"priority", "cpu", "lock_memory"});
  c.realtime.priority = static_cast<int>(realtime.integer("priority", c.realtime.priority, 1, 99));
  const std::int64_t cpu = realtime.integer("cpu", -1, -1, 1023);
  if (cpu >= 0) c.realtime.cpu = static_cast<int>(cpu);
  c.realtime.lock_memory = realtime.boolean("lock_memory", true);
  return c;
}

void use_controller_file(DaemonConfig& config, const std::string& path) {
  config.controller = apply_controller_file(load_controller_file(path), config.controller, path);
  config.controller_file = path;
  // The file's loop was identified with the ambient as an input: without the
  // sensor the PID would lose its feed-forward and the model-based loop its
  // reading of the housing's other side, silently.
  if (!config.board.devices.ambient_sensor) {
    if (config.controller.observer) {
      throw InputError(path + ": type = \"observer\": the model-based loop reads the ambient, and " + config.source +
                       " has no [devices.ambient_sensor]");
    }
    if (config.controller.feed_forward_a_per_c != 0.0) {
      throw InputError(path + ": feed_forward_a_per_c: needs the ambient reading, and " + config.source +
                       " has no [devices.ambient_sensor]");
    }
  }
  if (config.sensor_period_s > config.controller.pid.period_s) {
    throw InputError(path + ": control.period_s " + format_toml_number(config.controller.pid.period_s) +
                     " is shorter than the configuration's sensor_period_s (a fresh reading every PID period)");
  }
}

DaemonConfig load_daemon_config(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw InputError(path + ": no such configuration file");
  toml::table root;
  try {
    root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw InputError(path + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  DaemonConfig c = parse_daemon_config(root, path);
  if (!c.calibration_file.empty() && std::filesystem::path(c.calibration_file).is_relative()) {
    c.calibration_file = (std::filesystem::path(path).parent_path() / c.calibration_file).lexically_normal().string();
  }
  for (std::string* file : {&c.output.status_file, &c.output.metrics_file}) {
    if (!file->empty() && std::filesystem::path(*file).is_relative()) {
      *file = (std::filesystem::path(path).parent_path() / *file).lexically_normal().string();
    }
  }
  if (!c.controller_file.empty()) {
    std::filesystem::path file(c.controller_file);
    if (file.is_relative()) file = (std::filesystem::path(path).parent_path() / file).lexically_normal();
    use_controller_file(c, file.string());
  }
  return c;
}

}  // namespace gyrotc::app
