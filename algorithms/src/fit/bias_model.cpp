#include "gyrotc/algorithms/fit/bias_model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace gyrotc::fit {

namespace {

[[noreturn]] void invalid(const std::string& field, const std::string& why) {
  throw std::invalid_argument(field + ": " + why);
}

void check_finite(const std::vector<double>& values, const std::string& field) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) invalid(field + "[" + std::to_string(i) + "]", "not a finite number");
  }
}

void check_range(double t_min_c, double t_max_c, const std::string& prefix) {
  if (!std::isfinite(t_min_c) || !std::isfinite(t_max_c) || !(t_min_c < t_max_c)) {
    invalid(prefix + "t_min_c/t_max_c", "need finite t_min_c < t_max_c");
  }
}

void check_polynomial(const Polynomial& p, const std::string& prefix) {
  if (p.coefficients_mv.empty()) invalid(prefix + "coefficients_mv", "empty");
  check_finite(p.coefficients_mv, prefix + "coefficients_mv");
  if (!std::isfinite(p.center_c)) invalid(prefix + "center_c", "not a finite number");
  if (!std::isfinite(p.scale_c) || !(p.scale_c > 0.0)) invalid(prefix + "scale_c", "must be positive");
  check_range(p.t_min_c, p.t_max_c, prefix);
}

void check_piecewise(const Piecewise& pw) {
  if (pw.segments.empty()) invalid("segments", "empty");
  if (pw.breakpoints_c.size() + 1 != pw.segments.size()) {
    invalid("breakpoints_c", "need one breakpoint fewer than segments (" +
                                 std::to_string(pw.segments.size()) + " segments, " +
                                 std::to_string(pw.breakpoints_c.size()) + " breakpoints)");
  }
  check_finite(pw.breakpoints_c, "breakpoints_c");
  for (std::size_t i = 0; i < pw.segments.size(); ++i) {
    const std::string prefix = "segments[" + std::to_string(i) + "].";
    check_polynomial(pw.segments[i], prefix);
    if (i > 0 && pw.segments[i].t_min_c != pw.breakpoints_c[i - 1]) {
      invalid(prefix + "t_min_c", "must equal breakpoints_c[" + std::to_string(i - 1) + "]");
    }
    if (i + 1 < pw.segments.size() && pw.segments[i].t_max_c != pw.breakpoints_c[i]) {
      invalid(prefix + "t_max_c", "must equal breakpoints_c[" + std::to_string(i) + "]");
    }
  }
}

void check_network(const BpNetwork& net) {
  if (net.layers.size() < 2) invalid("layers", "need at least one hidden layer and the output layer");
  check_range(net.t_min_c, net.t_max_c, "");
  if (!std::isfinite(net.out_center_mv)) invalid("out_center_mv", "not a finite number");
  if (!std::isfinite(net.out_half_range_mv) || !(net.out_half_range_mv > 0.0)) {
    invalid("out_half_range_mv", "must be positive");
  }
  int previous = 1;  // one input: temperature
  for (std::size_t i = 0; i < net.layers.size(); ++i) {
    const NetworkLayer& layer = net.layers[i];
    const std::string prefix = "layers[" + std::to_string(i) + "].";
    const bool last = i + 1 == net.layers.size();
    if (layer.inputs != previous) {
      invalid(prefix + "inputs", "must be " + std::to_string(previous) + " (outputs of the layer before)");
    }
    if (layer.outputs < 1 || layer.outputs > BpNetwork::kMaxWidth || (last && layer.outputs != 1)) {
      invalid(prefix + "outputs", last ? "the output layer has one output"
                                       : "must be 1.." + std::to_string(BpNetwork::kMaxWidth));
    }
    const auto expected = static_cast<std::size_t>(layer.inputs) * static_cast<std::size_t>(layer.outputs);
    if (layer.weights.size() != expected) {
      invalid(prefix + "weights", "need " + std::to_string(expected) + " values, got " +
                                      std::to_string(layer.weights.size()));
    }
    if (layer.biases.size() != static_cast<std::size_t>(layer.outputs)) {
      invalid(prefix + "biases", "need " + std::to_string(layer.outputs) + " values, got " +
                                     std::to_string(layer.biases.size()));
    }
    check_finite(layer.weights, prefix + "weights");
    check_finite(layer.biases, prefix + "biases");
    previous = layer.outputs;
  }
}

