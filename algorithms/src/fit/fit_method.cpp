#include "gyrotc/algorithms/fit/fit_method.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <utility>

#include "gyrotc/algorithms/fit/polynomial_fit.hpp"
#include "gyrotc/algorithms/stats/summary.hpp"

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

const char* continuity_name(Continuity c) {
  switch (c) {
    case Continuity::none: return "independent";
    case Continuity::value: return "value-continuous";
    case Continuity::slope: return "slope-continuous";
  }
  return "";
}

std::string piecewise_structure(const PiecewiseSpec& spec) {
  std::string s = "orders " + join(spec.orders, "/");
  if (!spec.breakpoints_c.empty()) {
    s += ", breakpoints " + join(spec.breakpoints_c, ", ") + " C, " + continuity_name(spec.continuity);
  }
  return s;
}

// A fitted model with its structure, and how to refit that structure.
struct Prepared {
  BiasModel model;
  Method method;
  std::string structure;
  std::string choice;
  double condition_number;
  double dof;
  Fitter fitter;
  std::vector<Candidate> candidates;
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

Candidate candidate(std::string name, double dof, const std::vector<double>& loo) {
  Candidate c;
  c.name = std::move(name);
  c.score = cv_score(dof, loo);
  c.loo_max_abs = stats::max_abs(loo);
  return c;
}

// Marks the candidates within one standard error and the chosen one.
std::size_t choose(std::vector<Candidate>& candidates) {
  std::vector<CvScore> scores;
  for (const Candidate& c : candidates) scores.push_back(c.score);
  const std::size_t chosen = one_standard_error_choice(scores);
  std::size_t best = 0;
  for (std::size_t i = 1; i < scores.size(); ++i) {
    if (scores[i].mse < scores[best].mse) best = i;
  }
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    candidates[i].within_one_se = scores[i].mse <= scores[best].mse + scores[best].se;
    candidates[i].chosen = i == chosen;
  }
  return chosen;
}

const char* kOneSeRule = "the fewest effective parameters within one standard error of the best held-out mean square";

// How the candidates' held-out residuals were formed.
std::string held_out_name(double block_c) {
  if (block_c == 0.0) return "leave-one-out";
  return "leave-block-out (each point held out with every point within " + number(block_c) + " C of it)";
}

Prepared polynomial_of_order(std::span<const double> t, std::span<const double> v, int order, double lo,
                             double hi, std::string choice) {
  const PolynomialFit fit = fit_polynomial(t, v, order, lo, hi);
  Fitter fitter = [order](std::span<const double> ft, std::span<const double> fv, double flo, double fhi) {
    const int usable = std::min(order, static_cast<int>(ft.size()) - 1);
    return BiasModel::polynomial(fit_polynomial(ft, fv, usable, flo, fhi).poly);
  };
  return Prepared{BiasModel::polynomial(fit.poly), Method::polynomial, "order " + std::to_string(order),
                  std::move(choice), fit.condition_number, static_cast<double>(order + 1), std::move(fitter), {}};
}

// Orders 0 .. the supported order, each with its closed-form LOO.
std::vector<Candidate> polynomial_candidates(std::span<const double> t, std::span<const double> v, int max_order,
                                             double block_c = 0.0) {
  std::vector<Candidate> out;
  const int top = supported_polynomial_order(t.size(), max_order);
  for (int o = 0; o <= top; ++o) {
    out.push_back(candidate("poly " + std::to_string(o), o + 1.0, polynomial_loo_residuals(t, v, o, block_c)));
  }
  return out;
}

int order_of(const Candidate& c) { return std::stoi(c.name.substr(c.name.find(' ') + 1)); }

