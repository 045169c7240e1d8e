#include "gyrotc/app/formats/plant_file.hpp"

#include <toml++/toml.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {
namespace {

using model::PlantParams;

struct Key {
  const char* section;
  const char* name;
  double PlantParams::*field;
};

// The file layout: [section] key -> PlantParams field.
const std::vector<Key>& keys() {
  static const std::vector<Key> k = {
      {"thermal", "shell_capacity_j_per_k", &PlantParams::shell_capacity_j_per_k},
      {"thermal", "casing_capacity_j_per_k", &PlantParams::casing_capacity_j_per_k},
      {"thermal", "die_capacity_j_per_k", &PlantParams::die_capacity_j_per_k},
      {"thermal", "shell_ambient_w_per_k", &PlantParams::shell_ambient_w_per_k},
      {"thermal", "shell_casing_leak_w_per_k", &PlantParams::shell_casing_leak_w_per_k},
      {"thermal", "casing_die_w_per_k", &PlantParams::casing_die_w_per_k},
      {"thermal", "internal_power_w", &PlantParams::internal_power_w},
      {"tec", "seebeck_v_per_k", &PlantParams::tec_seebeck_v_per_k},
      {"tec", "resistance_ohm", &PlantParams::tec_resistance_ohm},
      {"tec", "conductance_w_per_k", &PlantParams::tec_conductance_w_per_k},
      {"stage", "dac_vref_v", &PlantParams::dac_vref_v},
      {"stage", "gain_a_per_v", &PlantParams::gain_a_per_v},
      {"stage", "current_limit_a", &PlantParams::current_limit_a},
      {"stage", "supply_pos_v", &PlantParams::supply_pos_v},
      {"stage", "supply_neg_v", &PlantParams::supply_neg_v},
      {"stage", "rail_headroom_v", &PlantParams::rail_headroom_v},
      {"stage", "opa548_theta_ja_c_per_w", &PlantParams::opa548_theta_ja_c_per_w},
      {"stage", "opa548_thermal_tau_s", &PlantParams::opa548_thermal_tau_s},
      {"stage", "opa548_shutdown_c", &PlantParams::opa548_shutdown_c},
      {"stage", "opa548_restart_c", &PlantParams::opa548_restart_c},
      {"sensors", "ds18b20_offset_c", &PlantParams::ds18b20_offset_c},
      {"sensors", "adc_noise_uv", &PlantParams::adc_noise_uv},
      {"gyro", "scale_mv_per_dps", &PlantParams::scale_mv_per_dps},
      {"gyro", "arw_deg_per_sqrt_h", &PlantParams::arw_deg_per_sqrt_h},
      {"gyro", "bias_instability_dps", &PlantParams::bias_instability_dps},
      {"gyro", "bias_instability_tau_s", &PlantParams::bias_instability_tau_s},
      {"gyro", "zero_rate_offset_mv", &PlantParams::zero_rate_offset_mv},
      {"integration", "max_thermal_step_s", &PlantParams::max_thermal_step_s},
      {"integration", "initial_temp_c", &PlantParams::initial_temp_c},
  };
  return k;
}

std::string where(const std::string& file, const toml::node& node) {
  const auto& src = node.source();
  if (src.begin.line == 0) return file;
  return file + ":" + std::to_string(src.begin.line);
}

double number(const std::string& file, const std::string& key, const toml::node& node) {
  if (auto v = node.value<double>()) return *v;
  throw InputError(where(file, node) + ": key '" + key + "' must be a number");
}

void reject_unknown(const std::string& file, const std::string& prefix, const toml::table& table,
                    const std::vector<std::string>& known) {
  for (const auto& [k, node] : table) {
    const std::string key(k.str());
    bool found = false;
    for (const auto& name : known) found = found || name == key;
    if (!found) throw InputError(where(file, node) + ": unknown key '" + prefix + key + "'");
  }
}

const toml::table& as_table(const std::string& file, std::string_view key, const toml::node& node) {
  if (const toml::table* t = node.as_table()) return *t;
  throw InputError(where(file, node) + ": '" + std::string(key) + "' must be a table");
}

// Reads the parameters of one effect table into an effect struct.
template <typename Effect>
void read_effect(const std::string& file, const std::string& name, const toml::table& table,
                 std::optional<Effect>& slot,
                 const std::vector<std::pair<const char*, double Effect::*>>& fields) {
  Effect effect;
  std::vector<std::string> known;
  for (const auto& [key, member] : fields) {
    known.emplace_back(key);
    if (const toml::node* node = table.get(key)) {
      effect.*member = number(file, "effects." + name + "." + key, *node);
    }
  }
  reject_unknown(file, "effects." + name + ".", table, known);
  slot = effect;
}

std::vector<double> numbers(const std::string& file, const std::string& key, const toml::node& node) {
  const toml::array* array = node.as_array();
  if (array == nullptr) throw InputError(where(file, node) + ": key '" + key + "' must be a list of numbers");
  std::vector<double> v;
  for (const toml::node& item : *array) v.push_back(number(file, key, item));
  return v;
}

// [gyro] zero_bias_c = [...], zero_bias_mv = [...]: both or neither.
void read_zero_bias(const std::string& file, const toml::table& gyro, PlantParams& params) {
  const toml::node* t = gyro.get("zero_bias_c");
  const toml::node* v = gyro.get("zero_bias_mv");
  if (t == nullptr && v == nullptr) return;
  if (t == nullptr || v == nullptr) {
    throw InputError(where(file, t != nullptr ? *t : *v) +
                     ": keys 'gyro.zero_bias_c' and 'gyro.zero_bias_mv' come together (the curve's temperatures "
                     "and outputs)");
  }
  try {
    params.zero_bias = model::ZeroBiasCurve(numbers(file, "gyro.zero_bias_c", *t), numbers(file, "gyro.zero_bias_mv", *v));
  } catch (const std::invalid_argument& e) {
    throw InputError(where(file, *t) + ": keys 'gyro.zero_bias_c', 'gyro.zero_bias_mv': " + e.what());
  }
}

std::string text_of(const std::string& file, const std::string& key, const toml::node& node) {
  if (auto v = node.value<std::string>()) return *v;
  throw InputError(where(file, node) + ": key '" + key + "' must be a string");
}

// prefix by value: a reference parameter bound to a temporary string makes
// every reference to the result "possibly dangling" for GCC 13+.
const toml::node& required(const std::string& file, const toml::table& table, std::string_view prefix,
                           const char* key) {
  if (const toml::node* node = table.get(key)) return *node;
  throw InputError(where(file, table) + ": '" + std::string(prefix) + "' needs the key '" + key + "'");
}

// A node named in the file: its index, or an error naming the line.
int node_index(const std::string& file, const std::string& key, const toml::node& node,
               const model::ThermalNetwork& net) {
  const std::string name = text_of(file, key, node);
  const int index = net.index_of(name);
  if (index == -2) {
    throw InputError(where(file, node) + ": key '" + key + "' names node '" + name +
                     "', which [network.nodes] does not have");
  }
  return index;
}

// between = ["a", "b"]
std::pair<int, int> between(const std::string& file, const std::string& prefix, const toml::table& table,
                            const model::ThermalNetwork& net) {
  const toml::node& node = required(file, table, prefix, "between");
  const toml::array* pair = node.as_array();
  if (pair == nullptr || pair->size() != 2) {
    throw InputError(where(file, node) + ": key '" + prefix + ".between' must be two node names");
  }
  return {node_index(file, prefix + ".between", *pair->get(0), net),
          node_index(file, prefix + ".between", *pair->get(1), net)};
}

model::NetworkSensor read_sensor(const std::string& file, const std::string& prefix, const toml::table& table,
                                 const model::ThermalNetwork& net) {
  reject_unknown(file, prefix + ".", table, {"node", "tau_s", "offset_c", "noise_c"});
  model::NetworkSensor s;
  s.node = node_index(file, prefix + ".node", required(file, table, prefix, "node"), net);
  if (const toml::node* n = table.get("tau_s")) s.tau_s = number(file, prefix + ".tau_s", *n);
  if (const toml::node* n = table.get("offset_c")) s.offset_c = number(file, prefix + ".offset_c", *n);
  if (const toml::node* n = table.get("noise_c")) s.noise_c = number(file, prefix + ".noise_c", *n);
  return s;
}

// [network]: the user's own lumped network (model/thermal_network.hpp).
model::ThermalNetwork read_network(const std::string& file, const toml::table& table) {
  reject_unknown(file, "network.", table, {"nodes", "links", "tec", "heat_w", "sensors", "gyro"});
  model::ThermalNetwork net;
  const toml::table& nodes = as_table(file, "network.nodes", required(file, table, "network", "nodes"));
  for (const auto& [k, node] : nodes) {
    const std::string name(k.str());
    if (name == "ambient") {
      throw InputError(where(file, node) + ": 'ambient' is the chamber, not a node: leave it out of [network.nodes]");
    }
    net.nodes.push_back({name, number(file, "network.nodes." + name, node), 0.0});
  }
  if (const toml::node* links = table.get("links")) {
    const toml::array* list = links->as_array();
    if (list == nullptr || !list->is_array_of_tables()) {
      throw InputError(where(file, *links) + ": 'network.links' must be [[network.links]] tables");
    }
    for (const toml::node& item : *list) {
      const toml::table& link = *item.as_table();
      reject_unknown(file, "network.links.", link, {"between", "w_per_k"});
      const auto [a, b] = between(file, "network.links", link, net);
      const double g = number(file, "network.links.w_per_k", required(file, link, "network.links", "w_per_k"));
      net.links.push_back({a, b, g});
    }
  }
  const toml::table& tec = as_table(file, "network.tec", required(file, table, "network", "tec"));
  reject_unknown(file, "network.tec.", tec, {"between"});
  std::tie(net.tec_from, net.tec_to) = between(file, "network.tec", tec, net);
  if (const toml::node* heat = table.get("heat_w")) {
    for (const auto& [k, node] : as_table(file, "network.heat_w", *heat)) {
      const std::string key = "network.heat_w." + std::string(k.str());
      const int i = net.index_of(std::string(k.str()));
      if (i < 0) throw InputError(where(file, node) + ": key '" + key + "' is not a node of [network.nodes]");
      net.nodes[static_cast<std::size_t>(i)].heat_w = number(file, key, node);
    }
  }
  const toml::table& sensors = as_table(file, "network.sensors", required(file, table, "network", "sensors"));
  reject_unknown(file, "network.sensors.", sensors, {"casing", "ambient"});
  net.casing_sensor = read_sensor(file, "network.sensors.casing",
                                  as_table(file, "network.sensors.casing",
                                           required(file, sensors, "network.sensors", "casing")),
                                  net);
  if (const toml::node* ambient = sensors.get("ambient")) {
    net.ambient_sensor =
        read_sensor(file, "network.sensors.ambient", as_table(file, "network.sensors.ambient", *ambient), net);
  }
  const toml::table& gyro = as_table(file, "network.gyro", required(file, table, "network", "gyro"));
  reject_unknown(file, "network.gyro.", gyro, {"node"});
  net.gyro_node = node_index(file, "network.gyro.node", required(file, gyro, "network.gyro", "node"), net);
  try {
    model::validate(net);
  } catch (const std::invalid_argument& e) {
    // Point at the node the complaint names, else at [network].
    std::string at = where(file, table);
    for (const auto& [k, node] : nodes) {
      if (std::string(e.what()).find("'" + std::string(k.str()) + "'") != std::string::npos) at = where(file, node);
    }
    throw InputError(at + ": " + e.what());
  }
  return net;
}

template <typename Num>
std::string format_network(const model::ThermalNetwork& net, const Num& num) {
  auto quoted = [&](int node) {
    std::string text = "\"";
    text += net.name_of(node);
    text += '"';
    return text;
  };
  auto pair = [&](int a, int b) { return "between = [" + quoted(a) + ", " + quoted(b) + "]\n"; };
  std::string out = "\n[network.nodes]\n";
  for (const auto& node : net.nodes) out += "\"" + node.name + "\" = " + num(node.capacity_j_per_k) + "\n";
  for (const auto& link : net.links) out += "\n[[network.links]]\n" + pair(link.a, link.b) + "w_per_k = " + num(link.w_per_k) + "\n";
  out += "\n[network.tec]\n" + pair(net.tec_from, net.tec_to);
  out += "\n[network.heat_w]\n";
  for (const auto& node : net.nodes) {
    if (node.heat_w != 0.0) out += "\"" + node.name + "\" = " + num(node.heat_w) + "\n";
  }
  auto sensor = [&](const char* which, const model::NetworkSensor& s) {
    return std::string("\n[network.sensors.") + which + "]\nnode = " + quoted(s.node) + "\ntau_s = " + num(s.tau_s) +
           "\noffset_c = " + num(s.offset_c) + "\nnoise_c = " + num(s.noise_c) + "\n";
  };
  out += sensor("casing", net.casing_sensor);
  out += sensor("ambient", net.ambient_sensor);
  out += "\n[network.gyro]\nnode = " + quoted(net.gyro_node) + "\n";
  return out;
}

}  // namespace

