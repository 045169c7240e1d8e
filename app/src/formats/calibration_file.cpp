#include "gyrotc/app/formats/calibration_file.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {

namespace {

constexpr std::string_view kFormat = "gyrotc-calibration";
constexpr std::int64_t kFileVersion = 1;
constexpr double kSeedScaleMvPerDps = 8.774;  // seed Table 2 note
// A die an hour behind its casing sensor is not a die: most likely a unit
// mistaken (ms for s).
constexpr double kMaxDieLagS = 3600.0;

// Reads typed keys of one table; every error names file, line and full key.
class Reader {
 public:
  Reader(const toml::table& table, std::string prefix, const std::string& file)
      : table_(table), prefix_(std::move(prefix)), file_(file) {}

  void only(std::initializer_list<std::string_view> allowed) const {
    for (auto&& [key, node] : table_) {
      if (std::find(allowed.begin(), allowed.end(), key.str()) == allowed.end()) {
        fail(&node, std::string(key.str()), "unknown key");
      }
    }
  }

  [[noreturn]] void fail(const toml::node* node, const std::string& key, const std::string& why) const {
    const auto line = node ? node->source().begin.line : table_.source().begin.line;
    std::string where = file_;
    if (line > 0) where += ":" + std::to_string(line);
    throw InputError(where + ": key '" + full(key) + "': " + why);
  }

  std::string full(const std::string& key) const { return prefix_.empty() ? key : prefix_ + "." + key; }

  const toml::node* get(const std::string& key) const { return table_.get(key); }

  const toml::node& required(const std::string& key) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr) fail(nullptr, key, "missing");
    return *node;
  }

  double number(const std::string& key) const {
    const toml::node& node = required(key);
    return as_number(node, key);
  }

  std::optional<double> optional_number(const std::string& key) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr) return std::nullopt;
    return as_number(*node, key);
  }

  std::int64_t integer(const std::string& key) const {
    const toml::node& node = required(key);
    const auto v = node.value_exact<std::int64_t>();
    if (!v) fail(&node, key, "expected an integer");
    return *v;
  }

  std::string text(const std::string& key) const {
    const toml::node& node = required(key);
    const auto v = node.value_exact<std::string>();
    if (!v) fail(&node, key, "expected a string");
    return *v;
  }

  std::vector<double> numbers(const std::string& key) const {
    const toml::node& node = required(key);
    const toml::array* array = node.as_array();
    if (array == nullptr) fail(&node, key, "expected an array of numbers");
    std::vector<double> out;
    for (std::size_t i = 0; i < array->size(); ++i) {
      const toml::node& item = *array->get(i);
      const auto v = item.value<double>();
      if (!item.is_number() || !v) fail(&item, key + "[" + std::to_string(i) + "]", "expected a number");
      if (!std::isfinite(*v)) fail(&item, key + "[" + std::to_string(i) + "]", "must be finite");
      out.push_back(*v);
    }
    return out;
  }

  const toml::table& table(const std::string& key) const {
    const toml::node& node = required(key);
    const toml::table* t = node.as_table();
    if (t == nullptr) fail(&node, key, "expected a table");
    return *t;
  }

  const toml::array& table_array(const std::string& key) const {
    const toml::node& node = required(key);
    const toml::array* a = node.as_array();
    if (a == nullptr || !a->is_array_of_tables() || a->empty()) {
      fail(&node, key, "expected one or more [[" + full(key) + "]] tables");
    }
    return *a;
  }

 private:
  double as_number(const toml::node& node, const std::string& key) const {
    const auto v = node.value<double>();  // integers convert
    if (!node.is_number() || !v) fail(&node, key, "expected a number");
    if (!std::isfinite(*v)) fail(&node, key, "must be finite");
    return *v;
  }

  const toml::table& table_;
  std::string prefix_;
  const std::string& file_;
};

fit::Polynomial read_polynomial(const Reader& r, double t_min_c, double t_max_c) {
  r.only({"center_c", "scale_c", "coefficients_mv"});
  fit::Polynomial p;
  p.center_c = r.number("center_c");
  p.scale_c = r.number("scale_c");
  if (!(p.scale_c > 0.0)) r.fail(r.get("scale_c"), "scale_c", "must be positive");
  p.coefficients_mv = r.numbers("coefficients_mv");
  if (p.coefficients_mv.empty()) r.fail(r.get("coefficients_mv"), "coefficients_mv", "must not be empty");
  p.t_min_c = t_min_c;
  p.t_max_c = t_max_c;
  return p;
}

