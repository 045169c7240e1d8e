#include "gyrotc/app/formats/board_config.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <string_view>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {

namespace {

// One table of the file: reads typed keys and names file, line and key in
// every error. Keys not in `allowed` are rejected on construction.
class Section {
 public:
  Section(const toml::table& table, std::string name, const std::string& source,
          std::initializer_list<std::string_view> allowed)
      : table_(table), name_(std::move(name)), source_(source) {
    for (auto&& [key, node] : table_) {
      if (std::find(allowed.begin(), allowed.end(), key.str()) == allowed.end()) {
        fail(node, std::string(key.str()), "unknown key in [" + name_ + "]");
      }
    }
  }

  [[noreturn]] void fail(const toml::node& node, const std::string& key, const std::string& why) const {
    throw InputError(source_ + ":" + std::to_string(node.source().begin.line) + ": " + qualified(key) + ": " + why);
  }

  double number(const std::string& key, double fallback, double min, double max) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr) return fallback;
    const std::optional<double> value = node->value<double>();  // integers convert
    if (!value || !node->is_number()) fail(*node, key, "expected a number");
    if (!(*value >= min && *value <= max)) {
      fail(*node, key, "must be within " + format(min) + " .. " + format(max) + ", got " + format(*value));
    }
    return *value;
  }

  std::string string(const std::string& key, const std::string& fallback) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr) return fallback;
    if (!node->is_string()) fail(*node, key, "expected a string");
    return *node->value<std::string>();
  }

  bool boolean(const std::string& key, bool fallback) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr) return fallback;
    if (!node->is_boolean()) fail(*node, key, "expected true or false");
    return *node->value<bool>();
  }

  std::uint64_t unsigned_integer(const std::string& key, std::uint64_t fallback) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr) return fallback;
    if (!node->is_integer() || *node->value<std::int64_t>() < 0) fail(*node, key, "expected an integer >= 0");
    return static_cast<std::uint64_t>(*node->value<std::int64_t>());
  }

  // "chip:line", e.g. "gpiochip0:25" or "/dev/gpiochip1:DRDY", with the
  // optional sibling keys <key>_bias ("as-is", "disabled", "pull-up",
  // "pull-down") and <key>_active_low.
  hal::GpioRef gpio(const std::string& key, const hal::GpioRef& fallback) const {
    const toml::node* node = table_.get(key);
    hal::GpioRef ref = fallback;
    if (node != nullptr) {
      const std::string text = string(key, "");
      const std::size_t colon = text.rfind(':');
      if (colon == std::string::npos || colon == 0 || colon + 1 == text.size()) {
        fail(*node, key, "expected \"chip:line\" (e.g. \"gpiochip0:25\"), got \"" + text + "\"");
      }
      ref.chip = text.substr(0, colon);
      ref.line = text.substr(colon + 1);
    }
    if (const toml::node* bias = table_.get(key + "_bias")) {
      const std::string text = string(key + "_bias", "");
      if (text == "as-is") {
        ref.bias = hal::GpioBias::as_is;
      } else if (text == "disabled") {
        ref.bias = hal::GpioBias::disabled;
      } else if (text == "pull-up") {
        ref.bias = hal::GpioBias::pull_up;
      } else if (text == "pull-down") {
        ref.bias = hal::GpioBias::pull_down;
      } else {
        fail(*bias, key + "_bias", "expected \"as-is\", \"disabled\", \"pull-up\" or \"pull-down\", got \"" + text + "\"");
      }
    }
    ref.active_low = boolean(key + "_active_low", ref.active_low);
    return ref;
  }

  const toml::table* subtable(const std::string& key) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr) return nullptr;
    if (!node->is_table()) fail(*node, key, "expected a table");
    return node->as_table();
  }

  const toml::node* get(const std::string& key) const { return table_.get(key); }
  const std::string& name() const { return name_; }

 private:
  std::string qualified(const std::string& key) const { return name_.empty() ? key : name_ + "." + key; }
  static std::string format(double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%g", v);
    return buffer;
  }

  const toml::table& table_;
  std::string name_;
  const std::string& source_;
};

constexpr double kInf = std::numeric_limits<double>::infinity();
const toml::table kEmpty;