model::PlantParams parse_plant(std::string_view text, const std::string& name) {
  toml::table root;
  try {
    root = toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    throw InputError(name + ":" + std::to_string(e.source().begin.line) + ": " +
                     std::string(e.description()));
  }
  PlantParams params;
  std::vector<std::string> top = {"format", "version", "effects", "network"};
  for (const auto& key : keys()) {
    bool seen = false;
    for (const auto& t : top) seen = seen || t == key.section;
    if (!seen) top.emplace_back(key.section);
  }
  reject_unknown(name, "", root, top);
  if (const toml::node* f = root.get("format")) {
    if (f->value<std::string>() != std::string("gyrotc-plant"))
      throw InputError(where(name, *f) + ": key 'format' must be \"gyrotc-plant\"");
  }
  std::int64_t version = 1;
  if (const toml::node* v = root.get("version")) {
    version = v->value<std::int64_t>().value_or(0);
    if (version != 1 && version != 2)
      throw InputError(where(name, *v) + ": key 'version' must be 1 or 2 (2 for a [network] plant)");
  }
  const toml::node* network_node = root.get("network");
  if (network_node != nullptr) {
    if (version != 2) {
      throw InputError(where(name, *network_node) + ": a [network] plant needs 'version = 2' at the top of the file");
    }
    if (const toml::node* thermal = root.get("thermal")) {
      throw InputError(where(name, *thermal) +
                       ": [thermal] sets the default three-node network; a [network] plant gives its own nodes and "
                       "links instead");
    }
    if (const toml::table* sensors = root["sensors"].as_table(); sensors && sensors->contains("ds18b20_offset_c")) {
      throw InputError(where(name, *sensors->get("ds18b20_offset_c")) +
                       ": key 'sensors.ds18b20_offset_c' is for the default network; a [network] plant sets "
                       "'network.sensors.casing.offset_c'");
    }
    params.network = read_network(name, as_table(name, "network", *network_node));
  }
  for (const auto& [section_key, section_node] : root) {
    const std::string section(section_key.str());
    if (section == "format" || section == "version" || section == "effects" || section == "network") continue;
    const toml::table& table = as_table(name, section, section_node);
    std::vector<std::string> known;
    for (const auto& key : keys()) {
      if (section != key.section) continue;
      known.emplace_back(key.name);
      if (const toml::node* node = table.get(key.name)) {
        params.*(key.field) = number(name, section + "." + key.name, *node);
      }
    }
    if (section == "gyro") {
      known.emplace_back("zero_bias_c");
      known.emplace_back("zero_bias_mv");
      read_zero_bias(name, table, params);
    }
    if (section == "stage") {
      known.emplace_back("dac_bits");
      if (const toml::node* node = table.get("dac_bits")) {
        auto bits = node->value<std::int64_t>();
        if (!bits) throw InputError(where(name, *node) + ": key 'stage.dac_bits' must be an integer");
        params.dac_bits = static_cast<int>(*bits);
      }
    }
    reject_unknown(name, section + ".", table, known);
  }
  if (const toml::node* effects_node = root.get("effects")) {
    const toml::table& effects = as_table(name, "effects", *effects_node);
    auto& e = params.effects;
    for (const auto& [k, node] : effects) {
      const std::string effect(k.str());
      const toml::table& t = as_table(name, "effects." + effect, node);
      using namespace model;
      if (effect == "thermal_lag") {
        read_effect<ThermalLagEffect>(name, effect, t, e.thermal_lag, {{"tau_s", &ThermalLagEffect::tau_s}});
      } else if (effect == "rate_sensitivity") {
        read_effect<RateSensitivityEffect>(name, effect, t, e.rate_sensitivity,
                                           {{"k_mv_per_c_per_s", &RateSensitivityEffect::k_mv_per_c_per_s}});
      } else if (effect == "ramp_hysteresis") {
        read_effect<RampHysteresisEffect>(
            name, effect, t, e.ramp_hysteresis,
            {{"h_mv", &RampHysteresisEffect::h_mv}, {"r0_c_per_s", &RampHysteresisEffect::r0_c_per_s}});
      } else if (effect == "warm_up") {
        read_effect<WarmUpEffect>(name, effect, t, e.warm_up,
                                  {{"a_mv", &WarmUpEffect::a_mv}, {"tau_s", &WarmUpEffect::tau_s}});
      } else if (effect == "linear_drift") {
        read_effect<LinearDriftEffect>(name, effect, t, e.linear_drift,
                                       {{"d_mv_per_h", &LinearDriftEffect::d_mv_per_h}});
      } else if (effect == "ambient_sensitivity") {
        read_effect<AmbientSensitivityEffect>(
            name, effect, t, e.ambient_sensitivity,
            {{"k_mv_per_c", &AmbientSensitivityEffect::k_mv_per_c}, {"ref_c", &AmbientSensitivityEffect::ref_c}});
      } else if (effect == "tec_joule_heating") {
        read_effect<TecJouleHeatingEffect>(name, effect, t, e.tec_joule_heating,
                                           {{"r_ohm", &TecJouleHeatingEffect::r_ohm}});
      } else {
        throw InputError(where(name, node) + ": unknown effect 'effects." + effect + "'");
      }
    }
  }
  try {
    model::validate(params);
  } catch (const std::invalid_argument& e) {
    // Name the file's key for the parameter the model complains about.
    std::string message = e.what();
    for (const auto& key : keys()) {
      const std::string section = key.section;
      const std::string field = (section == "tec" ? "tec_" : "") + std::string(key.name);
      if (message.find(" " + field + " ") != std::string::npos) {
        message += " (key '" + section + "." + key.name + "')";
        break;
      }
    }
    throw InputError(name + ": " + message);
  }
  return params;
}