void check_spline(const Spline& sp) {
  const std::size_t n = sp.knots_c.size();
  if (n < 2) invalid("knots_c", "need at least 2 knots");
  if (sp.values_mv.size() != n) {
    invalid("values_mv", "need one value per knot (" + std::to_string(n) + "), got " + std::to_string(sp.values_mv.size()));
  }
  if (sp.second_derivatives.size() != n) {
    invalid("second_derivatives", "need one per knot (" + std::to_string(n) + "), got " +
                                      std::to_string(sp.second_derivatives.size()));
  }
  check_finite(sp.knots_c, "knots_c");
  check_finite(sp.values_mv, "values_mv");
  check_finite(sp.second_derivatives, "second_derivatives");
  for (std::size_t i = 1; i < n; ++i) {
    if (!(sp.knots_c[i] > sp.knots_c[i - 1])) invalid("knots_c[" + std::to_string(i) + "]", "knots must ascend strictly");
  }
  check_range(sp.t_min_c, sp.t_max_c, "");
  if (sp.t_min_c > sp.knots_c.front() || sp.t_max_c < sp.knots_c.back()) {
    invalid("t_min_c/t_max_c", "the range must contain every knot");
  }
}

}  // namespace

double evaluate(const Spline& spline, double temp_c) noexcept {
  const std::vector<double>& x = spline.knots_c;
  // Interval i with x[i] <= T < x[i+1]; the end intervals continue outside the knots.
  const auto above = std::upper_bound(x.begin() + 1, x.end() - 1, temp_c);
  const auto i = static_cast<std::size_t>(above - x.begin()) - 1;
  const double h = x[i + 1] - x[i];
  const double a = (x[i + 1] - temp_c) / h;
  const double b = 1.0 - a;
  const double* y = spline.values_mv.data() + i;
  const double* m = spline.second_derivatives.data() + i;
  return a * y[0] + b * y[1] + ((a * a * a - a) * m[0] + (b * b * b - b) * m[1]) * (h * h / 6.0);
}

double evaluate(const Polynomial& poly, double temp_c) noexcept {
  const double x = (temp_c - poly.center_c) / poly.scale_c;
  double acc = 0.0;
  for (auto it = poly.coefficients_mv.rbegin(); it != poly.coefficients_mv.rend(); ++it) {
    acc = acc * x + *it;
  }
  return acc;
}

double evaluate(const BpNetwork& net, double temp_c) noexcept {
  std::array<double, BpNetwork::kMaxWidth> a{};
  std::array<double, BpNetwork::kMaxWidth> b{};
  a[0] = 2.0 * (temp_c - net.t_min_c) / (net.t_max_c - net.t_min_c) - 1.0;
  double* in = a.data();
  double* out = b.data();
  const std::size_t last = net.layers.size() - 1;
  for (std::size_t l = 0; l < net.layers.size(); ++l) {
    const NetworkLayer& layer = net.layers[l];
    const double* w = layer.weights.data();
    for (int o = 0; o < layer.outputs; ++o) out[o] = layer.biases[static_cast<std::size_t>(o)];
    // Input-major: the outputs' sums are independent chains the CPU overlaps
    // (output-major, each sum waits on its previous add). Each output still
    // adds its terms in input order, so the result is the same to the bit.
    for (int i = 0; i < layer.inputs; ++i) {
      const double x = in[i];
      for (int o = 0; o < layer.outputs; ++o) out[o] += w[o * layer.inputs + i] * x;
    }
    if (l != last) {
      for (int o = 0; o < layer.outputs; ++o) out[o] = tansig(out[o]);
    }
    std::swap(in, out);
  }
  return net.out_center_mv + net.out_half_range_mv * in[0];
}