void parse_sensor(const toml::table& table, const std::string& name, const std::string& source,
                  hal::W1SensorConfig& sensor) {
  const Section s(table, name, source, {"w1_root", "id", "source", "stuck_after_s"});
  sensor.w1_root = s.string("w1_root", sensor.w1_root);
  sensor.id = s.string("id", sensor.id);
  if (!sensor.id.empty() && sensor.id.find('/') != std::string::npos) {
    s.fail(*s.get("id"), "id", "expected a w1 device id like \"28-000005e2fdc3\"");
  }
  const std::string file = s.string("source", "w1_slave");
  if (file == "w1_slave") {
    sensor.options.source = hal::W1File::w1_slave;
  } else if (file == "temperature") {
    sensor.options.source = hal::W1File::temperature;
  } else {
    s.fail(*s.get("source"), "source", "expected \"w1_slave\" or \"temperature\", got \"" + file + "\"");
  }
  sensor.options.stuck_after_s = s.number("stuck_after_s", sensor.options.stuck_after_s, 0.0, kInf);
}

// Two DS18B20s on the bus: each must be named, and not both alike, or the
// casing sensor (the PID's input, the over-temperature latch's) can bind to
// the ambient one.
void check_sensor_ids(const Section& devices, const std::string& source, const hal::LinuxBoardConfig& d,
                      bool list_bus) {
  const auto& casing = d.casing_sensor;
  const auto& ambient = *d.ambient_sensor;
  const auto line_of = [&](const char* sensor) {
    const toml::node* table = devices.get(sensor);
    const toml::node* id = table != nullptr && table->is_table() ? table->as_table()->get("id") : nullptr;
    return std::to_string((id != nullptr ? id : table)->source().begin.line);
  };
  const auto on_bus = [&]() -> std::string {
    if (!list_bus) return " (ls " + casing.w1_root + ")";
    const auto ids = hal::W1Sysfs::list_ds18b20(casing.w1_root);
    if (!ids || ids->empty()) return " (no DS18B20 under " + casing.w1_root + " now)";
    std::string text;
    for (const std::string& id : *ids) text += (text.empty() ? "" : ", ") + id;
    return " (on the bus now: " + text + ")";
  };
  const auto quoted = [](const std::string& id) { return "\"" + id + "\""; };
  if (casing.id.empty()) {
    throw InputError(source + ":" + line_of("casing_sensor") +
                     ": devices.casing_sensor.id: empty, but a second DS18B20 is configured (ambient_sensor id " +
                     quoted(ambient.id) + "): the casing sensor could bind to either; set both ids" + on_bus());
  }
  if (ambient.id.empty()) {
    throw InputError(source + ":" + line_of("ambient_sensor") +
                     ": devices.ambient_sensor.id: empty, but the casing sensor is " + quoted(casing.id) +
                     ": the ambient sensor could bind to either; set both ids" + on_bus());
  }
  if (casing.id == ambient.id && casing.w1_root == ambient.w1_root) {
    throw InputError(source + ":" + line_of("ambient_sensor") + ": devices.ambient_sensor.id: " + quoted(ambient.id) +
                     " is the casing sensor's id too: one sensor cannot be both" + on_bus());
  }
}