// The model factories report inconsistencies by field name; put the file and
// the table in front.
template <typename F>
fit::BiasModel build(const std::string& file, const std::string& table, F&& make) {
  try {
    return make();
  } catch (const std::invalid_argument& e) {
    throw InputError(file + ": key '" + table + "': inconsistent model: " + e.what());
  }
}

std::string format_number(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);  // shortest round-trip form
  std::string s(buf, res.ptr);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";  // keep it a TOML float
  return s;
}

std::string format_numbers(const std::vector<double>& values) {
  std::string s = "[";
  for (std::size_t i = 0; i < values.size(); ++i) s += (i ? ", " : "") + format_number(values[i]);
  return s + "]";
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

// [bound]: the grid ascending, one bound per temperature, none negative.
CalibrationErrorBound read_bound(const Reader& r) {
  r.only({"confidence", "range_dps", "c", "dps", "how"});
  CalibrationErrorBound b;
  b.confidence = r.number("confidence");
  if (!(b.confidence > 0.0 && b.confidence < 1.0)) r.fail(r.get("confidence"), "confidence", "must be in (0, 1)");
  b.range_dps = r.number("range_dps");
  if (!(b.range_dps >= 0.0)) r.fail(r.get("range_dps"), "range_dps", "must be 0 or more deg/s");
  b.temp_c = r.numbers("c");
  b.dps = r.numbers("dps");
  if (b.temp_c.size() < 2) r.fail(r.get("c"), "c", "needs at least two temperatures");
  for (std::size_t i = 1; i < b.temp_c.size(); ++i) {
    if (!(b.temp_c[i] > b.temp_c[i - 1])) r.fail(r.get("c"), "c", "must be ascending");
  }
  if (b.dps.size() != b.temp_c.size()) {
    r.fail(r.get("dps"), "dps", "needs one value per temperature of c (" + std::to_string(b.temp_c.size()) + ")");
  }
  for (double v : b.dps) {
    if (!(v >= 0.0)) r.fail(r.get("dps"), "dps", "must be 0 or more deg/s");
  }
  if (r.get("how") != nullptr) b.how = r.text("how");
  return b;
}

}  // namespace

