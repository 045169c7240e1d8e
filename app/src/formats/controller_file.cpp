#include "gyrotc/app/formats/controller_file.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "gyrotc/algorithms/tune/identified_housing.hpp"
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

// The identified housing's keys, each with its range (thermal_model.hpp).
// An optional key keeps ThermalModel's default when absent (files written
// before it existed).
struct ModelKey {
  const char* key;
  double tune::ThermalModel::*field;
  double min;
  double max;
  bool required = true;
};
constexpr ModelKey kModelKeys[] = {
    {"peltier_per_a_s", &tune::ThermalModel::peltier_per_a_s, 1e-12, 1.0},
    {"joule_k_per_a2_s", &tune::ThermalModel::joule_k_per_a2_s, 1e-12, 100.0},
    {"loss_per_s", &tune::ThermalModel::loss_per_s, 1e-12, 1.0},
    {"shell_ratio", &tune::ThermalModel::shell_ratio, 1e-6, 1e6},
    {"shell_tau_s", &tune::ThermalModel::shell_tau_s, 1e-3, 1e7},
    {"internal_k_per_s", &tune::ThermalModel::internal_k_per_s, -1.0, 1.0},
    {"dead_time_s", &tune::ThermalModel::dead_time_s, 0.0, 3600.0},
    {"sensor_lag_s", &tune::ThermalModel::sensor_lag_s, 0.0, 36000.0},
    {"sensor_ambient_share", &tune::ThermalModel::sensor_ambient_share, 0.0, 0.9, false},
    {"rail_a", &tune::ThermalModel::rail_a, 1e-6, 1e6},
    {"stage_limit_a", &tune::ThermalModel::stage_limit_a, 1e-6, 1e6, false},
    {"side_per_s", &tune::ThermalModel::side_per_s, 0.0, 1.0, false},
    {"side_tau_s", &tune::ThermalModel::side_tau_s, 1e-3, 1e7, false},
};

void parse_pid(const toml::table& root, const std::string& name, ControllerFile& c) {
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
}

// The filter's and the LQ design's keys, each with its range; an optional
// key's default is ObserverLoopSpec's (observer_loop.hpp). The heats are per
// unit of the casing's heat capacity, hence K/s.
struct SpecKey {
  const char* key;
  double control::ObserverLoopSpec::*field;
  double min;
  double max;
  bool required;
};
constexpr SpecKey kSpecKeys[] = {
    {"design_ambient_c", &control::ObserverLoopSpec::design_ambient_c, -100.0, 200.0, true},
    {"reading_step_c", &control::ObserverLoopSpec::reading_step_c, 0.0, 10.0, false},
    {"reading_noise_c", &control::ObserverLoopSpec::reading_noise_c, 0.0, 10.0, false},
    {"ambient_noise_c", &control::ObserverLoopSpec::ambient_noise_c, 0.0, 10.0, false},
    {"noise_floor_steps", &control::ObserverLoopSpec::noise_floor_steps, 0.0, 10.0, false},
    {"initial_heat_k_per_s", &control::ObserverLoopSpec::initial_heat_w, 1e-15, 100.0, true},
    {"heat_walk_k_per_s_per_sqrt_s", &control::ObserverLoopSpec::disturbance_w_per_sqrt_s, 1e-15, 100.0, true},
    {"ambient_walk_c_per_sqrt_s", &control::ObserverLoopSpec::ambient_c_per_sqrt_s, 1e-9, 100.0, false},
    {"node_walk_c_per_sqrt_s", &control::ObserverLoopSpec::node_c_per_sqrt_s, 1e-9, 100.0, false},
    {"error_scale_c", &control::ObserverLoopSpec::error_scale_c, 1e-6, 100.0, false},
    {"current_scale_a", &control::ObserverLoopSpec::current_scale_a, 1e-6, 100.0, false},
    {"casing_weight", &control::ObserverLoopSpec::casing_weight, 0.0, 100.0, false},
};

// Whether keys (an array of structs with a `key`) names key.
template <typename Keys>
auto names_in(const Keys& keys) {
  return [&keys](std::string_view key) {
    return std::any_of(std::begin(keys), std::end(keys), [key](const auto& k) { return key == k.key; });
  };
}