void parse_devices(const toml::table& table, const std::string& source, hal::LinuxBoardConfig& d, bool list_bus) {
  const Section devices(table, "devices", source,
                        {"adc", "rate_dac", "tec_dac", "opa548", "casing_sensor", "ambient_sensor"});
  {
    const toml::table* t = devices.subtable("adc");
    const Section s(t ? *t : kEmpty, "devices.adc", source,
                    {"spi", "drdy", "drdy_bias", "drdy_active_low", "fclk_hz", "vref_v", "spi_speed_hz",
                     "latency_budget_s", "stamp_latency_max_s"});
    d.adc_spi = s.string("spi", d.adc_spi);
    d.adc_drdy = s.gpio("drdy", d.adc_drdy);
    d.adc.fclk_hz = s.number("fclk_hz", d.adc.fclk_hz, 1.0, 10e6);
    d.adc.vref_v = s.number("vref_v", d.adc.vref_v, 0.1, 5.0);
    d.adc.spi_speed_hz = static_cast<std::uint32_t>(s.number("spi_speed_hz", d.adc.spi_speed_hz, 1e3, 50e6));
    d.adc.latency_budget_s = s.number("latency_budget_s", d.adc.latency_budget_s, 0.0, 1.0);
    d.adc.stamp_latency_max_s = s.number("stamp_latency_max_s", d.adc.stamp_latency_max_s, 0.0, 0.1);
    if (hal::Status ok = hal::Ads1251::validate(d.adc); !ok) {
      const toml::node* at = s.get("fclk_hz");
      throw InputError(source + ":" + std::to_string(at ? at->source().begin.line : table.source().begin.line) +
                       ": devices.adc: " + std::string(ok.error().message()));
    }
  }
  {
    const toml::table* t = devices.subtable("rate_dac");
    const Section s(t ? *t : kEmpty, "devices.rate_dac", source, {"spi", "vref_v", "spi_speed_hz"});
    d.rate_dac_spi = s.string("spi", d.rate_dac_spi);
    d.rate_dac.vref_v = s.number("vref_v", d.rate_dac.vref_v, 0.1, 5.5);
    d.rate_dac.spi_speed_hz =
        static_cast<std::uint32_t>(s.number("spi_speed_hz", d.rate_dac.spi_speed_hz, 1e3, 30e6));
  }
  {
    const toml::table* t = devices.subtable("tec_dac");
    const Section s(t ? *t : kEmpty, "devices.tec_dac", source, {"spi", "spi_speed_hz"});
    d.tec_dac_spi = s.string("spi", d.tec_dac_spi);
    d.tec_dac.spi_speed_hz = static_cast<std::uint32_t>(s.number("spi_speed_hz", d.tec_dac.spi_speed_hz, 1e3, 30e6));
  }
  {
    const toml::table* t = devices.subtable("opa548");
    const Section s(t ? *t : kEmpty, "devices.opa548", source,
                    {"es", "es_bias", "es_active_low", "es_sense", "es_sense_bias", "es_sense_active_low"});
    d.opa548_es = s.gpio("es", d.opa548_es);
    if (s.get("es_sense") != nullptr) {
      d.opa548_es_sense = s.gpio("es_sense", {});
    } else if (const toml::node* orphan = s.get("es_sense_bias") ? s.get("es_sense_bias") : s.get("es_sense_active_low")) {
      s.fail(*orphan, "es_sense", "es_sense_bias / es_sense_active_low given without an es_sense line");
    }
  }
  {
    const toml::table* t = devices.subtable("casing_sensor");
    parse_sensor(t ? *t : kEmpty, "devices.casing_sensor", source, d.casing_sensor);
  }
  if (const toml::table* t = devices.subtable("ambient_sensor")) {
    d.ambient_sensor.emplace();
    parse_sensor(*t, "devices.ambient_sensor", source, *d.ambient_sensor);
    check_sensor_ids(devices, source, d, list_bus);
  }
}

}  // namespace