Calibration parse_calibration(std::string_view text, const std::string& name) {
  toml::table root;
  try {
    root = toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    throw InputError(name + ":" + std::to_string(e.source().begin.line) + ":" +
                     std::to_string(e.source().begin.column) + ": " + std::string(e.description()));
  }
  const Reader top(root, "", name);
  top.only({"format", "version", "kind", "range_c", "scale_mv_per_dps", "die_lag_s", "polynomial",
            "piecewise", "bp_network", "spline", "source", "bound"});
  if (top.text("format") != kFormat) {
    top.fail(top.get("format"), "format", "expected \"" + std::string(kFormat) + "\"");
  }
  if (top.integer("version") != kFileVersion) {
    top.fail(top.get("version"), "version", "unsupported version (this gyrotc reads version 1)");
  }
  const double scale = top.optional_number("scale_mv_per_dps").value_or(kSeedScaleMvPerDps);
  if (!(scale > 0.0)) top.fail(top.get("scale_mv_per_dps"), "scale_mv_per_dps", "must be positive");
  const double die_lag = top.optional_number("die_lag_s").value_or(0.0);
  if (!(die_lag >= 0.0 && die_lag <= kMaxDieLagS)) {
    top.fail(top.get("die_lag_s"), "die_lag_s", "must be 0..3600 s (the die's lag behind the casing sensor)");
  }
  const std::string kind = top.text("kind");
  if (kind != "polynomial" && kind != "piecewise" && kind != "bp_network" && kind != "spline" &&
      kind != "paper_reference") {
    top.fail(top.get("kind"), "kind",
             "expected \"polynomial\", \"piecewise\", \"spline\", \"bp_network\" or \"paper_reference\", got \"" +
                 kind + "\"");
  }
  std::optional<CalibrationErrorBound> bound;
  if (top.get("bound") != nullptr) bound = read_bound(Reader(top.table("bound"), "bound", name));
  if (kind == "paper_reference") return Calibration{fit::BiasModel::paper_reference(), scale, die_lag, bound};

  const std::vector<double> range = top.numbers("range_c");
  if (range.size() != 2 || !(range[0] < range[1])) {
    top.fail(top.get("range_c"), "range_c", "expected [t_min, t_max] with t_min < t_max");
  }
  if (kind == "polynomial") {
    const Reader r(top.table("polynomial"), "polynomial", name);
    fit::Polynomial p = read_polynomial(r, range[0], range[1]);
    return Calibration{build(name, "polynomial", [&] { return fit::BiasModel::polynomial(p); }), scale, die_lag, bound};
  }
  if (kind == "piecewise") {
    const Reader r(top.table("piecewise"), "piecewise", name);
    r.only({"breakpoints_c", "segment"});
    fit::Piecewise pw;
    pw.breakpoints_c = r.numbers("breakpoints_c");
    const toml::array& segments = r.table_array("segment");
    if (segments.size() != pw.breakpoints_c.size() + 1) {
      r.fail(r.get("segment"), "segment",
             std::to_string(segments.size()) + " segments need " + std::to_string(segments.size() - 1) +
                 " breakpoints, breakpoints_c has " + std::to_string(pw.breakpoints_c.size()));
    }
    double below = range[0];
    for (std::size_t i = 0; i < pw.breakpoints_c.size(); ++i) {
      if (!(pw.breakpoints_c[i] > below) || !(pw.breakpoints_c[i] < range[1])) {
        r.fail(r.get("breakpoints_c"), "breakpoints_c[" + std::to_string(i) + "]",
               "breakpoints must ascend strictly inside range_c");
      }
      below = pw.breakpoints_c[i];
    }
    for (std::size_t i = 0; i < segments.size(); ++i) {
      const Reader s(*segments.get(i)->as_table(), "piecewise.segment[" + std::to_string(i) + "]", name);
      const double lo = i == 0 ? range[0] : pw.breakpoints_c[i - 1];
      const double hi = i + 1 == segments.size() ? range[1] : pw.breakpoints_c[i];
      pw.segments.push_back(read_polynomial(s, lo, hi));
    }
    return Calibration{build(name, "piecewise", [&] { return fit::BiasModel::piecewise(pw); }), scale, die_lag, bound};
  }
  if (kind == "spline") {
    const Reader r(top.table("spline"), "spline", name);
    r.only({"knots_c", "values_mv", "second_derivatives"});
    fit::Spline sp;
    sp.knots_c = r.numbers("knots_c");
    sp.values_mv = r.numbers("values_mv");
    sp.second_derivatives = r.numbers("second_derivatives");
    sp.t_min_c = range[0];
    sp.t_max_c = range[1];
    if (sp.knots_c.size() < 2) r.fail(r.get("knots_c"), "knots_c", "need at least 2 knots");
    for (std::size_t i = 0; i < sp.knots_c.size(); ++i) {
      const bool ascending = i == 0 || sp.knots_c[i] > sp.knots_c[i - 1];
      if (!ascending || sp.knots_c[i] < range[0] || sp.knots_c[i] > range[1]) {
        r.fail(r.get("knots_c"), "knots_c[" + std::to_string(i) + "]", "knots must ascend strictly inside range_c");
      }
    }
    for (const char* key : {"values_mv", "second_derivatives"}) {
      if (r.numbers(key).size() != sp.knots_c.size()) {
        r.fail(r.get(key), key, "need one value per knot (" + std::to_string(sp.knots_c.size()) + "), got " +
                                    std::to_string(r.numbers(key).size()));
      }
    }
    return Calibration{build(name, "spline", [&] { return fit::BiasModel::spline(sp); }), scale, die_lag, bound};
  }
  {  // kind == "bp_network"
    const Reader r(top.table("bp_network"), "bp_network", name);
    r.only({"out_center_mv", "out_half_range_mv", "layer"});
    fit::BpNetwork net;
    net.t_min_c = range[0];
    net.t_max_c = range[1];
    net.out_center_mv = r.number("out_center_mv");
    net.out_half_range_mv = r.number("out_half_range_mv");
    const toml::array& layers = r.table_array("layer");
    for (std::size_t i = 0; i < layers.size(); ++i) {
      const Reader l(*layers.get(i)->as_table(), "bp_network.layer[" + std::to_string(i) + "]", name);
      l.only({"inputs", "outputs", "activation", "weights", "biases"});
      const bool last = i + 1 == layers.size();
      const std::string activation = l.text("activation");
      if (activation != (last ? "linear" : "tansig")) {
        l.fail(l.get("activation"), "activation",
               last ? "the output layer is \"linear\"" : "hidden layers are \"tansig\"");
      }
      fit::NetworkLayer layer;
      const std::int64_t inputs = l.integer("inputs");
      const std::int64_t outputs = l.integer("outputs");
      if (inputs < 1 || inputs > fit::BpNetwork::kMaxWidth) l.fail(l.get("inputs"), "inputs", "out of range");
      if (outputs < 1 || outputs > fit::BpNetwork::kMaxWidth) l.fail(l.get("outputs"), "outputs", "out of range");
      layer.inputs = static_cast<int>(inputs);
      layer.outputs = static_cast<int>(outputs);
      layer.weights = l.numbers("weights");
      layer.biases = l.numbers("biases");
      net.layers.push_back(std::move(layer));
    }
    return Calibration{build(name, "bp_network", [&] { return fit::BiasModel::bp_network(net); }), scale, die_lag, bound};
  }
}

