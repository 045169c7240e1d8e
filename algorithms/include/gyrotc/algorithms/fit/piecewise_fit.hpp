#pragma once

#include <span>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"

namespace gyrotc::fit {

// Structure of a piecewise model: interior breakpoints (ascending) and one
// polynomial order per segment. Segment i fits the points with
// breakpoints_c[i-1] < T <= breakpoints_c[i] (the first one from the lowest
// temperature), the same rule BiasModel uses to evaluate.
struct PiecewiseSpec {
  std::vector<double> breakpoints_c;
  std::vector<int> orders;
  // Join neighbouring segments with equal values at each breakpoint
  // (equality-constrained least squares over all segments at once).
  bool continuous = false;
};

// The seed's segmentation (Section 4.2): breakpoints -20 and 50 C, orders 4/3/4.
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
  // constrained system when continuous).
  double condition_number = 0.0;
};

// Least-squares fit of each segment (centred and scaled, by QR). The model's
// range is [t_min_c, t_max_c], or the data's range when t_min_c >= t_max_c.
// Throws std::invalid_argument naming the segment when it cannot be fitted.
PiecewiseFit fit_piecewise(std::span<const double> temp_c, std::span<const double> value,
                        const PiecewiseSpec& spec, ShortSegment short_segment = ShortSegment::reject,
                        double t_min_c = 0.0, double t_max_c = 0.0);

// Bounds of the automatic search.
struct PiecewiseSearch {
  int max_segments = 3;
  int max_order = 5;
};

struct PiecewiseChoice {
  PiecewiseSpec spec;
  double loo_rms = 0.0;  // same unit as the values
};

// Chooses breakpoints and orders by leave-one-out cross-validation: every
// split of the (sorted, distinct) temperatures into at most max_segments runs
// of consecutive points, each run with at least order + 2 points, orders
// 0..max_order; breakpoints sit midway between the neighbouring temperatures.
// Minimises the LOO sum of squares, which is additive over segments, so the
// best order of each candidate segment is found once (closed-form LOO through
// the hat matrix). Discontinuous segments only.
// Throws std::invalid_argument when there are fewer than 2 points.
PiecewiseChoice choose_piecewise(std::span<const double> temp_c, std::span<const double> value,
                                 const PiecewiseSearch& search = {});

}  // namespace gyrotc::fit
