#include "gyrotc/algorithms/fit/fit_method.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "gyrotc/algorithms/fit/polynomial_fit.hpp"

namespace gyrotc::fit {

namespace {

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string join(const std::vector<double>& values, const char* sep) {
  std::string s;
  for (std::size_t i = 0; i < values.size(); ++i) s += (i ? sep : "") + number(values[i]);
  return s;
}

std::string join(const std::vector<int>& values, const char* sep) {
  std::string s;
  for (std::size_t i = 0; i < values.size(); ++i) s += (i ? sep : "") + std::to_string(values[i]);
  return s;
}

std::string piecewise_structure(const PiecewiseSpec& spec) {
  std::string s = "orders " + join(spec.orders, "/");
  if (!spec.breakpoints_c.empty()) s += ", breakpoints " + join(spec.breakpoints_c, ", ") + " C";
  if (spec.continuous) s += ", continuous";
  return s;
}

double sum_squares(const std::vector<double>& r) {
  double s = 0.0;
  for (double x : r) s += x * x;
  return s;
}

// Order 0..max_order (at least order + 2 points) with the smallest LOO sum of squares.
int best_order(std::span<const double> t, std::span<const double> v, int max_order, double* loo_sse) {
  int best = -1;
  double best_sse = std::numeric_limits<double>::infinity();
  for (int o = 0; o <= max_order && static_cast<std::size_t>(o) + 2 <= t.size(); ++o) {
    const double sse = sum_squares(polynomial_loo_residuals(t, v, o));
    if (sse < best_sse) {
      best_sse = sse;
      best = o;
    }
  }
  if (loo_sse) *loo_sse = best_sse;
  return best;
}

// A fitted model with its structure, and how to refit that structure.
struct Prepared {
  BiasModel model;
  Method method;
  std::string structure;
  std::string choice;
  double condition_number;
  Fitter fitter;
};

// A structure the user gave needs order + 1 points per segment; a segment
// with exactly that many is interpolated, and its LOO folds (one point short)
// fit the highest order their points support.
void require_points(std::size_t have, int order, const std::string& what) {
  if (have < static_cast<std::size_t>(order) + 1) {
    throw std::invalid_argument(what + ": order " + std::to_string(order) + " needs at least " +
                                std::to_string(order + 1) + " points, got " + std::to_string(have));
  }
}

Prepared polynomial_of_order(std::span<const double> t, std::span<const double> v, int order, double lo,
                             double hi, std::string choice) {
  const PolynomialFit fit = fit_polynomial(t, v, order, lo, hi);
  Fitter fitter = [order](std::span<const double> ft, std::span<const double> fv, double flo, double fhi) {
    const int usable = std::min(order, static_cast<int>(ft.size()) - 1);
    return BiasModel::polynomial(fit_polynomial(ft, fv, usable, flo, fhi).poly);
  };
  return Prepared{BiasModel::polynomial(fit.poly), Method::polynomial, "order " + std::to_string(order),
                  std::move(choice), fit.condition_number, std::move(fitter)};
}

Prepared prepare_polynomial(std::span<const double> t, std::span<const double> v, const MethodOptions& o,
                            double lo, double hi) {
  if (o.orders.size() > 1) throw std::invalid_argument("poly: takes one order");
  if (o.orders.empty()) {
    const int order = best_order(t, v, o.max_poly_order, nullptr);
    if (order < 0) throw std::invalid_argument("poly: need at least 2 points");
    return polynomial_of_order(t, v, order, lo, hi,
                               "order " + std::to_string(order) + " of 0.." + std::to_string(o.max_poly_order) +
                                   " by leave-one-out");
  }
  const int order = o.orders[0];
  if (order < 0) throw std::invalid_argument("poly: order must be >= 0");
  require_points(t.size(), order, "poly");
  return polynomial_of_order(t, v, order, lo, hi, "");
}

Prepared piecewise_of_spec(std::span<const double> t, std::span<const double> v, const PiecewiseSpec& spec,
                           Method method, ShortSegment in_folds, double lo, double hi, std::string choice) {
  const PiecewiseFit fit = fit_piecewise(t, v, spec, ShortSegment::reject, lo, hi);
  Fitter fitter = [spec, in_folds](std::span<const double> ft, std::span<const double> fv, double flo, double fhi) {
    return BiasModel::piecewise(fit_piecewise(ft, fv, spec, in_folds, flo, fhi).pw);
  };
  return Prepared{BiasModel::piecewise(fit.pw), method, piecewise_structure(spec), std::move(choice),
                  fit.condition_number, std::move(fitter)};
}

// Points of each segment of a breakpoint list (same rule as fit_piecewise).
std::vector<std::pair<std::vector<double>, std::vector<double>>> segment_points(
    std::span<const double> t, std::span<const double> v, const std::vector<double>& breakpoints) {
  std::vector<std::pair<std::vector<double>, std::vector<double>>> out(breakpoints.size() + 1);
  for (std::size_t i = 0; i < t.size(); ++i) {
    std::size_t s = 0;
    while (s < breakpoints.size() && t[i] > breakpoints[s]) ++s;
    out[s].first.push_back(t[i]);
    out[s].second.push_back(v[i]);
  }
  return out;
}

Prepared prepare_piecewise(std::span<const double> t, std::span<const double> v, const MethodOptions& o,
                           double lo, double hi) {
  if (o.breakpoints_c.empty()) {
    if (!o.orders.empty()) {
      throw std::invalid_argument("piecewise: orders need breakpoints (give both, or neither to search)");
    }
    const PiecewiseChoice c = choose_piecewise(t, v, o.search);
    return piecewise_of_spec(t, v, c.spec, Method::piecewise, ShortSegment::reject, lo, hi,
                             "breakpoints and orders by leave-one-out (up to " +
                                 std::to_string(o.search.max_segments) + " segments, orders 0.." +
                                 std::to_string(o.search.max_order) + ")");
  }
  PiecewiseSpec spec;
  spec.breakpoints_c = o.breakpoints_c;
  spec.continuous = o.continuous;
  const std::size_t segments = o.breakpoints_c.size() + 1;
  if (!std::is_sorted(spec.breakpoints_c.begin(), spec.breakpoints_c.end()) ||
      std::adjacent_find(spec.breakpoints_c.begin(), spec.breakpoints_c.end()) != spec.breakpoints_c.end()) {
    throw std::invalid_argument("piecewise: breakpoints must be strictly ascending");
  }
  const auto parts = segment_points(t, v, spec.breakpoints_c);
  std::string choice;
  if (o.orders.empty()) {
    for (std::size_t s = 0; s < segments; ++s) {
      const int order = best_order(parts[s].first, parts[s].second, o.search.max_order, nullptr);
      if (order < 0) {
        throw std::invalid_argument("piecewise: segment " + std::to_string(s + 1) + " has " +
                                    std::to_string(parts[s].first.size()) + " points, needs at least 2");
      }
      spec.orders.push_back(order);
    }
    choice = "orders by leave-one-out per segment (0.." + std::to_string(o.search.max_order) + ")";
  } else if (o.orders.size() == 1) {
    spec.orders.assign(segments, o.orders[0]);
  } else if (o.orders.size() == segments) {
    spec.orders = o.orders;
  } else {
    throw std::invalid_argument("piecewise: " + std::to_string(o.orders.size()) + " orders for " +
                                std::to_string(segments) + " segments");
  }
  for (std::size_t s = 0; s < segments; ++s) {
    require_points(parts[s].first.size(), spec.orders[s], "piecewise segment " + std::to_string(s + 1));
  }
  return piecewise_of_spec(t, v, spec, Method::piecewise, ShortSegment::lower_order, lo, hi, choice);
}

Prepared prepare_bp(std::span<const double> t, std::span<const double> v, const MethodOptions& o, double lo,
                    double hi) {
  const BpTrainResult r = train_bp_network(t, v, o.bp, lo, hi);
  const BpTrainOptions bp = o.bp;
  Fitter fitter = [bp](std::span<const double> ft, std::span<const double> fv, double flo, double fhi) {
    return BiasModel::bp_network(train_bp_network(ft, fv, bp, flo, fhi).net);
  };
  std::string structure = "hidden " + join(bp.hidden, "x") + " tansig, linear output";
  std::string choice = "Levenberg-Marquardt, seed " + std::to_string(bp.seed) + ", best of " +
                       std::to_string(bp.restarts) + " trainings, " + std::to_string(r.epochs) +
                       " epochs, stopped by " + r.stop_reason;
  return Prepared{BiasModel::bp_network(r.net), Method::bp_network, std::move(structure), std::move(choice),
                  0.0, std::move(fitter)};
}

Prepared prepare_automatic(std::span<const double> t, std::span<const double> v, const MethodOptions& o,
                           double lo, double hi) {
  double poly_sse = 0.0;
  const int poly_order = best_order(t, v, o.max_poly_order, &poly_sse);
  if (poly_order < 0) throw std::invalid_argument("auto: need at least 2 points");
  const PiecewiseChoice pc = choose_piecewise(t, v, o.search);
  const double poly_rms = std::sqrt(poly_sse / static_cast<double>(t.size()));
  std::string compared = "polynomial order " + std::to_string(poly_order) + " (LOO RMS " + number(poly_rms) +
                         " mV) vs piecewise " + piecewise_structure(pc.spec) + " (LOO RMS " + number(pc.loo_rms) +
                         " mV)";
  if (pc.loo_rms < poly_rms) {
    return piecewise_of_spec(t, v, pc.spec, Method::piecewise, ShortSegment::reject, lo, hi,
                             "auto chose piecewise: " + compared);
  }
  return polynomial_of_order(t, v, poly_order, lo, hi, "auto chose polynomial: " + compared);
}

Prepared prepare(std::span<const double> t, std::span<const double> v, const MethodOptions& o, double lo,
                 double hi) {
  switch (o.method) {
    case Method::polynomial: return prepare_polynomial(t, v, o, lo, hi);
    case Method::piecewise: return prepare_piecewise(t, v, o, lo, hi);
    case Method::bp_network: return prepare_bp(t, v, o, lo, hi);
    case Method::paper:
      // The seed's first segment has 5 points for order 4: its LOO folds fit
      // the highest order their 4 points support.
      return piecewise_of_spec(t, v, paper_spec(), Method::paper, ShortSegment::lower_order, lo, hi,
                               "the seed's segmentation (Section 4.2)");
    case Method::automatic: return prepare_automatic(t, v, o, lo, hi);
  }
  throw std::invalid_argument("unknown method");
}

void check_data(std::span<const double> temp_c, std::span<const double> value) {
  if (temp_c.size() != value.size()) throw std::invalid_argument("temperature and value counts differ");
  if (temp_c.size() < 3) throw std::invalid_argument("need at least 3 points, got " + std::to_string(temp_c.size()));
}

}  // namespace

std::string_view method_name(Method m) {
  switch (m) {
    case Method::polynomial: return "poly";
    case Method::piecewise: return "piecewise";
    case Method::bp_network: return "bpnn";
    case Method::paper: return "paper";
    case Method::automatic: return "auto";
  }
  return "unknown";
}

std::optional<Method> parse_method(std::string_view name) {
  for (Method m : {Method::polynomial, Method::piecewise, Method::bp_network, Method::paper, Method::automatic}) {
    if (method_name(m) == name) return m;
  }
  return std::nullopt;
}

MethodFit fit_method(std::span<const double> temp_c, std::span<const double> value,
                     const MethodOptions& options) {
  check_data(temp_c, value);
  const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
  Prepared p = prepare(temp_c, value, options, *lo, *hi);
  const std::vector<double> in_sample = residuals(p.model, temp_c, value);
  const std::vector<double> loo = loo_residuals(temp_c, value, p.fitter);
  return MethodFit{std::move(p.model), p.method, std::move(p.structure), std::move(p.choice),
                   fit_errors(in_sample, loo), p.condition_number};
}

std::vector<double> nested_loo_residuals(std::span<const double> temp_c, std::span<const double> value,
                                         const MethodOptions& options) {
  check_data(temp_c, value);
  return loo_residuals(temp_c, value, [&options](std::span<const double> t, std::span<const double> v,
                                                 double lo, double hi) {
    return prepare(t, v, options, lo, hi).model;
  });
}

}  // namespace gyrotc::fit
