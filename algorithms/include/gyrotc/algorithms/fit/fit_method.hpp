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

namespace gyrotc::fit {

// The zero-bias modelling methods of `gyrotc fit`.
enum class Method {
  polynomial,  // one LMS polynomial over the whole range (seed Eq. 14-16)
  piecewise,   // piecewise LMS polynomials (seed Section 4.2)
  bp_network,  // BP neural network (seed Section 4.1)
  paper,       // the seed's segmentation refitted: breakpoints -20/50 C, orders 4/3/4
  automatic,   // polynomial or piecewise, structure chosen by leave-one-out CV
};

std::string_view method_name(Method m);                 // "poly", "piecewise", "bpnn", "paper", "auto"
std::optional<Method> parse_method(std::string_view name);

struct MethodOptions {
  Method method = Method::automatic;
  // polynomial: the order (chosen by LOO over 0..max_poly_order when empty).
  // piecewise: one order for every segment, or one per segment; chosen per
  // segment by LOO when empty.
  std::vector<int> orders;
  // piecewise: interior breakpoints; chosen with the orders by LOO when empty.
  std::vector<double> breakpoints_c;
  bool continuous = false;  // piecewise with given breakpoints only
  int max_poly_order = 10;
  PiecewiseSearch search;
  BpTrainOptions bp;
};

struct MethodFit {
  BiasModel model;
  Method method;            // what was fitted (never automatic)
  std::string structure;    // e.g. "orders 5/5/4, breakpoints -7.5, 52.5 C"
  std::string choice;       // for automatic or chosen structures: what CV compared
  FitErrors errors;         // in the unit of the values (mV)
  double condition_number;  // 0 for the BP network
};

// Fits `value` (mV) against temp_c with the chosen method and computes the
// in-sample and leave-one-out errors of the fitted structure (each LOO fold
// refits the same structure; a structure chosen by CV is chosen once, on all
// points). Throws std::invalid_argument with a message for the user when the
// data cannot support the request (too few points for the order, ...).
MethodFit fit_method(std::span<const double> temp_c, std::span<const double> value,
                     const MethodOptions& options);

// Leave-one-out residuals in which every fold repeats the method's whole
// choice on the remaining points (order, breakpoints, and for automatic the
// method): the honest figure for a structure chosen by cross-validation,
// whose plain LOO is optimistic because the choice has seen every point.
std::vector<double> nested_loo_residuals(std::span<const double> temp_c, std::span<const double> value,
                                         const MethodOptions& options);

}  // namespace gyrotc::fit