Calibration read_calibration(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path + ": read error");
  return parse_calibration(text.str(), path);
}

fit::BiasModel load_calibration(const std::string& path) { return read_calibration(path).model; }

std::string format_calibration(const fit::BiasModel& model, double scale_mv_per_dps,
                               const CalibrationSource& source, double die_lag_s,
                               const std::optional<CalibrationErrorBound>& bound) {
  std::string s;
  s += "# gyrotc calibration: zero-rate output (mV) of the gyro against casing temperature.\n";
  s += "# Compensated rate = (gyro_mv - bias_mv(T)) / scale_mv_per_dps; outside range_c the\n";
  s += "# model is evaluated at the nearest end of the range and the sample is flagged.\n";
  s += "format = " + quoted(std::string(kFormat)) + "\n";
  s += "version = " + std::to_string(kFileVersion) + "\n";
  s += "kind = " + quoted(std::string(model.kind_name())) + "\n";
  s += "scale_mv_per_dps = " + format_number(scale_mv_per_dps) + "\n";
  if (model.kind() != fit::BiasModel::Kind::paper_reference) {
    s += "range_c = " + format_numbers({model.t_min_c(), model.t_max_c()}) + "\n";
  }
  if (die_lag_s > 0.0) {
    s += "# T is the die's temperature: the casing sensor through a first-order lag of die_lag_s\n";
    s += "die_lag_s = " + format_number(die_lag_s) + "\n";
  }
  if (!source.method.empty()) {
    s += "\n[source]\n";
    s += "data = " + quoted(source.data) + "\n";
    s += "method = " + quoted(source.method) + "\n";
    s += "structure = " + quoted(source.structure) + "\n";
    s += "points = " + std::to_string(source.points) + "\n";
    s += "in_sample_max_abs_dps = " + format_number(source.in_sample_max_abs_dps) + "\n";
    s += "in_sample_rms_dps = " + format_number(source.in_sample_rms_dps) + "\n";
    s += "loo_max_abs_dps = " + format_number(source.loo_max_abs_dps) + "\n";
    s += "loo_rms_dps = " + format_number(source.loo_rms_dps) + "\n";
    if (source.nested_loo_max_abs_dps && source.nested_loo_rms_dps) {
      s += "nested_loo_max_abs_dps = " + format_number(*source.nested_loo_max_abs_dps) + "\n";
      s += "nested_loo_rms_dps = " + format_number(*source.nested_loo_rms_dps) + "\n";
    }
    if (!source.accepted.empty()) {
      s += "# record checks overridden with `gyrotc fit --accept`\n";
      s += "accepted = [";
      for (std::size_t i = 0; i < source.accepted.size(); ++i) s += (i ? ", " : "") + quoted(source.accepted[i]);
      s += "]\n";
    }
  }
  if (bound) {
    s += "\n[bound]\n";
    s += "# the calibration's own bound on its error (deg/s), from the record's noise: with this\n";
    s += "# confidence the error stays within range_dps over c's whole range at once, and within\n";
    s += "# dps[i] at c[i]\n";
    s += "confidence = " + format_number(bound->confidence) + "\n";
    s += "range_dps = " + format_number(bound->range_dps) + "\n";
    s += "c = " + format_numbers(bound->temp_c) + "\n";
    s += "dps = " + format_numbers(bound->dps) + "\n";
    if (!bound->how.empty()) s += "how = " + quoted(bound->how) + "\n";
  }
  auto polynomial = [&](const fit::Polynomial& p) {
    s += "# bias_mv = sum of coefficients_mv[k] * x^k, x = (T - center_c) / scale_c\n";
    s += "center_c = " + format_number(p.center_c) + "\n";
    s += "scale_c = " + format_number(p.scale_c) + "\n";
    s += "coefficients_mv = " + format_numbers(p.coefficients_mv) + "\n";
  };
  if (model.kind() == fit::BiasModel::Kind::polynomial) {
    s += "\n[polynomial]\n";
    polynomial(*model.as_polynomial());
  } else if (model.kind() == fit::BiasModel::Kind::piecewise) {
    const fit::Piecewise& pw = *model.as_piecewise();
    s += "\n[piecewise]\n";
    s += "# segment i covers breakpoints_c[i-1] < T <= breakpoints_c[i]\n";
    s += "breakpoints_c = " + format_numbers(pw.breakpoints_c) + "\n";
    for (const fit::Polynomial& p : pw.segments) {
      s += "\n[[piecewise.segment]]\n";
      polynomial(p);
    }
  } else if (model.kind() == fit::BiasModel::Kind::spline) {
    const fit::Spline& sp = *model.as_spline();
    s += "\n[spline]\n";
    s += "# cubic spline: on [x_i, x_i+1], with h = x_i+1 - x_i, a = (x_i+1 - T) / h, b = 1 - a,\n";
    s += "# bias_mv = a y_i + b y_i+1 + ((a^3 - a) m_i + (b^3 - b) m_i+1) h^2 / 6\n";
    s += "# (x: knots_c, y: values_mv, m: second_derivatives in mV/C^2); beyond the end knots the\n";
    s += "# end intervals' cubics continue up to range_c\n";
    s += "knots_c = " + format_numbers(sp.knots_c) + "\n";
    s += "values_mv = " + format_numbers(sp.values_mv) + "\n";
    s += "second_derivatives = " + format_numbers(sp.second_derivatives) + "\n";
  } else if (model.kind() == fit::BiasModel::Kind::bp_network) {
    const fit::BpNetwork& net = *model.as_bp_network();
    s += "\n[bp_network]\n";
    s += "# x = 2 (T - range_c[0]) / (range_c[1] - range_c[0]) - 1; bias_mv = out_center_mv + out_half_range_mv * y\n";
    s += "out_center_mv = " + format_number(net.out_center_mv) + "\n";
    s += "out_half_range_mv = " + format_number(net.out_half_range_mv) + "\n";
    for (std::size_t i = 0; i < net.layers.size(); ++i) {
      const fit::NetworkLayer& layer = net.layers[i];
      s += "\n[[bp_network.layer]]\n";
      s += "inputs = " + std::to_string(layer.inputs) + "\n";
      s += "outputs = " + std::to_string(layer.outputs) + "\n";
      s += std::string("activation = ") + (i + 1 == net.layers.size() ? "\"linear\"" : "\"tansig\"") + "\n";
      s += "weights = " + format_numbers(layer.weights) + "  # row-major, outputs x inputs\n";
      s += "biases = " + format_numbers(layer.biases) + "\n";
    }
  }
  return s;
}

void save_calibration(const fit::BiasModel& model, const std::string& path, double scale_mv_per_dps,
                      const CalibrationSource& source, double die_lag_s,
                      const std::optional<CalibrationErrorBound>& bound) {
  const std::string text = format_calibration(model, scale_mv_per_dps, source, die_lag_s, bound);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw RuntimeFailure(path + ": cannot write: " + std::strerror(errno));
  out << text;
  out.close();
  if (!out) throw RuntimeFailure(path + ": write failed: " + std::strerror(errno));
}

}  // namespace gyrotc::app