ObserverLoopFile parse_observer(const toml::table& root, const std::string& name) {
  ObserverLoopFile o;
  const toml::table* model_table = toml_section(root, "model", name);
  if (model_table == nullptr) throw InputError(name + ": [model] missing (type = \"observer\" is designed on it)");
  const TomlTable model(model_table, "model", name, names_in(kModelKeys));
  for (const ModelKey& k : kModelKeys) {
    double& value = o.model.*k.field;
    value = k.required ? required(model, k.key, k.min, k.max) : model.number(k.key, value, k.min, k.max);
  }
  const toml::table* observer_table = toml_section(root, "observer", name);
  if (observer_table == nullptr) throw InputError(name + ": [observer] missing (type = \"observer\" needs its noises)");
  const TomlTable t(observer_table, "observer", name, names_in(kSpecKeys));
  for (const SpecKey& k : kSpecKeys) {
    double& value = o.spec.*k.field;
    value = k.required ? required(t, k.key, k.min, k.max) : t.number(k.key, value, k.min, k.max);
  }
  return o;
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
    if (key != "format" && key != "version" && key != "type" && key != "control" && key != "rail" &&
        key != "failsafe" && key != "model" && key != "observer" && key != "identified" && key != "design") {
      throw InputError(name + ":" + std::to_string(node.source().begin.line) + ": " + key +
                       ": unknown key (expected format, version, type, [control], [rail], [failsafe], [model], "
                       "[observer], [identified], [design])");
    }
  }
  const toml::node* format = root.get("format");
  if (format == nullptr || format->value<std::string>() != std::string("gyrotc-controller")) {
    throw InputError(name + ": not a controller file (format = \"gyrotc-controller\" expected; `gyrotc tune` "
                     "writes one)");
  }
  const toml::node* version = root.get("version");
  const std::int64_t version_number = version != nullptr ? version->value<std::int64_t>().value_or(0) : 1;
  if (version_number != 1 && version_number != 2) {
    throw InputError(name + ":" + std::to_string(version->source().begin.line) +
                     ": version: must be 1 or 2 (a newer gyrotc wrote this file?)");
  }
  const toml::node* type = root.get("type");
  const std::string type_name = type != nullptr ? type->value<std::string>().value_or("?") : "pid";
  if (type_name != "pid" && type_name != "observer") {
    throw InputError(name + ":" + std::to_string(type->source().begin.line) +
                     ": type: must be \"pid\" or \"observer\"");
  }
  if (type_name == "observer" && version_number < 2) {
    throw InputError(name + ":" + std::to_string(type->source().begin.line) +
                     ": type: \"observer\" needs version = 2");
  }
  (void)toml_section(root, "identified", name);
  (void)toml_section(root, "design", name);

  ControllerFile c;
  if (type_name == "observer") {
    const TomlTable control(toml_section(root, "control", name), "control", name, {"setpoint_c", "period_s"});
    c.setpoint_c = required(control, "setpoint_c", -55.0, 125.0);
    c.period_s = required(control, "period_s", 0.01, 3600.0);
    c.observer = parse_observer(root, name);
  } else {
    for (const char* table : {"model", "observer"}) {
      if (const toml::node* node = root.get(table)) {
        throw InputError(name + ":" + std::to_string(node->source().begin.line) + ": [" + table +
                         "]: only a type = \"observer\" file has one");
      }
    }
    parse_pid(root, name, c);
  }
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
  if (c.observer) {
    const ObserverLoopFile& o = *c.observer;
    out += "format = \"gyrotc-controller\"\nversion = 2\ntype = \"observer\"   # the model-based loop\n\n[control]\n";
    out += "setpoint_c = " + num(c.setpoint_c) + "\n";
    out += "period_s = " + num(c.period_s) + "\n";
    out += "\n[model]                # the identified housing, per unit of the casing's heat capacity\n";
    for (const ModelKey& k : kModelKeys) out += std::string(k.key) + " = " + num(o.model.*k.field) + "\n";
    out += "\n[observer]             # the filter's noises (heats in K/s of the casing) and the LQ weights\n";
    for (const SpecKey& k : kSpecKeys) out += std::string(k.key) + " = " + num(o.spec.*k.field) + "\n";
  } else {
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
  }
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
  base.observer = nullptr;
  if (file.stuck_min_drive_a) base.limits.stuck_min_drive_a = *file.stuck_min_drive_a;
  try {
    if (file.observer) {
      control::ObserverLoopSpec spec = file.observer->spec;
      spec.setpoint_c = file.setpoint_c;
      spec.period_s = file.period_s;
      base.observer = std::make_shared<const control::ObserverLoopDesign>(control::design_observer_loop(
          tune::identified_housing(file.observer->model, std::max(out_max, -out_min)), spec));
    }
    validate(base);
  } catch (const std::invalid_argument& e) {
    throw InputError(source + ": " + e.what());
  }
  return base;
}

}  // namespace gyrotc::app