model::PlantParams load_plant(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the plant file");
  std::stringstream text;
  text << in.rdbuf();
  return parse_plant(text.str(), path);
}

std::string format_plant(const model::PlantParams& params) {
  auto num = [](double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    std::string s(buf);
    if (s.find_first_of(".eE") == std::string::npos && s.find("inf") == std::string::npos &&
        s.find("nan") == std::string::npos)
      s += ".0";
    return s;
  };
  std::string out = "# gyrotc plant description (see app/include/gyrotc/app/formats/plant_file.hpp)\n";
  out += std::string("format = \"gyrotc-plant\"\nversion = ") + (params.network ? "2" : "1") + "\n";
  std::string section;
  for (const auto& key : keys()) {
    // A network plant's own tables replace the default network's keys.
    if (params.network && (std::string(key.section) == "thermal" || key.field == &PlantParams::ds18b20_offset_c))
      continue;
    if (section != key.section) {
      section = key.section;
      out += "\n[" + section + "]\n";
      if (section == "stage") out += "dac_bits = " + std::to_string(params.dac_bits) + "\n";
    }
    out += std::string(key.name) + " = " + num(params.*(key.field)) + "\n";
    if (key.field == &PlantParams::zero_rate_offset_mv && !(params.zero_bias == model::ZeroBiasCurve())) {
      auto list = [&](const std::vector<double>& v) {
        std::string text = "[";
        for (std::size_t i = 0; i < v.size(); ++i) text += (i ? ", " : "") + num(v[i]);
        return text + "]";
      };
      out += "zero_bias_c = " + list(params.zero_bias.temp_c()) + "\n";
      out += "zero_bias_mv = " + list(params.zero_bias.gyro_mv()) + "\n";
    }
  }
  if (params.network) out += format_network(*params.network, num);
  const auto& e = params.effects;
  if (e.thermal_lag) out += "\n[effects.thermal_lag]\ntau_s = " + num(e.thermal_lag->tau_s) + "\n";
  if (e.rate_sensitivity)
    out += "\n[effects.rate_sensitivity]\nk_mv_per_c_per_s = " + num(e.rate_sensitivity->k_mv_per_c_per_s) + "\n";
  if (e.ramp_hysteresis)
    out += "\n[effects.ramp_hysteresis]\nh_mv = " + num(e.ramp_hysteresis->h_mv) +
           "\nr0_c_per_s = " + num(e.ramp_hysteresis->r0_c_per_s) + "\n";
  if (e.warm_up)
    out += "\n[effects.warm_up]\na_mv = " + num(e.warm_up->a_mv) + "\ntau_s = " + num(e.warm_up->tau_s) + "\n";
  if (e.linear_drift) out += "\n[effects.linear_drift]\nd_mv_per_h = " + num(e.linear_drift->d_mv_per_h) + "\n";
  if (e.ambient_sensitivity)
    out += "\n[effects.ambient_sensitivity]\nk_mv_per_c = " + num(e.ambient_sensitivity->k_mv_per_c) +
           "\nref_c = " + num(e.ambient_sensitivity->ref_c) + "\n";
  if (e.tec_joule_heating)
    out += "\n[effects.tec_joule_heating]\nr_ohm = " + num(e.tec_joule_heating->r_ohm) + "\n";
  return out;
}

void save_plant(const model::PlantParams& params, const std::string& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw RuntimeFailure(path + ": cannot write the plant file");
  out << format_plant(params);
  if (!out) throw RuntimeFailure(path + ": cannot write the plant file");
}

}  // namespace gyrotc::app
