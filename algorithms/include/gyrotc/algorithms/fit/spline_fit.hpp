#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"

namespace gyrotc::fit {

// Interpolating cubic spline through (temp_c, value) with not-a-knot ends
// (the third derivative is continuous at the second and the last but one
// knot), as MATLAB's spline and SciPy's CubicSpline build it by default.
// Nothing is chosen from the data. Two points give the line, three the
// parabola through them. The range is [t_min_c, t_max_c] (the data's when
// t_min_c >= t_max_c); outside the knots the end cubics continue.
// Throws std::invalid_argument for fewer than 2 points, mismatched spans,
// non-finite values or repeated temperatures.
Spline fit_interpolating_spline(std::span<const double> temp_c, std::span<const double> value,
                                double t_min_c = 0.0, double t_max_c = 0.0);

// What the penalised spline's roughness penalty measures.
enum class SmoothingPenalty {
  // Jumps of the third derivative at the knots, sum_k jump_k^2 / hbar_k
  // (hbar_k: mean of the two intervals at knot k), a discrete integral of the
  // squared fourth derivative: the curve shrinks towards one cubic. The
  // fitted curve is the not-a-knot interpolant through the smoothed values,
  // so lambda = 0 gives the interpolating spline and a large lambda the
  // least-squares cubic; a curve that bends at the ends of the range keeps
  // its end curvature.
  third_derivative_jumps,
  // The integral of the squared second derivative: the classical smoothing
  // spline (Reinsch 1967; Green & Silverman 1994, Section 2.3), a natural
  // spline (second derivative 0 at the end knots): the curve shrinks towards
  // a straight line and straightens at the ends of the range; between an end
  // knot and the range end it continues as a straight line (the minimiser's
  // form there), stored as one more knot at the range end.
  curvature,
};

// How the smoothing parameter of a penalised spline is chosen.
enum class SmoothingCriterion {
  // Exact leave-one-out of the linear smoother, the mean of
  // ((y_i - g_i) / (1 - A_ii))^2: the figure `gyrotc fit` reports, each
  // point with its own leverage (a spline's end points have the highest).
  loo,
  // Generalised cross-validation, n |y - A y|^2 / tr(I - A)^2 (Craven &
  // Wahba 1979): leave-one-out with every leverage replaced by the mean one.
  gcv,
};

struct SmoothingOptions {
  SmoothingPenalty penalty = SmoothingPenalty::third_derivative_jumps;
  SmoothingCriterion criterion = SmoothingCriterion::loo;
  // Effective degrees of freedom tr(A) to fit instead of choosing lambda by
  // the criterion (above the penalty's null space, below the points); 0 = choose.
  double dof = 0.0;
  // The penalty weight itself (> 0), instead of dof or the criterion; 0 = not given.
  double lambda = 0.0;
  // loo: each point predicted without every point within this many C of it
  // (held_out_blocks, cross_validation.hpp); 0 = leave one out.
  double block_c = 0.0;
};

struct SmoothingSplineFit {
  Spline spline;
  double lambda = 0.0;     // penalty weight
  double dof = 0.0;        // effective degrees of freedom tr(A): from the penalty's null space
                           // (4: a cubic; 2: a line) up to the number of points (interpolation)
  double criterion = 0.0;  // the criterion's value at lambda (mV^2)
  // Exact leave-one-out residuals at this lambda, (y_i - g_i) / (1 - A_ii), in
  // the order of the input points (with block_c, each point's held-out block's).
  std::vector<double> loo_residuals;
};

// Penalised (smoothing) cubic spline with a knot at every distinct
// temperature: the fitted values g minimise
//   sum (value_i - g_i)^2 + lambda * penalty(g),
// a linear smoother g = A(lambda) y computed through the Demmler-Reinsch basis
// of the penalty (eigenvectors of its matrix K, A = (I + lambda K)^-1), so
// that every lambda costs O(n^2). Unless options.dof fixes it, lambda is the
// criterion's minimum over the whole range from interpolation to the
// penalty's null space (a log grid of 20 points per decade, the smoothest of
// equal values, then golden-section refinement). Needs at least 5 distinct
// temperatures (3 for the curvature penalty) and at most kMaxSmoothingPoints
// (the basis is dense, O(n^3)). Throws std::invalid_argument like
// fit_interpolating_spline.
SmoothingSplineFit fit_smoothing_spline(std::span<const double> temp_c, std::span<const double> value,
                                        const SmoothingOptions& options = {}, double t_min_c = 0.0,
                                        double t_max_c = 0.0);

inline constexpr std::size_t kMaxSmoothingPoints = 500;

}  // namespace gyrotc::fit