Prepared prepare_polynomial(std::span<const double> t, std::span<const double> v, const MethodOptions& o,
                            double lo, double hi) {
  if (o.orders.size() > 1) throw std::invalid_argument("poly: takes one order");
  if (o.orders.empty()) {
    std::vector<Candidate> candidates = polynomial_candidates(t, v, o.max_poly_order, o.cv_block_c);
    if (candidates.empty()) throw std::invalid_argument("poly: need at least 3 points");
    const int order = order_of(candidates[choose(candidates)]);
    Prepared p = polynomial_of_order(t, v, order, lo, hi,
                                     "order " + std::to_string(order) + " of 0.." +
                                         std::to_string(order_of(candidates.back())) +
                                         " (at least 3 points per coefficient) by " + held_out_name(o.cv_block_c) +
                                         ": " + kOneSeRule);
    p.candidates = std::move(candidates);
    return p;
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
                  fit.condition_number, static_cast<double>(piecewise_dof(spec)), std::move(fitter), {}};
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
    const PiecewiseChoice c = choose_piecewise(t, v, o.search, o.continuity);
    return piecewise_of_spec(t, v, c.spec, Method::piecewise, ShortSegment::reject, lo, hi,
                             "breakpoints and orders by leave-one-out over " + std::to_string(c.candidates) +
                                 " structures (up to " + std::to_string(o.search.max_segments) +
                                 " segments, orders 0.." + std::to_string(o.search.max_order) +
                                 ", at least order + 3 points each): " + kOneSeRule);
  }
  PiecewiseSpec spec;
  spec.breakpoints_c = o.breakpoints_c;
  spec.continuity = o.continuity;
  const std::size_t segments = o.breakpoints_c.size() + 1;
  if (!std::is_sorted(spec.breakpoints_c.begin(), spec.breakpoints_c.end()) ||
      std::adjacent_find(spec.breakpoints_c.begin(), spec.breakpoints_c.end()) != spec.breakpoints_c.end()) {
    throw std::invalid_argument("piecewise: breakpoints must be strictly ascending");
  }
  const auto parts = segment_points(t, v, spec.breakpoints_c);
  std::string choice;
  if (o.orders.empty()) {
    // Each segment's order by the rule, as if the segment stood alone.
    for (std::size_t s = 0; s < segments; ++s) {
      std::vector<Candidate> candidates;
      if (parts[s].first.size() >= 3) candidates = polynomial_candidates(parts[s].first, parts[s].second, o.search.max_order);
      if (candidates.empty()) {
        throw std::invalid_argument("piecewise: segment " + std::to_string(s + 1) + " has " +
                                    std::to_string(parts[s].first.size()) + " points, needs at least 3");
      }
      spec.orders.push_back(order_of(candidates[choose(candidates)]));
    }
    choice = "orders per segment (0.." + std::to_string(o.search.max_order) +
             ", at least 3 points per coefficient): " + kOneSeRule;
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

Prepared prepare_spline(std::span<const double> t, std::span<const double> v, double lo, double hi) {
  Fitter fitter = [](std::span<const double> ft, std::span<const double> fv, double flo, double fhi) {
    return BiasModel::spline(fit_interpolating_spline(ft, fv, flo, fhi));
  };
  return Prepared{BiasModel::spline(fit_interpolating_spline(t, v, lo, hi)), Method::spline,
                  "interpolating cubic, not-a-knot ends, " + std::to_string(t.size()) + " knots", "", 0.0,
                  static_cast<double>(t.size()), std::move(fitter), {}};
}

const char* penalty_name(SmoothingPenalty p) {
  return p == SmoothingPenalty::third_derivative_jumps ? "third-derivative jumps" : "curvature";
}

Prepared prepare_smoothing(std::span<const double> t, std::span<const double> v, const SmoothingOptions& o,
                           double lo, double hi) {
  const SmoothingSplineFit fit = fit_smoothing_spline(t, v, o, lo, hi);
  // Plain LOO folds refit with the chosen effective parameters (lambda's
  // scale depends on the knots, the effective parameters do not).
  SmoothingOptions fixed = o;
  fixed.dof = fit.dof;
  Fitter fitter = [fixed](std::span<const double> ft, std::span<const double> fv, double flo, double fhi) {
    SmoothingOptions fold = fixed;
    fold.dof = std::min(fold.dof, static_cast<double>(ft.size()) - 1e-3);
    return BiasModel::spline(fit_smoothing_spline(ft, fv, fold, flo, fhi).spline);
  };
  char structure[160];
  std::snprintf(structure, sizeof structure, "penalised cubic (%s), %zu knots, %.2f effective parameters",
                penalty_name(o.penalty), t.size(), fit.dof);
  std::string choice;
  if (o.dof == 0.0) {
    choice = "smoothing by " + (o.criterion == SmoothingCriterion::loo ? held_out_name(o.block_c) : std::string("GCV")) +
             " (lambda " + number(fit.lambda) + ")";
  }
  return Prepared{BiasModel::spline(fit.spline), Method::smoothing, structure, std::move(choice), 0.0, fit.dof,
                  std::move(fitter), {}};
}

Prepared prepare_bp(std::span<const double> t, std::span<const double> v, const MethodOptions& o, double lo,
                    double hi) {
  const BpTrainResult r = train_bp_network(t, v, o.bp, lo, hi);
  const BpTrainOptions bp = o.bp;
  Fitter fitter = [bp](std::span<const double> ft, std::span<const double> fv, double flo, double fhi) {
    return BiasModel::bp_network(train_bp_network(ft, fv, bp, flo, fhi).net);
  };
  std::string structure = "hidden " + join(bp.hidden, "x") + " tansig, linear output";
  std::string choice = "Levenberg-Marquardt, seed " + std::to_string(bp.seed) + ", best held-out error of " +
                       std::to_string(bp.restarts) + " trainings, " + std::to_string(r.epochs) +
                       " epochs, stopped by " + r.stop_reason;
  BiasModel model = BiasModel::bp_network(r.net);
  const auto parameters = static_cast<double>(model.parameter_count());
  return Prepared{std::move(model), Method::bp_network, std::move(structure), std::move(choice), 0.0, parameters,
                  std::move(fitter), {}};
}

// auto: the polynomials the points support, the interpolating spline and the
// penalised spline, compared by leave-one-out (closed form for the
// polynomials and, at its chosen smoothing, the penalised spline; refits for
// the interpolating spline) and chosen by the one-standard-error rule.
Prepared prepare_automatic(std::span<const double> t, std::span<const double> v, const MethodOptions& o,
                           double lo, double hi) {
  std::vector<Candidate> candidates = polynomial_candidates(t, v, o.max_poly_order, o.cv_block_c);
  std::optional<Prepared> spline;
  if (t.size() >= 4) {
    spline = prepare_spline(t, v, lo, hi);
    candidates.push_back(candidate("spline", spline->dof, block_residuals(t, v, spline->fitter, o.cv_block_c, 4)));
  }
  SmoothingOptions so = o.smoothing;
  so.dof = 0.0;
  so.block_c = o.cv_block_c;
  const std::size_t smooth_min = so.penalty == SmoothingPenalty::third_derivative_jumps ? 6 : 4;
  if (t.size() >= smooth_min && t.size() <= kMaxSmoothingPoints) {
    const SmoothingSplineFit smooth = fit_smoothing_spline(t, v, so, lo, hi);
    candidates.push_back(candidate("smooth", smooth.dof, smooth.loo_residuals));
  }
  if (candidates.empty()) throw std::invalid_argument("auto: need at least 3 points");
  const std::size_t chosen = choose(candidates);
  const std::string& name = candidates[chosen].name;
  std::string compared;
  for (const Candidate& c : candidates) compared += (compared.empty() ? "" : ", ") + c.name;
  std::string choice = "auto chose " + name + " of " + compared + " by " + held_out_name(o.cv_block_c) + ": " + kOneSeRule;
  Prepared p = name == "spline"   ? std::move(*spline)
               : name == "smooth" ? prepare_smoothing(t, v, so, lo, hi)
                                  : polynomial_of_order(t, v, order_of(candidates[chosen]), lo, hi, "");
  p.choice = std::move(choice);
  p.candidates = std::move(candidates);
  return p;
}

Prepared prepare(std::span<const double> t, std::span<const double> v, const MethodOptions& o, double lo,
                 double hi) {
  switch (o.method) {
    case Method::polynomial: return prepare_polynomial(t, v, o, lo, hi);
    case Method::piecewise: return prepare_piecewise(t, v, o, lo, hi);
    case Method::spline: return prepare_spline(t, v, lo, hi);
    case Method::smoothing: {
      SmoothingOptions so = o.smoothing;
      so.block_c = o.cv_block_c;
      return prepare_smoothing(t, v, so, lo, hi);
    }
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

int supported_polynomial_order(std::size_t points, int max_order) {
  return std::min(max_order, static_cast<int>(points / 3) - 1);
}

std::string_view method_name(Method m) {
  switch (m) {
    case Method::polynomial: return "poly";
    case Method::piecewise: return "piecewise";
    case Method::spline: return "spline";
    case Method::smoothing: return "smooth";
    case Method::bp_network: return "bpnn";
    case Method::paper: return "paper";
    case Method::automatic: return "auto";
  }
  return "unknown";
}

std::optional<Method> parse_method(std::string_view name) {
  for (Method m : {Method::polynomial, Method::piecewise, Method::spline, Method::smoothing, Method::bp_network,
                   Method::paper, Method::automatic}) {
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
                   fit_errors(in_sample, loo), p.condition_number, p.dof, std::move(p.candidates)};
}

bool method_chooses(const MethodOptions& o) {
  switch (o.method) {
    case Method::polynomial:
    case Method::piecewise: return o.orders.empty();
    case Method::smoothing: return o.smoothing.dof == 0.0;
    case Method::automatic: return true;
    case Method::spline:
    case Method::bp_network:
    case Method::paper: return false;
  }
  return true;
}

std::vector<double> nested_loo_residuals(std::span<const double> temp_c, std::span<const double> value,
                                         const MethodOptions& options) {
  check_data(temp_c, value);
  if (!method_chooses(options)) {
    // Nothing to choose: the plain LOO, whose folds refit the structure.
    const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
    return loo_residuals(temp_c, value, prepare(temp_c, value, options, *lo, *hi).fitter);
  }
  return loo_residuals(temp_c, value, [&options](std::span<const double> t, std::span<const double> v,
                                                 double lo, double hi) {
    return prepare(t, v, options, lo, hi).model;
  });
}

}  // namespace gyrotc::fit
