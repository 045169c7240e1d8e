#include "gyrotc/app/formats/controller_file.hpp"

#include <toml++/toml.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/formats/toml_table.hpp"

namespace gyrotc::app {
namespace {

// A key the file must give.
double required(const TomlTable& t, const char* key, double min, double max) {
  if (t.get(key) == nullptr) t.fail_at(key, "missing");
  return t.number(key, 0.0, min, max);
}

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  std::string s(buf);
  if (s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}

}  // namespace

ControllerFile parse_controller_file(std::string_view text, const std::string& name) {
  toml::table root;
  try {
    root = toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    throw InputError(name + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  for (const auto& [k, node] : root) {
    const std::string key(k.str());
    if (key != "format" && key != "version" && key != "control" && key != "rail" && key != "failsafe" &&
        key != "identified" && key != "design") {
      throw InputError(name + ":" + std::to_string(node.source().begin.line) + ": " + key +
                       ": unknown key (expected format, version, [control], [rail], [failsafe], [identified], "
                       "[design])");
    }
  }
  const toml::node* format = root.get("format");
  if (format == nullptr || format->value<std::string>() != std::string("gyrotc-controller")) {
    throw InputError(name + ": not a controller file (format = \"gyrotc-controller\" expected; `gyrotc tune` "
                     "writes one)");
  }
  const toml::node* version = root.get("version");
  if (version != nullptr && version->value<std::int64_t>() != std::int64_t{1}) {
    throw InputError(name + ":" + std::to_string(version->source().begin.line) + ": version: must be 1");
  }
  (void)toml_section(root, "identified", name);
  (void)toml_section(root, "design", name);

  ControllerFile c;
  const TomlTable control(toml_section(root, "control", name), "control", name,
                          {"setpoint_c", "kp", "ki", "kd", "period_s", "xi_c", "feed_forward_a_per_c",
                           "feed_forward_lag_s", "setpoint_ramp_c_per_s"});
  c.setpoint_c = required(control, "setpoint_c", -55.0, 125.0);
  c.kp = required(control, "kp", 1e-9, kUnbounded);
  c.ki = required(control, "ki", 1e-9, kUnbounded);
  c.kd = required(control, "kd", 0.0, kUnbounded);
  c.period_s = required(control, "period_s", 0.01, 3600.0);
  c.xi_c = required(control, "xi_c", 0.0, 200.0);
  c.feed_forward_a_per_c = control.number("feed_forward_a_per_c", 0.0, -10.0, 10.0);
  c.feed_forward_lag_s = control.number("feed_forward_lag_s", 0.0, 0.0, 1e5);
  c.setpoint_ramp_c_per_s = control.number("setpoint_ramp_c_per_s", 0.0, 0.0, 100.0);

  const toml::table* rail_table = toml_section(root, "rail", name);
  const TomlTable rail(rail_table, "rail", name, {"pos_a", "neg_a", "a_per_c"});
  if (rail_table != nullptr) {
    c.rail.known = true;
    c.rail.pos_a = required(rail, "pos_a", -100.0, 100.0);
    c.rail.neg_a = required(rail, "neg_a", -100.0, 100.0);
    if (c.rail.neg_a >= c.rail.pos_a) rail.fail_at("neg_a", "must be below rail.pos_a");
    c.rail.a_per_c = required(rail, "a_per_c", 0.0, 10.0);
  }
  const TomlTable failsafe(toml_section(root, "failsafe", name), "failsafe", name, {"stuck_min_drive_a"});
  if (failsafe.get("stuck_min_drive_a") != nullptr) {
    c.stuck_min_drive_a = failsafe.number("stuck_min_drive_a", 0.0, 1e-3, 100.0);
  }
  return c;
}

ControllerFile load_controller_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the controller file");
  std::stringstream text;
  text << in.rdbuf();
  return parse_controller_file(text.str(), path);
}

std::string format_controller_file(const ControllerFile& c, const std::string& informational) {
  std::string out = "# gyrotc controller (see app/include/gyrotc/app/formats/controller_file.hpp)\n";
  out += "format = \"gyrotc-controller\"\nversion = 1\n\n[control]\n";
  out += "setpoint_c = " + num(c.setpoint_c) + "\n";
  out += "kp = " + num(c.kp) + "                 # seed Eq. 17/18 gain form: KI = Kp T/TI, KD = Kp TD/T\n";
  out += "ki = " + num(c.ki) + "\n";
  out += "kd = " + num(c.kd) + "\n";
  out += "period_s = " + num(c.period_s) + "\n";
  out += "xi_c = " + num(c.xi_c) + "               # integral separation band\n";
  out += "feed_forward_a_per_c = " + num(c.feed_forward_a_per_c) + "\n";
  out += "feed_forward_lag_s = " + num(c.feed_forward_lag_s) + "      # the ambient through the housing's lag\n";
  out += "setpoint_ramp_c_per_s = " + num(c.setpoint_ramp_c_per_s) + "\n";
  if (c.rail.known) {
    out += "\n[rail]                 # OPA548 output swing: max = pos_a - a_per_c * (casing - ambient)\n";
    out += "pos_a = " + num(c.rail.pos_a) + "\nneg_a = " + num(c.rail.neg_a) + "\na_per_c = " + num(c.rail.a_per_c) + "\n";
  }
  if (c.stuck_min_drive_a) out += "\n[failsafe]\nstuck_min_drive_a = " + num(*c.stuck_min_drive_a) + "\n";
  if (!informational.empty()) out += "\n" + informational;
  return out;
}

void save_controller_file(const ControllerFile& file, const std::string& path, const std::string& informational) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw RuntimeFailure(path + ": cannot write the controller file");
  out << format_controller_file(file, informational);
  if (!out) throw RuntimeFailure(path + ": cannot write the controller file");
}

ControllerConfig apply_controller_file(const ControllerFile& file, ControllerConfig base, const std::string& source) {
  const double out_min = base.pid.out_min;
  const double out_max = base.pid.out_max;
  base.setpoint_c = file.setpoint_c;
  base.pid = control::PidParams::from_gains(file.kp, file.ki, file.kd, file.period_s);
  base.pid.xi_c = file.xi_c;
  base.pid.out_min = out_min;
  base.pid.out_max = out_max;
  base.feed_forward_a_per_c = file.feed_forward_a_per_c;
  base.feed_forward_lag_s = file.feed_forward_lag_s;
  base.setpoint_ramp_c_per_s = file.setpoint_ramp_c_per_s;
  base.rail = file.rail;
  if (file.stuck_min_drive_a) base.limits.stuck_min_drive_a = *file.stuck_min_drive_a;
  try {
    validate(base);
  } catch (const std::invalid_argument& e) {
    throw InputError(source + ": " + e.what());
  }
  return base;
}

}  // namespace gyrotc::app