BoardConfig parse_board_config(const toml::table& root, const std::string& source) {
  BoardConfig config;
  const toml::node* hal_node = root.get("hal");
  if (hal_node == nullptr) {
    throw InputError(source + ": missing key 'hal' (\"linux\" or \"sim\")");
  }
  const std::optional<std::string> hal = hal_node->value<std::string>();
  if (hal == "linux") {
    config.hal = HalKind::linux_devices;
  } else if (hal == "sim") {
    config.hal = HalKind::sim;
  } else {
    throw InputError(source + ":" + std::to_string(hal_node->source().begin.line) +
                     ": hal: expected \"linux\" or \"sim\"");
  }

  if (const toml::node* node = root.get("devices")) {
    if (!node->is_table()) {
      throw InputError(source + ":" + std::to_string(node->source().begin.line) + ": devices: expected a table");
    }
    parse_devices(*node->as_table(), source, config.devices, config.hal == HalKind::linux_devices);
  } else {
    parse_devices(kEmpty, source, config.devices, config.hal == HalKind::linux_devices);
  }

  const auto table_of = [&](const char* key) -> const toml::table* {
    const toml::node* node = root.get(key);
    if (node == nullptr) return nullptr;
    if (!node->is_table()) {
      throw InputError(source + ":" + std::to_string(node->source().begin.line) + ": " + key + ": expected a table");
    }
    return node->as_table();
  };

  {
    const toml::table* t = table_of("tec");
    const Section s(t ? *t : kEmpty, "tec", source, {"dac_vref_v", "gain_a_per_v", "current_limit_a"});
    auto& d = config.devices;
    d.tec_dac.vref_v = s.number("dac_vref_v", d.tec_dac.vref_v, 0.1, 5.5);
    d.tec.gain_a_per_v = s.number("gain_a_per_v", d.tec.gain_a_per_v, 1e-3, 100.0);
    d.tec.current_limit_a = s.number("current_limit_a", d.tec.current_limit_a, 0.0, 10.0);
  }
  {
    const toml::table* t = table_of("sim");
    const Section s(t ? *t : kEmpty, "sim", source,
                    {"seed", "thermal_step_s", "initial_temp_c", "adc_wake_min_us", "adc_wake_max_us",
                     "adc_stall_probability", "adc_stall_max_us", "adc_irq_delay_max_us", "adc_stamp_delay_max_us",
                     "adc_spi_start_max_us", "adc_spi_return_max_us"});
    config.sim.seed = s.unsigned_integer("seed", config.sim.seed);
    config.sim.thermal_step_s = s.number("thermal_step_s", config.sim.thermal_step_s, 1e-4, 10.0);
    if (s.get("initial_temp_c") != nullptr) config.sim.initial_temp_c = s.number("initial_temp_c", 0.0, -55.0, 125.0);
    hal::SimAds1251::Timing& a = config.sim.adc_timing;
    const auto us = [&](const char* key, double fallback_s, double min_s) {
      return s.number(key, fallback_s * 1e6, min_s * 1e6, 1e6) * 1e-6;
    };
    a.wake_min_s = us("adc_wake_min_us", a.wake_min_s, 0.0);
    a.wake_max_s = us("adc_wake_max_us", a.wake_max_s, a.wake_min_s);
    a.stall_probability = s.number("adc_stall_probability", a.stall_probability, 0.0, 1.0);
    a.stall_max_s = us("adc_stall_max_us", std::max(a.stall_max_s, a.wake_max_s), a.wake_max_s);
    a.irq_delay_max_s = us("adc_irq_delay_max_us", a.irq_delay_max_s, 0.0);
    a.stamp_delay_max_s = us("adc_stamp_delay_max_us", a.stamp_delay_max_s, 0.0);
    a.spi_start_max_s = us("adc_spi_start_max_us", a.spi_start_max_s, 0.0);
    a.spi_return_max_s = us("adc_spi_return_max_us", a.spi_return_max_s, 0.0);
  }
  return config;
}

hal::Board BoardInstance::board() { return linux_board ? linux_board->board() : sim_board->board(); }

model::PlantParams sim_plant_params(const BoardConfig& config) {
  model::PlantParams params;
  params.dac_vref_v = config.devices.tec_dac.vref_v;
  params.gain_a_per_v = config.devices.tec.gain_a_per_v;
  if (config.sim.initial_temp_c) params.initial_temp_c = *config.sim.initial_temp_c;
  return params;
}

hal::SimBoardOptions sim_board_options(const BoardConfig& config, SimTiming timing) {
  hal::SimBoardOptions options;
  options.realtime = timing == SimTiming::realtime;
  options.thermal_step_s = config.sim.thermal_step_s;
  options.adc = config.devices.adc;
  options.rate_dac = config.devices.rate_dac;
  options.tec_current_limit_a = config.devices.tec.current_limit_a;
  options.sensor = config.devices.casing_sensor.options;
  options.ambient_sensor = config.devices.ambient_sensor.has_value();
  options.opa548_sense = config.devices.opa548_es_sense.has_value();
  options.adc_timing = config.sim.adc_timing;
  return options;
}

BoardInstance make_board(const BoardConfig& config, SimTiming timing) {
  BoardInstance instance;
  if (config.hal == HalKind::sim) {
    instance.sim_board =
        std::make_unique<hal::SimBoard>(sim_plant_params(config), config.sim.seed, sim_board_options(config, timing));
    return instance;
  }
  hal::LinuxBoard::Opened opened = hal::LinuxBoard::open(config.devices);
  if (!opened.board) {
    std::string message = "cannot open the board:";
    for (const auto& f : opened.failures) message += " " + f.device + ": " + f.message + ";";
    message.pop_back();
    throw RuntimeFailure(message);
  }
  instance.linux_board = std::move(opened.board);
  return instance;
}

}  // namespace gyrotc::app