BiasModel::BiasModel(Kind kind, std::variant<Polynomial, Piecewise, BpNetwork, Spline> model,
                     double t_min_c, double t_max_c)
    : kind_(kind), model_(std::move(model)), t_min_c_(t_min_c), t_max_c_(t_max_c) {}

BiasModel BiasModel::polynomial(Polynomial poly) {
  check_polynomial(poly, "");
  const double lo = poly.t_min_c;
  const double hi = poly.t_max_c;
  return BiasModel(Kind::polynomial, std::move(poly), lo, hi);
}

BiasModel BiasModel::piecewise(Piecewise pw) {
  check_piecewise(pw);
  const double lo = pw.segments.front().t_min_c;
  const double hi = pw.segments.back().t_max_c;
  return BiasModel(Kind::piecewise, std::move(pw), lo, hi);
}

BiasModel BiasModel::bp_network(BpNetwork net) {
  check_network(net);
  const double lo = net.t_min_c;
  const double hi = net.t_max_c;
  return BiasModel(Kind::bp_network, std::move(net), lo, hi);
}

BiasModel BiasModel::spline(Spline spline) {
  check_spline(spline);
  const double lo = spline.t_min_c;
  const double hi = spline.t_max_c;
  return BiasModel(Kind::spline, std::move(spline), lo, hi);
}

BiasModel BiasModel::paper_reference() {
  // Seed Section 4.2, the three printed segments in raw T (C), V_bias in mV.
  Piecewise pw;
  pw.breakpoints_c = {-20.0, 50.0};
  // -40 <= T <= -20
  pw.segments.push_back({0.0, 1.0, {-10.3, -19.2567, -1.139, -0.02933, -0.00028}, -40.0, -20.0});
  // -20 < T <= 50; printed a0 = -101.6788 and a3 = -0.000089526, signs flipped
  // per the erratum in data/README.md.
  pw.segments.push_back({0.0, 1.0, {101.6788, -0.64109, -0.01231, 0.000089526}, -20.0, 50.0});
  // 50 < T <= 80
  pw.segments.push_back({0.0, 1.0, {2370.0786, -146.13135, 3.413, -0.03502, 0.0001333}, 50.0, 80.0});
  check_piecewise(pw);
  return BiasModel(Kind::paper_reference, std::move(pw), -40.0, 80.0);
}

std::string_view BiasModel::kind_name() const noexcept {
  switch (kind_) {
    case Kind::polynomial: return "polynomial";
    case Kind::piecewise: return "piecewise";
    case Kind::bp_network: return "bp_network";
    case Kind::paper_reference: return "paper_reference";
    case Kind::spline: return "spline";
  }
  return "unknown";
}

double BiasModel::bias_mv(double temp_c) const noexcept {
  const double t = std::clamp(temp_c, t_min_c_, t_max_c_);
  if (const auto* poly = std::get_if<Polynomial>(&model_)) return evaluate(*poly, t);
  if (const auto* pw = std::get_if<Piecewise>(&model_)) {
    std::size_t i = 0;
    while (i < pw->breakpoints_c.size() && t > pw->breakpoints_c[i]) ++i;
    return evaluate(pw->segments[i], t);
  }
  if (const auto* sp = std::get_if<Spline>(&model_)) return evaluate(*sp, t);
  return evaluate(std::get<BpNetwork>(model_), t);
}

std::size_t BiasModel::parameter_count() const noexcept {
  if (const auto* poly = std::get_if<Polynomial>(&model_)) return poly->coefficients_mv.size();
  if (const auto* pw = std::get_if<Piecewise>(&model_)) {
    std::size_t n = pw->breakpoints_c.size();
    for (const auto& s : pw->segments) n += s.coefficients_mv.size();
    return n;
  }
  if (const auto* sp = std::get_if<Spline>(&model_)) return 3 * sp->knots_c.size();
  std::size_t n = 0;
  for (const auto& layer : std::get<BpNetwork>(model_).layers) n += layer.weights.size() + layer.biases.size();
  return n;
}

}  // namespace gyrotc::fit
