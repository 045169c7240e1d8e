#pragma once

#include <span>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"

namespace gyrotc::fit {

// How neighbouring segments of a piecewise model meet at a breakpoint.
enum class Continuity {
  none,   // fitted independently (the seed's Section 4.2): the model steps at each breakpoint
  value,  // equal values at each breakpoint
  slope,  // equal values and first derivatives at each breakpoint
};

// Structure of a piecewise model: interior breakpoints (ascending) and one
// polynomial order per segment. Segment i fits the points with
// breakpoints_c[i-1] < T <= breakpoints_c[i] (the first one from the lowest
// temperature), the same rule BiasModel uses to evaluate. Joined segments are
// fitted together, as equality-constrained least squares over all segments.
struct PiecewiseSpec {
  std::vector<double> breakpoints_c;
  std::vector<int> orders;
  Continuity continuity = Continuity::value;
};

// The seed's segmentation (Section 4.2): breakpoints -20 and 50 C, orders
// 4/3/4, segments fitted independently.
PiecewiseSpec paper_spec();

// What to do when a segment has fewer than order + 1 points.
enum class ShortSegment {
  reject,       // throw std::invalid_argument
  lower_order,  // fit the highest order the points support (used in LOO folds
                // of a structure that has no point to spare, like the seed's
                // first segment: 5 points for order 4)
};

struct PiecewiseFit {
  Piecewise pw;
  // Largest condition number of the segments' design matrices (of the joint
  // constrained system when joined).
  double condition_number = 0.0;
};

// Least-squares fit of each segment (centred and scaled, by QR). The model's
// range is [t_min_c, t_max_c], or the data's range when t_min_c >= t_max_c.
// Throws std::invalid_argument naming the segment when it cannot be fitted.
PiecewiseFit fit_piecewise(std::span<const double> temp_c, std::span<const double> value,
                           const PiecewiseSpec& spec, ShortSegment short_segment = ShortSegment::reject,
                           double t_min_c = 0.0, double t_max_c = 0.0);

// Number of free parameters of a structure: the coefficients less one
// constraint per breakpoint for continuity of value, two for value and slope.
int piecewise_dof(const PiecewiseSpec& spec);

// Bounds of the automatic search.
struct PiecewiseSearch {
  int max_segments = 3;
  int max_order = 4;
};

struct PiecewiseChoice {
  PiecewiseSpec spec;
  std::vector<double> loo_residuals;  // of the chosen structure, in the input's order
  std::size_t candidates = 0;         // structures compared
};

// Chooses breakpoints and orders by leave-one-out cross-validation with the
// one-standard-error rule (see one_standard_error_choice in
// cross_validation.hpp): every split of the (sorted, distinct) temperatures
// into at most max_segments runs of consecutive points, each run with at least
// order + 3 points, orders 0..max_order, joined as `continuity` says;
// breakpoints sit midway between the neighbouring temperatures. Each
// structure's LOO residuals come in closed form from its hat matrix
// (r_i / (1 - h_ii); a joined fit is least squares in the null space of its
// constraints, so the formula holds). Throws std::invalid_argument when no
// structure fits the points.
PiecewiseChoice choose_piecewise(std::span<const double> temp_c, std::span<const double> value,
                                 const PiecewiseSearch& search = {}, Continuity continuity = Continuity::value);

}  // namespace gyrotc::fit
