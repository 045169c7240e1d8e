#pragma once

#include <cmath>
#include <cstddef>
#include <string_view>
#include <variant>
#include <vector>

namespace gyrotc::fit {

// A polynomial in the centred and scaled temperature x = (T - center_c) / scale_c:
//   bias_mv = c[0] + c[1] x + ... + c[m] x^m
// valid on [t_min_c, t_max_c]. Centring and scaling keep the fit well
// conditioned; center 0 and scale 1 give the seed's raw-T form.
struct Polynomial {
  double center_c = 0.0;
  double scale_c = 1.0;
  std::vector<double> coefficients_mv;  // ascending powers of x
  double t_min_c = 0.0;
  double t_max_c = 0.0;

  int order() const noexcept { return static_cast<int>(coefficients_mv.size()) - 1; }
};

// Horner's rule at temp_c, no range clamping, no allocation.
double evaluate(const Polynomial& poly, double temp_c) noexcept;

// Segments joined at interior breakpoints. Segment i covers
// (breakpoints_c[i-1], breakpoints_c[i]]: a breakpoint belongs to the segment
// below it, as in the seed (-40 <= T <= -20, -20 < T <= 50, 50 < T <= 80).
struct Piecewise {
  std::vector<double> breakpoints_c;  // ascending, segments.size() - 1 of them
  std::vector<Polynomial> segments;
};

// A cubic spline: on each interval [x_i, x_{i+1}] of the knots, with
// h = x_{i+1} - x_i, a = (x_{i+1} - T) / h and b = 1 - a,
//   bias_mv = a y_i + b y_{i+1} + ((a^3 - a) m_i + (b^3 - b) m_{i+1}) h^2 / 6,
// the cubic with values y and second derivatives m at the interval's ends, so
// the curve and its first two derivatives are continuous at every knot. Both
// spline fits store this form: the interpolating one (not-a-knot ends) and the
// penalised smoothing one (natural ends, m = 0 at the end knots). Between a
// range end and the nearest knot (a leave-one-out fold without an end point)
// the end interval's cubic continues.
struct Spline {
  std::vector<double> knots_c;              // strictly ascending, at least 2
  std::vector<double> values_mv;            // y, one per knot
  std::vector<double> second_derivatives;   // m, mV/C^2, one per knot
  double t_min_c = 0.0;                     // <= knots_c.front()
  double t_max_c = 0.0;                     // >= knots_c.back()
};

// The spline at temp_c (no range clamping), no allocation: a binary search
// for the interval and one cubic.
double evaluate(const Spline& spline, double temp_c) noexcept;

// One layer of a BP network: out = f(W in + b), W row-major (outputs x inputs).
struct NetworkLayer {
  int inputs = 0;
  int outputs = 0;
  std::vector<double> weights;  // outputs * inputs
  std::vector<double> biases;   // outputs
};

// The seed's BP network (Section 4.1): one input (temperature), tansig hidden
// layers, one linear output. Input and output are normalised to [-1, 1] over
// the training range (MATLAB mapminmax):
//   x = 2 (T - t_min_c) / (t_max_c - t_min_c) - 1,   bias_mv = out_center_mv + out_half_range_mv * y.
struct BpNetwork {
  std::vector<NetworkLayer> layers;  // hidden layers (tanh) then the output layer (linear)
  double t_min_c = 0.0;
  double t_max_c = 0.0;
  double out_center_mv = 0.0;
  double out_half_range_mv = 1.0;

  // Widest hidden layer inference supports (it runs on a stack buffer).
  static constexpr int kMaxWidth = 64;
};

// The hidden layers' activation, MATLAB's tansig as the seed used it:
// 2 / (1 + exp(-2 n)) - 1. It equals tanh(n) to within 4e-16 and costs less
// than half of glibc's tanh, which dominated inference. Training and inference
// both use it, so a network evaluates exactly as it was trained.
inline double tansig(double n) noexcept { return 2.0 / (1.0 + std::exp(-2.0 * n)) - 1.0; }

// Evaluates the network at temp_c (no clamping), no allocation.
double evaluate(const BpNetwork& net, double temp_c) noexcept;

// Zero-bias temperature model: the gyro's zero-rate output (mV) as a function
// of the casing temperature. A value type holding one of the seed's three
// model kinds, a cubic spline, or the seed's own printed piecewise coefficients.
//
// Outside the calibrated range [t_min_c, t_max_c] the model is evaluated at the
// nearest end of the range (clamping): polynomials extrapolate badly, and the
// Compensator reports the clamp as a flag.
class BiasModel {
 public:
  enum class Kind { polynomial, piecewise, bp_network, paper_reference, spline };

  // Each factory validates its argument and throws std::invalid_argument
  // naming the offending field (e.g. "segments[1].coefficients_mv").
  static BiasModel polynomial(Polynomial poly);
  static BiasModel piecewise(Piecewise pw);
  static BiasModel bp_network(BpNetwork net);
  static BiasModel spline(Spline spline);
  // The seed's printed piecewise polynomial (Section 4.2, breakpoints -20 and
  // 50 C, orders 4/3/4), with the erratum of data/README.md (middle segment:
  // signs of a0 and a3 flipped). Reproduces Table 2 within 1.56 mV.
  static BiasModel paper_reference();

  Kind kind() const noexcept { return kind_; }
  // "polynomial", "piecewise", "bp_network", "paper_reference", "spline".
  std::string_view kind_name() const noexcept;

  // Zero-rate output (mV) at temp_c, clamped to the calibrated range. No allocation.
  double bias_mv(double temp_c) const noexcept;
  double t_min_c() const noexcept { return t_min_c_; }
  double t_max_c() const noexcept { return t_max_c_; }
  // Number of stored numbers that define the curve (coefficients, weights, biases).
  std::size_t parameter_count() const noexcept;

  // The held model (nullptr when another kind is held). paper_reference is a Piecewise.
  const Polynomial* as_polynomial() const noexcept { return std::get_if<Polynomial>(&model_); }
  const Piecewise* as_piecewise() const noexcept { return std::get_if<Piecewise>(&model_); }
  const BpNetwork* as_bp_network() const noexcept { return std::get_if<BpNetwork>(&model_); }
  const Spline* as_spline() const noexcept { return std::get_if<Spline>(&model_); }

 private:
  BiasModel(Kind kind, std::variant<Polynomial, Piecewise, BpNetwork, Spline> model, double t_min_c,
            double t_max_c);

  Kind kind_;
  std::variant<Polynomial, Piecewise, BpNetwork, Spline> model_;
  double t_min_c_;
  double t_max_c_;
};

}  // namespace gyrotc::fit
