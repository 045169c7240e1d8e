#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/algorithms/fit/bp_network_fit.hpp"
#include "gyrotc/algorithms/fit/cross_validation.hpp"
#include "gyrotc/algorithms/fit/piecewise_fit.hpp"
#include "gyrotc/algorithms/fit/spline_fit.hpp"

namespace gyrotc::fit {

// The zero-bias modelling methods of `gyrotc fit`.
enum class Method {
  polynomial,  // one LMS polynomial over the whole range (seed Eq. 14-16)
  piecewise,   // piecewise LMS polynomials (seed Section 4.2), joined by default
  spline,      // interpolating not-a-knot cubic spline: nothing chosen
  smoothing,   // penalised cubic spline, smoothing chosen by cross-validation
  bp_network,  // BP neural network (seed Section 4.1)
  paper,       // the seed's segmentation refitted: breakpoints -20/50 C, orders 4/3/4, independent
  automatic,   // polynomial, spline or smoothing spline by the one-standard-error rule
};

// "poly", "piecewise", "spline", "smooth", "bpnn", "paper", "auto"
std::string_view method_name(Method m);
std::optional<Method> parse_method(std::string_view name);

// The highest polynomial order the points support: at least three points
// per coefficient, (points / 3) - 1, and no more than max_order.
int supported_polynomial_order(std::size_t points, int max_order);

struct MethodOptions {
  Method method = Method::automatic;
  // polynomial: the order (chosen when empty, up to supported_polynomial_order).
  // piecewise: one order for every segment, or one per segment; chosen
  // with the breakpoints when both are empty, per segment when only the
  // breakpoints are given.
  std::vector<int> orders;
  // piecewise: interior breakpoints; chosen with the orders when empty.
  std::vector<double> breakpoints_c;
  Continuity continuity = Continuity::value;  // piecewise
  int max_poly_order = 10;
  // auto, poly and smooth: the held-out residuals that choose the model leave
  // out every point within this many C of the one predicted (0: leave one
  // out); it sets smoothing.block_c.
  double cv_block_c = 0.0;
  PiecewiseSearch search;
  SmoothingOptions smoothing;
  BpTrainOptions bp;
};

// One candidate compared by a CV choice (auto's methods, poly's orders):
// name, effective parameters and its leave-one-out figures.
struct Candidate {
  std::string name;       // e.g. "poly 3", "spline", "smooth"
  CvScore score;          // in the unit of the values (mV^2)
  double loo_max_abs = 0.0;
  bool within_one_se = false;  // LOO mean square within one standard error of the best
  bool chosen = false;
};

struct MethodFit {
  BiasModel model;
  Method method;            // what was fitted (never automatic)
  std::string structure;    // e.g. "orders 3/3/2, breakpoints -7.5, 52.5 C, value-continuous"
  std::string choice;       // for chosen structures: what CV compared and the rule
  FitErrors errors;         // in the unit of the values (mV)
  double condition_number;  // 0 for the splines and the BP network
  double dof;               // effective parameters (penalised fits: tr of the hat matrix)
  std::vector<Candidate> candidates;  // what a CV choice compared (empty when nothing was chosen)
};

// Fits `value` (mV) against temp_c with the chosen method and computes the
// in-sample and leave-one-out errors of the fitted structure (each LOO fold
// refits the same structure; a structure chosen by CV is chosen once, on all
// points, so that LOO is optimistic: see nested_loo_residuals). Throws
// std::invalid_argument with a message for the user when the data cannot
// support the request (too few points for the order, ...).
MethodFit fit_method(std::span<const double> temp_c, std::span<const double> value,
                     const MethodOptions& options);

// Leave-one-out residuals in which every fold repeats the method's whole
// choice on the remaining points (order, breakpoints, smoothing, and for
// automatic the method): an honest estimate of the error at a temperature the
// fit has not seen, also for a structure chosen by cross-validation. For a
// method that chooses nothing it equals the plain LOO.
std::vector<double> nested_loo_residuals(std::span<const double> temp_c, std::span<const double> value,
                                         const MethodOptions& options);

// Whether the method (with these options) chooses anything from the data,
// i.e. whether its nested LOO differs from its plain LOO.
bool method_chooses(const MethodOptions& options);

}  // namespace gyrotc::fit
